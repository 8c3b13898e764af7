//! What the rig does, as traits the capture sequencer drives: a [`Camera`],
//! a [`LightController`], a [`Projector`], a [`Trigger`] and a
//! [`Positioner`], plus the value types they exchange.
//!
//! Boundaries: no device I/O here; the real drivers (`crate::camera`,
//! `crate::lights`, `crate::projector`, `crate::footswitch`) and the
//! simulated rig implement these.
//! Times are on the monotonic clock ([`monotonic_now`]), the clock V4L2
//! stamps its buffers with, so a light change and a frame can be compared.

use crate::error::DriverError;
use matscan_scan::raster::{RgbRaster, ScalarRaster};
use matscan_scan::{GrayAxis, Pattern};
use std::num::NonZeroU32;
use std::time::Duration;

/// Now on `CLOCK_MONOTONIC`, the clock of V4L2 buffer timestamps.
pub fn monotonic_now() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always
    // exists on Linux, so the call cannot fail.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    Duration::new(
        ts.tv_sec.max(0) as u64,
        ts.tv_nsec.clamp(0, 999_999_999) as u32,
    )
}

/// A light or projector level in `0..=1`, finite by construction.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Level(f32);

impl Level {
    pub const ZERO: Level = Level(0.0);
    pub const FULL: Level = Level(1.0);

    /// `None` unless `value` is finite and in `0..=1`.
    pub fn new(value: f32) -> Option<Level> {
        (value.is_finite() && (0.0..=1.0).contains(&value)).then_some(Level(value))
    }

    pub fn get(self) -> f32 {
        self.0
    }

    /// The 8-bit PWM duty the light controller is sent.
    pub fn to_u8(self) -> u8 {
        (self.0 * 255.0).round() as u8
    }

    pub fn from_u8(duty: u8) -> Level {
        Level(duty as f32 / 255.0)
    }
}

/// The rig's switchable lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum LightId {
    Flash0,
    Flash1,
    Backlight,
}

impl LightId {
    pub const ALL: [LightId; 3] = [LightId::Flash0, LightId::Flash1, LightId::Backlight];

    /// The light's name in the scan manifest.
    pub fn name(self) -> &'static str {
        match self {
            LightId::Flash0 => "flash0",
            LightId::Flash1 => "flash1",
            LightId::Backlight => "backlight",
        }
    }

    /// The light's code on the controller's serial line.
    pub fn wire_code(self) -> &'static str {
        match self {
            LightId::Flash0 => "F0",
            LightId::Flash1 => "F1",
            LightId::Backlight => "BL",
        }
    }

    pub fn from_wire_code(code: &str) -> Option<LightId> {
        LightId::ALL.into_iter().find(|l| l.wire_code() == code)
    }

    pub fn from_name(name: &str) -> Option<LightId> {
        LightId::ALL.into_iter().find(|l| l.name() == name)
    }

    pub fn index(self) -> usize {
        self as usize
    }
}

/// What a light is doing.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum LightState {
    #[default]
    Off,
    On(Level),
}

impl LightState {
    /// The emitted fraction of full power (0 when off).
    pub fn level(self) -> f32 {
        match self {
            LightState::Off => 0.0,
            LightState::On(l) => l.get(),
        }
    }
}

/// A checkerboard: squares of `period_px / 2` projector pixels, `high` on
/// even squares, `low` on odd ones, shifted by `phase_px` (the contract's
/// definition).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checker {
    pub period_px: NonZeroU32,
    pub phase_px: [u32; 2],
    pub low: Level,
    pub high: Level,
}

/// One bit of the Gray code of the projector's column or row index, full
/// white where the bit is set (clear, when `inverted`): the structured
/// light that calibrates the projector (the contract's `gray-code`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GrayCode {
    pub axis: GrayAxis,
    /// 0 is the finest stripes, one projector pixel wide.
    pub bit: u32,
    pub inverted: bool,
}

impl GrayCode {
    /// Every Gray-code image of a `width` x `height` projector, columns
    /// then rows, each bit followed by its inverse: what a projector
    /// calibration photographs per board pose.
    pub fn sequence(width: u32, height: u32) -> Vec<GrayCode> {
        let size = matscan_scan::calib_bundle::ProjectorSize { width, height };
        [GrayAxis::Columns, GrayAxis::Rows]
            .into_iter()
            .flat_map(|axis| {
                (0..size.bits(axis)).flat_map(move |bit| {
                    [false, true].map(|inverted| GrayCode {
                        axis,
                        bit,
                        inverted,
                    })
                })
            })
            .collect()
    }
}

/// What the projector shows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum ProjectorPattern {
    #[default]
    Black,
    Uniform(Level),
    Checker(Checker),
    GrayCode(GrayCode),
}

impl ProjectorPattern {
    /// The scan contract's pattern (black is a uniform level of 0).
    pub fn to_pattern(self) -> Pattern {
        match self {
            ProjectorPattern::Black => Pattern::Uniform { level: 0.0 },
            ProjectorPattern::Uniform(l) => Pattern::Uniform {
                level: l.get() as f64,
            },
            ProjectorPattern::Checker(c) => Pattern::Checker {
                period_px: c.period_px.get() as f64,
                phase_px: [c.phase_px[0] as f64, c.phase_px[1] as f64],
                low: c.low.get() as f64,
                high: c.high.get() as f64,
            },
            ProjectorPattern::GrayCode(g) => Pattern::GrayCode {
                axis: g.axis,
                bit: g.bit,
                inverted: g.inverted,
            },
        }
    }

    /// A manifest pattern a real projector can show: `None` for levels
    /// outside `0..=1` or a period or phase that is not a whole, non-negative
    /// number of pixels.
    pub fn from_pattern(pattern: &Pattern) -> Option<ProjectorPattern> {
        let level = |v: f64| Level::new(v as f32);
        let whole = |v: f64| {
            (v.is_finite() && v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64)
                .then_some(v as u32)
        };
        match *pattern {
            Pattern::Uniform { level: 0.0 } => Some(ProjectorPattern::Black),
            Pattern::Uniform { level: l } => level(l).map(ProjectorPattern::Uniform),
            Pattern::Checker {
                period_px,
                phase_px,
                low,
                high,
            } => Some(ProjectorPattern::Checker(Checker {
                period_px: NonZeroU32::new(whole(period_px)?)?,
                phase_px: [whole(phase_px[0])?, whole(phase_px[1])?],
                low: level(low)?,
                high: level(high)?,
            })),
            Pattern::GrayCode {
                axis,
                bit,
                inverted,
            } => Some(ProjectorPattern::GrayCode(GrayCode {
                axis,
                bit,
                inverted,
            })),
        }
    }

    /// The level of projector pixel (column `u`, row `v`).
    pub fn value_at(&self, u: u32, v: u32) -> f32 {
        match self {
            ProjectorPattern::Black => 0.0,
            ProjectorPattern::Uniform(l) => l.get(),
            ProjectorPattern::Checker(_) | ProjectorPattern::GrayCode(_) => {
                self.to_pattern().value_at(u as i64, v as i64) as f32
            }
        }
    }

    /// The whole projector image, for a display that shows a picture.
    pub fn raster(&self, width: u32, height: u32) -> ScalarRaster {
        ScalarRaster::from_fn(width, height, |u, v| self.value_at(u, v))
    }
}

/// Exposure, gain and white balance, locked for a whole scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraSettings {
    exposure_s: f32,
    gain: f32,
    white_balance_k: u32,
}

impl CameraSettings {
    /// `None` unless the exposure is positive and finite, the gain at least 1
    /// and finite, and the white balance within 1000..=15000 K.
    pub fn new(exposure_s: f32, gain: f32, white_balance_k: u32) -> Option<CameraSettings> {
        let ok = exposure_s.is_finite()
            && exposure_s > 0.0
            && gain.is_finite()
            && gain >= 1.0
            && (1000..=15000).contains(&white_balance_k);
        ok.then_some(CameraSettings {
            exposure_s,
            gain,
            white_balance_k,
        })
    }

    pub fn exposure_s(&self) -> f32 {
        self.exposure_s
    }

    pub fn gain(&self) -> f32 {
        self.gain
    }

    pub fn white_balance_k(&self) -> u32 {
        self.white_balance_k
    }
}

impl Default for CameraSettings {
    fn default() -> Self {
        CameraSettings {
            exposure_s: 0.02,
            gain: 1.0,
            white_balance_k: 5000,
        }
    }
}

/// One photo: linear RGB with what the camera did to take it.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Linear RGB, row 0 at the top, 1.0 = sensor white at this exposure.
    pub rgb: RgbRaster,
    /// Start of exposure (or the driver's stamp) on the monotonic clock.
    pub timestamp: Duration,
    pub exposure_s: f32,
    pub gain: f32,
    /// The driver's frame counter (gaps mean dropped frames).
    pub sequence: u64,
}

/// A camera with every automatic control locked.
pub trait Camera {
    /// The device's stable name (a /dev/v4l/by-id path, or `sim:camera`).
    fn id(&self) -> &str;
    fn resolution(&self) -> (u32, u32);
    /// Switches auto exposure, exposure priority, auto white balance,
    /// autofocus and auto gain off and applies `settings`; frames taken
    /// before the new values settle are dropped by the next
    /// [`Camera::capture`].
    fn lock(&mut self, settings: CameraSettings) -> Result<(), DriverError>;
    fn settings(&self) -> CameraSettings;
    /// Something the camera sees changed at `at` (monotonic clock): the
    /// next capture drops the frames that may predate it.
    fn scene_changed(&mut self, at: Duration);
    /// One fresh frame.
    fn capture(&mut self) -> Result<Frame, DriverError>;
    /// The mean of `frames` fresh frames (at least one) of a scene that
    /// does not change meanwhile: each frame's noise is its own, so the
    /// mean's falls with the square root of their number. The stamp and
    /// counter are the first frame's.
    fn capture_mean(&mut self, frames: usize) -> Result<Frame, DriverError> {
        let first = self.capture()?;
        let rgb = first
            .rgb
            .mean_with(frames.saturating_sub(1), |_| Ok(self.capture()?.rgb))?;
        Ok(Frame { rgb, ..first })
    }
}

/// The light controller; `Ok` means the controller acknowledged.
pub trait LightController {
    fn id(&self) -> &str;
    fn set(&mut self, light: LightId, state: LightState) -> Result<(), DriverError>;
    fn all_off(&mut self) -> Result<(), DriverError>;
    /// The last acknowledged state of `light`.
    fn state(&self, light: LightId) -> LightState;

    fn on(&mut self, light: LightId, level: Level) -> Result<(), DriverError> {
        self.set(light, LightState::On(level))
    }

    fn off(&mut self, light: LightId) -> Result<(), DriverError> {
        self.set(light, LightState::Off)
    }
}

/// The pattern projector.
pub trait Projector {
    fn id(&self) -> &str;
    /// Width and height in projector pixels.
    fn resolution(&self) -> (u32, u32);
    fn show(&mut self, pattern: ProjectorPattern) -> Result<(), DriverError>;
    fn pattern(&self) -> ProjectorPattern;
    /// Whether [`Projector::show`] can show `pattern` exactly; a capture
    /// plan leaves out the photos of patterns it cannot. A framebuffer
    /// shows anything, hence the default.
    fn can_show(&self, pattern: &ProjectorPattern) -> bool {
        let _ = pattern;
        true
    }
}

/// One footswitch press.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Press {
    /// When it was pressed, monotonic clock.
    pub timestamp: Duration,
}

/// What the operator presses to start a capture.
pub trait Trigger {
    fn id(&self) -> &str;
    /// The next press, or `None` when `timeout` passes without one.
    fn wait(&mut self, timeout: Duration) -> Result<Option<Press>, DriverError>;
}

/// A turntable (or anything) that moves the object to the next position.
pub trait Positioner {
    fn id(&self) -> &str;
    /// Number of positions in one turn.
    fn count(&self) -> usize;
    /// The current position index.
    fn position(&self) -> usize;
    /// Moves to the next position (wrapping after the last) and returns its
    /// index once the object has stopped.
    fn advance(&mut self) -> Result<usize, DriverError>;
}

/// Where a calibration target goes for the next photos.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TargetPlacement {
    /// The reference placement, the same at every position: where the
    /// object stands, on its easel. It ties each position's camera to the
    /// world frame.
    Reference,
    /// On the mount's further seat, the same at every position: the board
    /// turned away from the reference placement.
    Seat,
    /// Anywhere the camera sees it whole, tilted differently each time.
    HandHeld,
    /// Where both the camera and the projector see it whole.
    InProjectorView,
    /// The light-calibration sphere, somewhere new in the camera's view
    /// with the backlight panel behind it.
    Sphere,
    /// The white card on the board's mount at the reference placement,
    /// white side to the camera.
    WhiteCard,
    /// Nothing on the mount: the backlight panel seen alone.
    EmptyMount,
}

/// Places a calibration target in front of the camera without a person:
/// the simulated rig's operator. A real rig has none; its operator reads
/// the prompt, places the target and presses the footswitch.
pub trait TargetHand {
    fn id(&self) -> &str;
    /// Puts the target at `placement` for the camera at rig position
    /// `position`; it is still when this returns.
    fn place(&mut self, position: usize, placement: TargetPlacement) -> Result<(), DriverError>;
    /// Takes the target away: the object is in view again.
    fn remove(&mut self);
}

/// What every live camera must do, for the device tests that run where a
/// camera exists: a frame of its resolution with finite, non-negative
/// values, and a later frame after a change.
#[cfg(all(test, feature = "hardware"))]
pub(crate) fn assert_live_captures(cam: &mut dyn Camera) {
    let frame = cam.capture().expect("a first frame");
    assert_eq!((frame.rgb.width, frame.rgb.height), cam.resolution());
    assert!(frame
        .rgb
        .data
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
    cam.scene_changed(monotonic_now());
    let next = cam.capture().expect("a fresh frame after a change");
    assert!(next.timestamp > frame.timestamp);
}
