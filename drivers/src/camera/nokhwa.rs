//! Cameras through `nokhwa` (feature `hardware`): the portable backend for
//! platforms without V4L2 (Media Foundation, AVFoundation) and for cameras
//! the `super::v4l2` driver cannot open. **On Linux prefer `super::v4l2`**:
//! it sets the stream's timeout and buffer count, honours `bytesused` and
//! the row stride, and sees the GREY format nokhwa misspells.
//!
//! Job: open a camera by index or device path, pick a format
//! `super::convert` decodes at the requested size, lock exposure, gain,
//! white balance and focus through nokhwa's camera controls, drop stale
//! frames after a change (the rule of [`StaleFrames`], as in `v4l2`) and
//! decode each frame to linear RGB with [`decode_frame`] through the
//! configured [`Response`].
//!
//! Boundaries: the device through nokhwa only; pixel decoding and the
//! stale-frame rule are `super::convert`'s. A worker thread owns the nokhwa
//! camera (nokhwa's camera is not `Send`, and its `frame()` blocks with no
//! timeout), so [`NokhwaCamera`] is `Send` and a capture gives up after
//! `capture_timeout` instead of hanging on a dead camera.
//!
//! Crate choice: `nokhwa` 0.10 with `input-native` (V4L2 through `v4l` on
//! Linux, Media Foundation on Windows, AVFoundation on macOS), without its
//! decoders: frames are taken raw in their source format.
//!
//! Limits found in nokhwa 0.10.11 / nokhwa-core 0.1.9 /
//! nokhwa-bindings-linux 0.1.4 (read from their source, not from a camera):
//! - Its named controls do not cover UVC exposure: on Linux
//!   `KnownCameraControl::Exposure` is `V4L2_CID_EXPOSURE` (a sensor
//!   control UVC webcams lack), there is no named auto-exposure, autogain,
//!   auto white balance or autofocus control, and `Focus` is
//!   `FOCUS_RELATIVE`. On Linux this module therefore sets the UVC controls
//!   by their raw V4L2 ids through `KnownCameraControl::Other(id)`
//!   (`exposure_auto` = manual, `exposure_time_absolute` in 100 µs, ...),
//!   which nokhwa passes through to `VIDIOC_S_EXT_CTRLS`.
//! - On Windows, nokhwa's `set_camera_control` keeps the control's current
//!   auto/manual flag, so auto exposure cannot be switched off; on macOS
//!   exposure is a mode without a duration. Elsewhere than Linux this
//!   module therefore cannot make exposure manual: `lock` fails with
//!   [`DriverError::Control`] for `exposure_auto` unless
//!   [`NokhwaConfig::allow_auto_exposure`] is set (then it warns). A
//!   radiometric scan with auto exposure is wrong.
//! - Linux streams use `v4l`'s default 4 mmap buffers with no poll timeout
//!   (hence the worker thread), frames are the whole mmap buffer (MJPEG
//!   trailing bytes are ignored by the decoder), rows are assumed tightly
//!   packed (nokhwa gives no stride), and `GREY` cameras are not listed
//!   (nokhwa looks for the fourcc `GRAY`).
//! - nokhwa stamps Linux frames on the wall clock (converted from the
//!   driver's monotonic stamp); this module converts back to the monotonic
//!   clock. Elsewhere the frame is stamped when it is dequeued.
//! - Its `Drop` unwraps `stop_stream()`; that runs on the worker thread,
//!   so a failure there cannot take the daemon down.
//! - NV12 frames are not decoded (`super::convert` has no NV12): a camera
//!   offering only NV12 fails with [`DriverError::UnsupportedFormat`].

use crate::camera::convert::{decode_frame, PixelFormat, Response, StaleFrames};
use crate::error::DriverError;
use crate::traits::{monotonic_now, Camera, CameraSettings, Frame};
use matscan_scan::raster::RgbRaster;
use nokhwa::utils::{
    CameraControl, CameraFormat, CameraIndex, ControlValueDescription, ControlValueSetter,
    FrameFormat, KnownCameraControl, KnownCameraControlFlag, RequestedFormat, RequestedFormatType,
};
use std::path::Path;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// Streaming buffers nokhwa's V4L2 backend allocates (`v4l`'s default):
/// the least number of frames dropped after a change.
pub const NOKHWA_BUFFERS: u32 = 4;

/// Formats this module decodes, for messages.
pub const DECODED: &str = "YUYV, MJPEG, RAWRGB, GRAY, RAWBGR";

/// nokhwa formats in order of preference (the V4L2 driver's order).
const PREFERRED: [FrameFormat; 5] = [
    FrameFormat::YUYV,
    FrameFormat::MJPEG,
    FrameFormat::RAWRGB,
    FrameFormat::GRAY,
    FrameFormat::RAWBGR,
];

/// Which camera: a numeric index, or a device path (`/dev/video0`, a
/// `/dev/v4l/by-id/...` link) resolved to its index on open.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraSelector {
    Index(u32),
    Path(String),
}

impl CameraSelector {
    /// All digits is an index, anything else a path.
    pub fn parse(text: &str) -> CameraSelector {
        let t = text.trim();
        match t.parse::<u32>() {
            Ok(i) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => {
                CameraSelector::Index(i)
            }
            _ => CameraSelector::Path(t.to_string()),
        }
    }

    /// The camera's name in messages and [`Camera::id`].
    pub fn name(&self) -> String {
        match self {
            CameraSelector::Index(i) => format!("nokhwa:{i}"),
            CameraSelector::Path(p) => p.clone(),
        }
    }

    /// The index nokhwa opens: a path is followed through its links to
    /// `/dev/videoN`.
    pub fn resolve(&self) -> Result<u32, DriverError> {
        match self {
            CameraSelector::Index(i) => Ok(*i),
            CameraSelector::Path(p) => {
                let real = std::fs::canonicalize(p)
                    .map_err(|e| DriverError::io(p, "resolving the camera path", e))?;
                index_from_video_path(&real).ok_or_else(|| DriverError::InvalidSetting {
                    device: p.clone(),
                    reason: format!(
                        "resolves to {}, expected a /dev/videoN device",
                        real.display()
                    ),
                })
            }
        }
    }
}

/// `N` of a `/dev/videoN` path.
pub fn index_from_video_path(path: &Path) -> Option<u32> {
    let name = path.file_name()?.to_str()?;
    let digits = name.strip_prefix("video")?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// How to open a camera through nokhwa.
#[derive(Debug, Clone, PartialEq)]
pub struct NokhwaConfig {
    pub index: CameraSelector,
    pub width: u32,
    pub height: u32,
    /// The camera's response curve.
    pub response: Response,
    /// Time after a change before frames count as fresh.
    pub settle: Duration,
    /// Longest wait for one fresh frame (and for a control change).
    pub capture_timeout: Duration,
    pub settings: CameraSettings,
    /// Accept a camera whose exposure cannot be made manual (a warning
    /// instead of an error). Wrong for radiometric scans; off by default.
    pub allow_auto_exposure: bool,
}

impl NokhwaConfig {
    /// The V4L2 driver's defaults: 150 ms settle, sRGB response, 3 s
    /// capture timeout, default settings; auto exposure refused.
    pub fn new(index: CameraSelector, width: u32, height: u32) -> NokhwaConfig {
        NokhwaConfig {
            index,
            width,
            height,
            response: Response::Srgb,
            settle: Duration::from_millis(150),
            capture_timeout: Duration::from_secs(3),
            settings: CameraSettings::default(),
            allow_auto_exposure: false,
        }
    }
}

/// How a nokhwa frame format is decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Source {
    pub format: PixelFormat,
    /// BGR bytes: red and blue are swapped before decoding as RGB24.
    pub swap_red_blue: bool,
}

/// The `super::convert` format of a nokhwa frame format; `None` for NV12.
pub fn pixel_format(format: FrameFormat) -> Option<Source> {
    let plain = |format| {
        Some(Source {
            format,
            swap_red_blue: false,
        })
    };
    match format {
        FrameFormat::YUYV => plain(PixelFormat::Yuyv),
        FrameFormat::MJPEG => plain(PixelFormat::Mjpg),
        FrameFormat::GRAY => plain(PixelFormat::Grey),
        FrameFormat::RAWRGB => plain(PixelFormat::Rgb24),
        FrameFormat::RAWBGR => Some(Source {
            format: PixelFormat::Rgb24,
            swap_red_blue: true,
        }),
        FrameFormat::NV12 => None,
    }
}

/// The best offered format at exactly `width`x`height`: first by
/// [`PREFERRED`] order, then the highest frame rate.
pub fn choose_format(offered: &[CameraFormat], width: u32, height: u32) -> Option<CameraFormat> {
    PREFERRED.iter().find_map(|&want| {
        offered
            .iter()
            .filter(|f| f.format() == want && f.width() == width && f.height() == height)
            .max_by_key(|f| f.frame_rate())
            .copied()
    })
}

/// V4L2 absolute exposure, in units of 100 µs (at least 1).
pub fn exposure_units(exposure_s: f32) -> i64 {
    ((exposure_s as f64 * 10_000.0).round() as i64).max(1)
}

/// The camera's gain value for a linear `gain` (1 = the control's minimum,
/// or 1 when the minimum is 0), clamped to its range (the V4L2 driver's
/// rule).
pub fn gain_value(gain: f32, min: i64, max: i64) -> i64 {
    let base = min.max(1) as f64;
    ((base * gain as f64).round() as i64).clamp(min, max.max(min))
}

/// Raw V4L2 control ids (`linux/v4l2-controls.h`), set through
/// `KnownCameraControl::Other` because nokhwa names none of them.
mod cid {
    pub const AUTO_WHITE_BALANCE: u32 = 0x0098_090c;
    pub const AUTOGAIN: u32 = 0x0098_0912;
    pub const GAIN: u32 = 0x0098_0913;
    pub const WHITE_BALANCE_TEMPERATURE: u32 = 0x0098_091a;
    pub const EXPOSURE_AUTO: u32 = 0x009a_0901;
    pub const EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
    pub const EXPOSURE_AUTO_PRIORITY: u32 = 0x009a_0903;
    pub const FOCUS_AUTO: u32 = 0x009a_090c;
    /// `V4L2_EXPOSURE_MANUAL` of the exposure-auto menu.
    pub const EXPOSURE_MANUAL: i64 = 1;
}

/// The nokhwa control of a V4L2 id as nokhwa's Linux backend lists it
/// (its named controls for the ids it maps, `Other` for the rest).
pub fn v4l2_control(id: u32) -> KnownCameraControl {
    match id {
        cid::GAIN => KnownCameraControl::Gain,
        cid::WHITE_BALANCE_TEMPERATURE => KnownCameraControl::WhiteBalance,
        other => KnownCameraControl::Other(other as u128),
    }
}

/// One control write.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    pub name: &'static str,
    pub control: KnownCameraControl,
    pub value: ControlValueSetter,
}

/// The control writes that lock `settings`, and warnings to log.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LockPlan {
    pub steps: Vec<Step>,
    pub warnings: Vec<String>,
}

/// Plans the lock on a V4L2 camera (nokhwa's Linux backend) from the
/// controls it lists: automatic controls off first, then the manual
/// values, as the `v4l2` driver does. Controls the camera lacks are skipped,
/// except that exposure must become manual (both `exposure_auto` and
/// `exposure_time_absolute` present) unless `allow_auto_exposure`. A value
/// outside the control's range is an error naming it.
pub fn plan_v4l2_lock(
    device: &str,
    settings: &CameraSettings,
    present: &[CameraControl],
    allow_auto_exposure: bool,
) -> Result<LockPlan, DriverError> {
    let find = |id: u32| present.iter().find(|c| c.control() == v4l2_control(id));
    let control_err = |control: &'static str, reason: String| DriverError::Control {
        device: device.to_string(),
        control,
        reason,
    };
    let mut plan = LockPlan::default();
    let exposure_manual =
        find(cid::EXPOSURE_AUTO).is_some() && find(cid::EXPOSURE_ABSOLUTE).is_some();
    if !exposure_manual {
        let reason = "the camera lists no exposure_auto and exposure_time_absolute controls \
                      nokhwa can set, so exposure may stay automatic"
            .to_string();
        if !allow_auto_exposure {
            return Err(control_err("exposure_auto", reason));
        }
        plan.warnings.push(format!(
            "{device}: {reason} (allowed by allow_auto_exposure)"
        ));
    }
    let gain = find(cid::GAIN).map(|c| match c.description() {
        ControlValueDescription::IntegerRange { min, max, .. } => {
            gain_value(settings.gain(), *min, *max)
        }
        _ => settings.gain().round() as i64,
    });
    let wanted: [(u32, &'static str, Option<i64>); 8] = [
        (
            cid::EXPOSURE_AUTO,
            "exposure_auto",
            Some(cid::EXPOSURE_MANUAL),
        ),
        (
            cid::EXPOSURE_AUTO_PRIORITY,
            "exposure_auto_priority",
            Some(0),
        ),
        (cid::AUTO_WHITE_BALANCE, "white_balance_automatic", Some(0)),
        (cid::FOCUS_AUTO, "focus_automatic_continuous", Some(0)),
        (cid::AUTOGAIN, "gain_automatic", Some(0)),
        (
            cid::EXPOSURE_ABSOLUTE,
            "exposure_time_absolute",
            Some(exposure_units(settings.exposure_s())),
        ),
        (
            cid::WHITE_BALANCE_TEMPERATURE,
            "white_balance_temperature",
            Some(settings.white_balance_k() as i64),
        ),
        (cid::GAIN, "gain", gain),
    ];
    for (id, name, value) in wanted {
        let (Some(control), Some(value)) = (find(id), value) else {
            tracing::debug!("{device}: no control `{name}`; skipped");
            continue;
        };
        if control.flag().contains(&KnownCameraControlFlag::ReadOnly) {
            return Err(control_err(name, "the camera reports it read-only".into()));
        }
        let setter = match control.description() {
            ControlValueDescription::Boolean { .. } => ControlValueSetter::Boolean(value != 0),
            ControlValueDescription::IntegerRange { min, max, .. } => {
                if value < *min || value > *max {
                    return Err(control_err(
                        name,
                        format!("{value} is outside the camera's range {min}..={max}"),
                    ));
                }
                ControlValueSetter::Integer(value)
            }
            ControlValueDescription::Integer { .. } => ControlValueSetter::Integer(value),
            other => {
                return Err(control_err(
                    name,
                    format!("expected an integer or boolean control, nokhwa lists {other:?}"),
                ))
            }
        };
        plan.steps.push(Step {
            name,
            control: control.control(),
            value: setter,
        });
    }
    Ok(plan)
}

/// Plans the lock where nokhwa cannot make exposure manual (Media
/// Foundation keeps the current auto flag; AVFoundation has no exposure
/// duration): an error for `exposure_auto` unless `allow_auto_exposure`,
/// and then no writes at all (gain and white balance values would be in
/// platform units this module does not know), only warnings.
pub fn plan_portable_lock(
    device: &str,
    allow_auto_exposure: bool,
) -> Result<LockPlan, DriverError> {
    let reason = "nokhwa cannot switch exposure to manual on this platform".to_string();
    if !allow_auto_exposure {
        return Err(DriverError::Control {
            device: device.to_string(),
            control: "exposure_auto",
            reason,
        });
    }
    Ok(LockPlan {
        steps: Vec::new(),
        warnings: vec![format!(
            "{device}: {reason}; exposure, gain, white balance and focus stay automatic \
             (allowed by allow_auto_exposure)"
        )],
    })
}

/// A frame stamped on the wall clock at `wall`, moved to the monotonic
/// clock given both clocks now; `None` if it is in the future or older
/// than `max_age`.
pub fn wall_to_monotonic(
    wall: Duration,
    wall_now: Duration,
    mono_now: Duration,
    max_age: Duration,
) -> Option<Duration> {
    let age = wall_now.checked_sub(wall)?;
    (age <= max_age)
        .then(|| mono_now.checked_sub(age))
        .flatten()
}

/// A frame as the worker hands it over.
struct Raw {
    bytes: Vec<u8>,
    format: FrameFormat,
    timestamp: Duration,
}

enum Command {
    Lock(CameraSettings),
    Grab,
}

enum Reply {
    Opened(Result<CameraFormat, DriverError>),
    Locked(Result<(), DriverError>),
    Frame(Result<Raw, DriverError>),
}

/// An open nokhwa camera with its controls locked (as far as nokhwa can).
pub struct NokhwaCamera {
    config: NokhwaConfig,
    name: String,
    format: CameraFormat,
    stale: StaleFrames,
    /// Frames returned by `capture`.
    frames: u64,
    /// Frames received from nokhwa, stale ones included (the sequence).
    grabbed: u64,
    commands: Option<Sender<Command>>,
    replies: Receiver<Reply>,
    /// A `Grab` was sent and its frame has not come back yet.
    grabbing: bool,
    worker: Option<JoinHandle<()>>,
}

impl NokhwaCamera {
    /// Opens the camera, picks a decodable format at the configured size,
    /// locks the controls and starts streaming.
    pub fn open(config: NokhwaConfig) -> Result<NokhwaCamera, DriverError> {
        let name = config.index.name();
        if let CameraSelector::Path(p) = &config.index {
            if !p.starts_with("/dev/v4l/by-id/") && !p.starts_with("/dev/v4l/by-path/") {
                tracing::warn!(
                    "{p}: not a /dev/v4l/by-id path; the device number may change after a replug"
                );
            }
        }
        let index = config.index.resolve()?;
        let (cmd_tx, cmd_rx) = mpsc::channel();
        let (reply_tx, reply_rx) = mpsc::channel();
        let worker = {
            let (thread_name, thread_config) = (name.clone(), config.clone());
            std::thread::Builder::new()
                .name(format!("nokhwa {name}"))
                .spawn(move || worker(index, &thread_name, &thread_config, cmd_rx, reply_tx))
                .map_err(|e| DriverError::io(&name, "starting the camera thread", e))?
        };
        let wait = config.capture_timeout.max(Duration::from_secs(10));
        let format = match reply_rx.recv_timeout(wait) {
            Ok(Reply::Opened(r)) => r?,
            Ok(_) => unreachable!("the worker answers Opened first"),
            Err(RecvTimeoutError::Timeout) => {
                return Err(DriverError::io(
                    &name,
                    "opening the camera",
                    std::io::Error::new(
                        std::io::ErrorKind::TimedOut,
                        format!("nokhwa did not open it within {wait:?}"),
                    ),
                ))
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(DriverError::io(
                    &name,
                    "opening the camera",
                    std::io::Error::other("the camera thread stopped"),
                ))
            }
        };
        let mut stale = StaleFrames::new(config.settle, NOKHWA_BUFFERS);
        stale.changed(monotonic_now());
        Ok(NokhwaCamera {
            config,
            name,
            format,
            stale,
            frames: 0,
            grabbed: 0,
            commands: Some(cmd_tx),
            replies: reply_rx,
            grabbing: false,
            worker: Some(worker),
        })
    }

    /// The format nokhwa streams.
    pub fn frame_format(&self) -> FrameFormat {
        self.format.format()
    }

    /// The stream's frame rate.
    pub fn frame_rate(&self) -> u32 {
        self.format.frame_rate()
    }

    fn send(&self, command: Command) -> Result<(), DriverError> {
        let lost = || self.lost("the camera thread stopped".into());
        self.commands
            .as_ref()
            .ok_or_else(lost)?
            .send(command)
            .map_err(|_| lost())
    }

    fn lost(&self, reason: String) -> DriverError {
        DriverError::CameraLost {
            device: self.name.clone(),
            frames: self.frames,
            reason,
        }
    }

    fn no_fresh_frame(&self, start: Instant) -> DriverError {
        DriverError::NoFreshFrame {
            device: self.name.clone(),
            waited: start.elapsed(),
            dropped: self.stale.dropped(),
        }
    }

    fn decode(&self, raw: Raw) -> Result<Frame, DriverError> {
        let rgb = decode_raw(
            &self.name,
            raw.format,
            self.format.width(),
            self.format.height(),
            raw.bytes,
            &self.config.response,
        )?;
        Ok(Frame {
            rgb,
            timestamp: raw.timestamp,
            exposure_s: self.config.settings.exposure_s(),
            gain: self.config.settings.gain(),
            // Counts stale frames too, so gaps show the frames dropped.
            sequence: self.grabbed.saturating_sub(1),
        })
    }
}

/// One nokhwa frame (tightly packed rows) as linear RGB through
/// [`decode_frame`]; BGR is reordered to RGB first, NV12 is
/// [`DriverError::UnsupportedFormat`] naming `device`.
pub fn decode_raw(
    device: &str,
    format: FrameFormat,
    width: u32,
    height: u32,
    mut bytes: Vec<u8>,
    response: &Response,
) -> Result<RgbRaster, DriverError> {
    let source = pixel_format(format).ok_or_else(|| DriverError::UnsupportedFormat {
        device: device.to_string(),
        fourcc: format.to_string(),
        expected: DECODED,
    })?;
    if source.swap_red_blue {
        bytes.chunks_exact_mut(3).for_each(|p| p.swap(0, 2));
    }
    decode_frame(device, source.format, width, height, 0, &bytes, response)
}

impl Camera for NokhwaCamera {
    fn id(&self) -> &str {
        &self.name
    }

    fn resolution(&self) -> (u32, u32) {
        (self.format.width(), self.format.height())
    }

    fn lock(&mut self, settings: CameraSettings) -> Result<(), DriverError> {
        self.send(Command::Lock(settings))?;
        let start = Instant::now();
        loop {
            let left = self.config.capture_timeout.saturating_sub(start.elapsed());
            match self.replies.recv_timeout(left) {
                Ok(Reply::Locked(r)) => {
                    r?;
                    break;
                }
                // A frame grabbed before the lock is stale anyway.
                Ok(Reply::Frame(r)) => {
                    self.grabbing = false;
                    self.grabbed += u64::from(r.is_ok());
                }
                Ok(Reply::Opened(_)) => {}
                Err(RecvTimeoutError::Timeout) => {
                    return Err(DriverError::Control {
                        device: self.name.clone(),
                        control: "all",
                        reason: format!(
                            "the camera did not answer within {:?}",
                            self.config.capture_timeout
                        ),
                    })
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(self.lost("the camera thread stopped".into()))
                }
            }
        }
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
            if !self.grabbing {
                self.send(Command::Grab)?;
                self.grabbing = true;
            }
            let left = self.config.capture_timeout.saturating_sub(start.elapsed());
            let raw = match self.replies.recv_timeout(left) {
                Ok(Reply::Frame(r)) => {
                    self.grabbing = false;
                    match r {
                        Ok(raw) => {
                            self.grabbed += 1;
                            raw
                        }
                        Err(DriverError::CameraLost { reason, .. }) => {
                            return Err(self.lost(reason))
                        }
                        Err(e) => return Err(e),
                    }
                }
                Ok(_) => continue,
                Err(RecvTimeoutError::Timeout) => return Err(self.no_fresh_frame(start)),
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(self.lost("the camera thread stopped".into()))
                }
            };
            if !self.stale.accept(raw.timestamp) {
                if start.elapsed() > self.config.capture_timeout {
                    return Err(self.no_fresh_frame(start));
                }
                continue;
            }
            let frame = self.decode(raw)?;
            self.frames += 1;
            return Ok(frame);
        }
    }
}

impl Drop for NokhwaCamera {
    fn drop(&mut self) {
        // Closing the command channel ends the worker, which drops the
        // nokhwa camera (closing the device) and then its reply sender.
        self.commands = None;
        let deadline = Instant::now() + self.config.capture_timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.replies.recv_timeout(left) {
                Ok(_) => continue,
                Err(RecvTimeoutError::Disconnected) => {
                    if let Some(w) = self.worker.take() {
                        let _ = w.join();
                    }
                    return;
                }
                Err(RecvTimeoutError::Timeout) => {
                    tracing::warn!(
                        "{}: the camera thread is stuck in nokhwa; leaving it behind",
                        self.name
                    );
                    return;
                }
            }
        }
    }
}

fn nokhwa_io(device: &str, action: &'static str, e: nokhwa::NokhwaError) -> DriverError {
    DriverError::io(device, action, std::io::Error::other(e.to_string()))
}

/// The worker thread: owns the nokhwa camera for its whole life.
fn worker(
    index: u32,
    name: &str,
    config: &NokhwaConfig,
    commands: Receiver<Command>,
    replies: Sender<Reply>,
) {
    let mut camera = match open_nokhwa(index, name, config) {
        Ok((camera, format)) => {
            if replies.send(Reply::Opened(Ok(format))).is_err() {
                return;
            }
            camera
        }
        Err(e) => {
            let _ = replies.send(Reply::Opened(Err(e)));
            return;
        }
    };
    while let Ok(command) = commands.recv() {
        let reply = match command {
            Command::Lock(settings) => Reply::Locked(lock_controls(
                &mut camera,
                name,
                &settings,
                config.allow_auto_exposure,
            )),
            Command::Grab => Reply::Frame(grab(&mut camera, name)),
        };
        if replies.send(reply).is_err() {
            return;
        }
    }
}

fn open_nokhwa(
    index: u32,
    name: &str,
    config: &NokhwaConfig,
) -> Result<(nokhwa::Camera, CameraFormat), DriverError> {
    let any = RequestedFormat::with_formats(RequestedFormatType::None, &PREFERRED);
    let mut camera = nokhwa::Camera::new(CameraIndex::Index(index), any)
        .map_err(|e| nokhwa_io(name, "opening the camera", e))?;
    let offered = camera
        .compatible_camera_formats()
        .map_err(|e| nokhwa_io(name, "listing the camera formats", e))?;
    let Some(chosen) = choose_format(&offered, config.width, config.height) else {
        let mut listed: Vec<String> = offered
            .iter()
            .map(|f| format!("{}x{} {}", f.width(), f.height(), f.format()))
            .collect();
        listed.sort();
        listed.dedup();
        return Err(DriverError::UnsupportedFormat {
            device: name.to_string(),
            fourcc: format!(
                "none at {}x{} (offered: {})",
                config.width,
                config.height,
                listed.join(", ")
            ),
            expected: DECODED,
        });
    };
    let exact = [chosen.format()];
    camera
        .set_camera_requset(RequestedFormat::with_formats(
            RequestedFormatType::Exact(chosen),
            &exact,
        ))
        .map_err(|e| nokhwa_io(name, "setting the format", e))?;
    lock_controls(
        &mut camera,
        name,
        &config.settings,
        config.allow_auto_exposure,
    )?;
    camera
        .open_stream()
        .map_err(|e| nokhwa_io(name, "starting the stream", e))?;
    Ok((camera, chosen))
}

fn lock_controls(
    camera: &mut nokhwa::Camera,
    name: &str,
    settings: &CameraSettings,
    allow_auto_exposure: bool,
) -> Result<(), DriverError> {
    let plan = if cfg!(target_os = "linux") {
        let present = camera
            .camera_controls()
            .map_err(|e| nokhwa_io(name, "listing the camera controls", e))?;
        plan_v4l2_lock(name, settings, &present, allow_auto_exposure)?
    } else {
        plan_portable_lock(name, allow_auto_exposure)?
    };
    for warning in &plan.warnings {
        tracing::warn!("{warning}");
    }
    for step in plan.steps {
        camera
            .set_camera_control(step.control, step.value.clone())
            .map_err(|e| {
                let now = camera
                    .camera_control(step.control)
                    .map(|c| format!("{:?}", c.value()))
                    .unwrap_or_else(|_| "unreadable".into());
                DriverError::Control {
                    device: name.to_string(),
                    control: step.name,
                    reason: format!("setting {:?} failed ({e}); it reads {now}", step.value),
                }
            })?;
    }
    Ok(())
}

fn grab(camera: &mut nokhwa::Camera, name: &str) -> Result<Raw, DriverError> {
    let buffer = camera.frame().map_err(|e| DriverError::CameraLost {
        device: name.to_string(),
        frames: 0,
        reason: e.to_string(),
    })?;
    let mono_now = monotonic_now();
    let stamped = if cfg!(target_os = "linux") {
        let wall_now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default();
        buffer
            .capture_timestamp()
            .and_then(|wall| wall_to_monotonic(wall, wall_now, mono_now, Duration::from_secs(10)))
    } else {
        None
    };
    Ok(Raw {
        bytes: buffer.buffer().to_vec(),
        format: buffer.source_frame_format(),
        timestamp: stamped.unwrap_or(mono_now),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn range(control: KnownCameraControl, min: i64, max: i64) -> CameraControl {
        CameraControl::new(
            control,
            format!("{control:?}"),
            ControlValueDescription::IntegerRange {
                min,
                max,
                value: min,
                step: 1,
                default: min,
            },
            vec![],
            true,
        )
    }

    fn boolean(control: KnownCameraControl) -> CameraControl {
        CameraControl::new(
            control,
            format!("{control:?}"),
            ControlValueDescription::Boolean {
                value: true,
                default: true,
            },
            vec![],
            true,
        )
    }

    /// A typical UVC webcam as nokhwa's Linux backend lists it.
    fn webcam() -> Vec<CameraControl> {
        vec![
            range(v4l2_control(cid::EXPOSURE_AUTO), 0, 3),
            boolean(v4l2_control(cid::EXPOSURE_AUTO_PRIORITY)),
            boolean(v4l2_control(cid::AUTO_WHITE_BALANCE)),
            range(v4l2_control(cid::EXPOSURE_ABSOLUTE), 3, 2047),
            range(KnownCameraControl::WhiteBalance, 2800, 6500),
            range(KnownCameraControl::Gain, 0, 255),
            range(KnownCameraControl::Brightness, -64, 64),
        ]
    }

    #[test]
    fn selectors_parse_indices_and_paths() {
        assert_eq!(CameraSelector::parse("0"), CameraSelector::Index(0));
        assert_eq!(CameraSelector::parse(" 12 "), CameraSelector::Index(12));
        assert_eq!(
            CameraSelector::parse("/dev/video2"),
            CameraSelector::Path("/dev/video2".into())
        );
        assert_eq!(
            CameraSelector::parse("+1"),
            CameraSelector::Path("+1".into())
        );
        assert_eq!(CameraSelector::Index(3).name(), "nokhwa:3");
        assert_eq!(index_from_video_path(Path::new("/dev/video10")), Some(10));
        assert_eq!(index_from_video_path(Path::new("/dev/video")), None);
        assert_eq!(index_from_video_path(Path::new("/dev/videoX1")), None);
        assert_eq!(index_from_video_path(Path::new("/dev/media0")), None);
    }

    #[test]
    fn a_missing_path_names_itself() {
        let err = CameraSelector::parse("/dev/v4l/by-id/usb-no-such-camera")
            .resolve()
            .unwrap_err()
            .to_string();
        assert!(err.contains("/dev/v4l/by-id/usb-no-such-camera"), "{err}");
        let err = NokhwaCamera::open(NokhwaConfig::new(
            CameraSelector::parse("/dev/v4l/by-id/usb-no-such-camera"),
            640,
            480,
        ))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(err.contains("usb-no-such-camera"), "{err}");
    }

    #[test]
    fn a_path_that_is_not_a_video_device_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("camera");
        std::fs::write(&file, b"").unwrap();
        let sel = CameraSelector::Path(file.display().to_string());
        match sel.resolve() {
            Err(DriverError::InvalidSetting { device, reason }) => {
                assert!(device.ends_with("camera"));
                assert!(reason.contains("/dev/videoN"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn formats_map_to_the_decoders() {
        assert_eq!(
            pixel_format(FrameFormat::YUYV).unwrap().format,
            PixelFormat::Yuyv
        );
        assert_eq!(
            pixel_format(FrameFormat::MJPEG).unwrap().format,
            PixelFormat::Mjpg
        );
        assert_eq!(
            pixel_format(FrameFormat::GRAY).unwrap().format,
            PixelFormat::Grey
        );
        let rgb = pixel_format(FrameFormat::RAWRGB).unwrap();
        assert_eq!((rgb.format, rgb.swap_red_blue), (PixelFormat::Rgb24, false));
        let bgr = pixel_format(FrameFormat::RAWBGR).unwrap();
        assert_eq!((bgr.format, bgr.swap_red_blue), (PixelFormat::Rgb24, true));
        assert_eq!(pixel_format(FrameFormat::NV12), None);
        for f in PREFERRED {
            assert!(
                pixel_format(f).is_some(),
                "{f:?} is preferred but not decoded"
            );
        }
    }

    #[test]
    fn raw_frames_decode_through_convert() {
        let lin = Response::Linear;
        // One BGR pixel (blue 255, red 0) decodes as blue.
        let rgb = decode_raw("cam", FrameFormat::RAWBGR, 1, 1, vec![255, 0, 0], &lin).unwrap();
        assert_eq!(rgb.data, vec![[0.0, 0.0, 1.0]]);
        let rgb = decode_raw("cam", FrameFormat::RAWRGB, 1, 1, vec![255, 0, 0], &lin).unwrap();
        assert_eq!(rgb.data, vec![[1.0, 0.0, 0.0]]);
        let rgb = decode_raw("cam", FrameFormat::GRAY, 2, 1, vec![0, 255], &lin).unwrap();
        assert_eq!(rgb.data, vec![[0.0; 3], [1.0; 3]]);
        match decode_raw("/dev/video4", FrameFormat::NV12, 2, 2, vec![0; 6], &lin) {
            Err(DriverError::UnsupportedFormat { device, fourcc, .. }) => {
                assert_eq!(device, "/dev/video4");
                assert!(fourcc.contains("NV12"), "{fourcc}");
            }
            other => panic!("{other:?}"),
        }
        // A short YUYV buffer is a size error naming the device.
        let err = decode_raw("/dev/video4", FrameFormat::YUYV, 4, 2, vec![0; 8], &lin).unwrap_err();
        assert!(matches!(err, DriverError::FrameSize { .. }), "{err}");
        assert!(err.to_string().contains("/dev/video4"));
    }

    #[test]
    fn the_preferred_format_at_the_exact_size_wins() {
        let f = |w, h, ff, fps| CameraFormat::new_from(w, h, ff, fps);
        let offered = [
            f(1280, 720, FrameFormat::MJPEG, 30),
            f(640, 480, FrameFormat::MJPEG, 30),
            f(640, 480, FrameFormat::YUYV, 15),
            f(640, 480, FrameFormat::YUYV, 30),
            f(640, 480, FrameFormat::NV12, 60),
        ];
        assert_eq!(
            choose_format(&offered, 640, 480),
            Some(f(640, 480, FrameFormat::YUYV, 30))
        );
        assert_eq!(
            choose_format(&offered, 1280, 720),
            Some(f(1280, 720, FrameFormat::MJPEG, 30))
        );
        assert_eq!(choose_format(&offered, 800, 600), None);
        assert_eq!(
            choose_format(&[f(640, 480, FrameFormat::NV12, 30)], 640, 480),
            None
        );
    }

    #[test]
    fn control_values_convert_like_the_v4l2_driver() {
        assert_eq!(exposure_units(0.02), 200);
        assert_eq!(exposure_units(0.000_01), 1);
        assert_eq!(exposure_units(1.0 / 30.0), 333);
        assert_eq!(gain_value(1.0, 0, 255), 1);
        assert_eq!(gain_value(2.0, 16, 255), 32);
        assert_eq!(gain_value(100.0, 16, 255), 255);
        assert_eq!(gain_value(1.0, 16, 255), 16);
    }

    #[test]
    fn a_webcam_lock_turns_automatics_off_before_the_values() {
        let settings = CameraSettings::new(0.02, 2.0, 5000).unwrap();
        let plan = plan_v4l2_lock("cam", &settings, &webcam(), false).unwrap();
        let names: Vec<_> = plan.steps.iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            [
                "exposure_auto",
                "exposure_auto_priority",
                "white_balance_automatic",
                "exposure_time_absolute",
                "white_balance_temperature",
                "gain"
            ]
        );
        let value = |name: &str| {
            plan.steps
                .iter()
                .find(|s| s.name == name)
                .map(|s| (s.control, s.value.clone()))
                .unwrap()
        };
        assert_eq!(
            value("exposure_auto"),
            (
                KnownCameraControl::Other(0x009a_0901),
                ControlValueSetter::Integer(1)
            )
        );
        assert_eq!(
            value("white_balance_automatic").1,
            ControlValueSetter::Boolean(false)
        );
        assert_eq!(
            value("exposure_time_absolute").1,
            ControlValueSetter::Integer(200)
        );
        assert_eq!(
            value("white_balance_temperature"),
            (
                KnownCameraControl::WhiteBalance,
                ControlValueSetter::Integer(5000)
            )
        );
        assert_eq!(
            value("gain"),
            (KnownCameraControl::Gain, ControlValueSetter::Integer(2))
        );
        assert!(plan.warnings.is_empty());
    }

    #[test]
    fn exposure_that_cannot_be_manual_is_an_error_unless_allowed() {
        let settings = CameraSettings::default();
        let no_auto: Vec<_> = webcam()
            .into_iter()
            .filter(|c| c.control() != v4l2_control(cid::EXPOSURE_AUTO))
            .collect();
        match plan_v4l2_lock("/dev/video7", &settings, &no_auto, false) {
            Err(DriverError::Control {
                device, control, ..
            }) => {
                assert_eq!(device, "/dev/video7");
                assert_eq!(control, "exposure_auto");
            }
            other => panic!("{other:?}"),
        }
        let plan = plan_v4l2_lock("/dev/video7", &settings, &no_auto, true).unwrap();
        assert_eq!(plan.warnings.len(), 1);
        assert!(plan.warnings[0].contains("/dev/video7"));
        assert!(plan.steps.iter().all(|s| s.name != "exposure_auto"));

        assert!(matches!(
            plan_portable_lock("cam", false),
            Err(DriverError::Control {
                control: "exposure_auto",
                ..
            })
        ));
        let plan = plan_portable_lock("cam", true).unwrap();
        assert!(plan.steps.is_empty() && plan.warnings.len() == 1);
    }

    #[test]
    fn out_of_range_values_name_the_control() {
        // 1 s is 10000 units, beyond this webcam's 2047.
        let settings = CameraSettings::new(1.0, 1.0, 5000).unwrap();
        let err = plan_v4l2_lock("cam", &settings, &webcam(), false).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("exposure_time_absolute"), "{text}");
        assert!(text.contains("3..=2047"), "{text}");
        // 9000 K is beyond the white balance range.
        let settings = CameraSettings::new(0.02, 1.0, 9000).unwrap();
        let text = plan_v4l2_lock("cam", &settings, &webcam(), false)
            .unwrap_err()
            .to_string();
        assert!(text.contains("white_balance_temperature"), "{text}");
    }

    #[test]
    fn read_only_controls_are_refused() {
        let mut controls = webcam();
        controls[3] = CameraControl::new(
            v4l2_control(cid::EXPOSURE_ABSOLUTE),
            "exposure".into(),
            ControlValueDescription::IntegerRange {
                min: 1,
                max: 5000,
                value: 1,
                step: 1,
                default: 1,
            },
            vec![KnownCameraControlFlag::ReadOnly],
            true,
        );
        let err = plan_v4l2_lock("cam", &CameraSettings::default(), &controls, false).unwrap_err();
        assert!(err.to_string().contains("exposure_time_absolute"), "{err}");
    }

    #[test]
    fn wall_stamps_move_to_the_monotonic_clock() {
        let s = Duration::from_secs;
        let ms = Duration::from_millis;
        assert_eq!(
            wall_to_monotonic(s(1_000_000) - ms(30), s(1_000_000), s(500), s(10)),
            Some(s(500) - ms(30))
        );
        assert_eq!(
            wall_to_monotonic(s(1_000_001), s(1_000_000), s(500), s(10)),
            None
        );
        assert_eq!(
            wall_to_monotonic(s(999_000), s(1_000_000), s(500), s(10)),
            None
        );
        assert_eq!(
            wall_to_monotonic(s(999_999), s(1_000_000), ms(500), s(10)),
            None
        );
    }

    #[test]
    fn opens_and_captures_from_dev_video0_or_skips() {
        let path = "/dev/video0";
        if !Path::new(path).exists() {
            eprintln!("skipped: no camera at /dev/video0");
            return;
        }
        let mut config = NokhwaConfig::new(CameraSelector::parse(path), 640, 480);
        config.capture_timeout = Duration::from_secs(5);
        config.allow_auto_exposure = true;
        let mut cam = match NokhwaCamera::open(config) {
            Ok(c) => c,
            Err(DriverError::UnsupportedFormat { .. }) => {
                eprintln!("skipped: {path} offers no decoded format at 640x480 through nokhwa");
                return;
            }
            Err(e) => panic!("{e}"),
        };
        crate::traits::assert_live_captures(&mut cam);
    }
}
