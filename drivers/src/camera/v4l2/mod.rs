//! V4L2 cameras (feature `hardware`): open by a stable /dev/v4l/by-id path,
//! lock every automatic control, stream through mmap buffers, drop stale
//! frames after a change and decode to linear RGB (`super::convert`).
//!
//! Every automatic control (exposure, exposure priority, white balance,
//! focus, gain) is switched off and the manual values applied on every open,
//! because UVC cameras forget them on replug or reboot. Controls a camera
//! does not have are skipped (logged); a control it has but refuses is an
//! error naming it.
//!
//! Boundaries: the device; pixel decoding and the stale-frame rule are
//! `super::convert`'s. Crate choice: `v4l` (mmap streaming, controls); its
//! bindings need libclang at build time, hence the feature.

mod controls;

use crate::camera::convert::{decode_frame, PixelFormat, Response, StaleFrames};
use crate::error::DriverError;
use crate::traits::{monotonic_now, Camera, CameraSettings, Frame};
use std::path::Path;
use std::time::{Duration, Instant};
use v4l::buffer::Type;
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, Format, FourCC};

/// How to open a camera.
#[derive(Debug, Clone, PartialEq)]
pub struct V4l2Config {
    /// Prefer `/dev/v4l/by-id/...`: /dev/videoN numbers change between boots.
    pub path: String,
    pub width: u32,
    pub height: u32,
    /// Formats to ask for, best first; the first the camera accepts wins.
    pub formats: Vec<PixelFormat>,
    /// Streaming buffers (also the least number of frames dropped after a
    /// change).
    pub buffers: u32,
    /// Time after a change before frames count as fresh.
    pub settle: Duration,
    /// The camera's response curve.
    pub response: Response,
    /// Longest wait for one fresh frame.
    pub capture_timeout: Duration,
    pub settings: CameraSettings,
}

impl V4l2Config {
    pub fn new(path: &str, width: u32, height: u32) -> V4l2Config {
        V4l2Config {
            path: path.to_string(),
            width,
            height,
            formats: vec![
                PixelFormat::Yuyv,
                PixelFormat::Mjpg,
                PixelFormat::Rgb24,
                PixelFormat::Grey,
            ],
            buffers: 4,
            settle: Duration::from_millis(150),
            response: Response::Srgb,
            capture_timeout: Duration::from_secs(3),
            settings: CameraSettings::default(),
        }
    }
}

/// An open V4L2 camera with its controls locked.
pub struct V4l2Camera {
    config: V4l2Config,
    // Declared before `device`: the stream unmaps its buffers first.
    stream: Stream<'static>,
    device: Device,
    format: PixelFormat,
    width: u32,
    height: u32,
    stride: usize,
    stale: StaleFrames,
    frames: u64,
}

impl V4l2Camera {
    /// Opens the camera, negotiates the format, locks the controls and
    /// starts streaming.
    pub fn open(config: V4l2Config) -> Result<V4l2Camera, DriverError> {
        let path = config.path.as_str();
        if !path.starts_with("/dev/v4l/by-id/") && !path.starts_with("/dev/v4l/by-path/") {
            tracing::warn!(
                "{path}: not a /dev/v4l/by-id path; the device number may change after a replug"
            );
        }
        let io = |action: &'static str| move |e: std::io::Error| DriverError::io(path, action, e);
        let device = Device::with_path(&config.path).map_err(io("opening the camera"))?;
        let mut chosen = None;
        for &f in &config.formats {
            let want = Format::new(config.width, config.height, FourCC::new(&f.fourcc()));
            let got = device.set_format(&want).map_err(io("setting the format"))?;
            if got.fourcc.repr == f.fourcc()
                && got.width == config.width
                && got.height == config.height
            {
                chosen = Some((f, got));
                break;
            }
        }
        let Some((format, got)) = chosen else {
            let current = device.format().map_err(io("reading the format"))?;
            return Err(DriverError::UnsupportedFormat {
                device: path.to_string(),
                fourcc: format!("{}x{} {}", current.width, current.height, current.fourcc),
                expected: crate::camera::convert::formats::SUPPORTED,
            });
        };
        controls::lock(&device, path, &config.settings)?;
        let mut stream = Stream::with_buffers(&device, Type::VideoCapture, config.buffers.max(1))
            .map_err(io("allocating stream buffers"))?;
        stream.set_timeout(config.capture_timeout);
        let mut stale = StaleFrames::new(config.settle, config.buffers.max(1));
        stale.changed(monotonic_now());
        Ok(V4l2Camera {
            format,
            width: got.width,
            height: got.height,
            stride: got.stride as usize,
            stale,
            frames: 0,
            stream,
            device,
            config,
        })
    }

    /// Closes and opens the camera again (after a replug), re-applying every
    /// control.
    pub fn reopen(&mut self) -> Result<(), DriverError> {
        let config = self.config.clone();
        // The old stream must be gone before the device is opened again.
        *self = V4l2Camera::open(config)?;
        Ok(())
    }

    pub fn format(&self) -> PixelFormat {
        self.format
    }
}

fn lost(path: &str, frames: u64, e: std::io::Error) -> DriverError {
    DriverError::CameraLost {
        device: path.to_string(),
        frames,
        reason: e.to_string(),
    }
}

impl Camera for V4l2Camera {
    fn id(&self) -> &str {
        &self.config.path
    }

    fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    fn lock(&mut self, settings: CameraSettings) -> Result<(), DriverError> {
        controls::lock(&self.device, &self.config.path, &settings)?;
        self.config.settings = settings;
        self.stale.changed(monotonic_now());
        Ok(())
    }

    fn settings(&self) -> CameraSettings {
        self.config.settings
    }

    fn scene_changed(&mut self, at: Duration) {
        self.stale.changed(at);
    }

    fn capture(&mut self) -> Result<Frame, DriverError> {
        let start = Instant::now();
        loop {
            let (bytes, meta) = match self.stream.next() {
                Ok(x) => x,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                    return Err(DriverError::NoFreshFrame {
                        device: self.config.path.clone(),
                        waited: start.elapsed(),
                        dropped: self.stale.dropped(),
                    })
                }
                Err(e) => {
                    let frames = self.frames;
                    return Err(lost(&self.config.path, frames, e));
                }
            };
            let stamp: Duration = meta.timestamp.into();
            let timestamp = if stamp.is_zero() {
                monotonic_now()
            } else {
                stamp
            };
            let used = (meta.bytesused as usize).min(bytes.len());
            let sequence = meta.sequence as u64;
            if !self.stale.accept(timestamp) {
                if start.elapsed() > self.config.capture_timeout {
                    return Err(DriverError::NoFreshFrame {
                        device: self.config.path.clone(),
                        waited: start.elapsed(),
                        dropped: self.stale.dropped(),
                    });
                }
                continue;
            }
            let payload = if self.format == PixelFormat::Mjpg {
                &bytes[..used]
            } else {
                bytes
            };
            let rgb = decode_frame(
                &self.config.path,
                self.format,
                self.width,
                self.height,
                self.stride,
                payload,
                &self.config.response,
            )?;
            self.frames += 1;
            return Ok(Frame {
                rgb,
                timestamp,
                exposure_s: self.config.settings.exposure_s(),
                gain: self.config.settings.gain(),
                sequence,
            });
        }
    }
}

/// The V4L2 capture devices present (`/dev/video*`), for the skip message
/// of hardware tests and for the daemon's device listing.
pub fn video_devices() -> Vec<std::path::PathBuf> {
    let mut found: Vec<_> = std::fs::read_dir(Path::new("/dev"))
        .map(|dir| {
            dir.filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| {
                    p.file_name()
                        .and_then(|n| n.to_str())
                        .is_some_and(|n| n.starts_with("video"))
                })
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn opens_and_captures_from_the_first_camera_or_skips() {
        let devices = video_devices();
        let Some(dev) = devices.first() else {
            eprintln!(
                "skipped: no /dev/video* device on this machine, the V4L2 path is untested here"
            );
            return;
        };
        let path = dev.display().to_string();
        let mut config = V4l2Config::new(&path, 640, 480);
        config.capture_timeout = Duration::from_secs(5);
        let mut cam = match V4l2Camera::open(config) {
            Ok(c) => c,
            Err(DriverError::UnsupportedFormat { .. }) => {
                eprintln!("skipped: {path} offers none of the decoded formats at 640x480");
                return;
            }
            // A node this user may not open (not in the `video` group, a
            // container without the device's permissions) tests nothing.
            Err(DriverError::Io { source, .. })
                if source.kind() == std::io::ErrorKind::PermissionDenied =>
            {
                eprintln!("skipped: {path} exists but this user may not open it ({source})");
                return;
            }
            Err(e) => panic!("{e}"),
        };
        crate::traits::assert_live_captures(&mut cam);
    }

    #[test]
    fn a_missing_camera_names_its_path() {
        let err = V4l2Camera::open(V4l2Config::new(
            "/dev/v4l/by-id/usb-no-such-camera",
            640,
            480,
        ))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(err.contains("/dev/v4l/by-id/usb-no-such-camera"), "{err}");
    }
}
