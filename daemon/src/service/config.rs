//! The daemon's TOML configuration: parsed strictly (unknown keys are
//! errors, since a misspelt safety setting must not be silently ignored),
//! validated into types that cannot hold a wrong value, with defaults
//! documented on each field and in `docs/daemon-protocol.md`.
//!
//! Boundaries: reads text; opens no device and no socket.

use super::sequencer::{BoardPlan, CalibrationTarget, SpherePlan, WhitePlan};
use matscan_drivers::projector::kms::{Gamma, ModeRequest};
use matscan_drivers::usb::UsbId;
use matscan_scan::calib_bundle::BoardFrames;
use matscan_scan::Param;
use matscan_sim::scene::{GeometryKind, SceneKind};
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::num::NonZeroU32;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Where the control socket goes when neither the config nor `--socket`
/// says (systemd's `RuntimeDirectory=matscan`).
pub const DEFAULT_SOCKET: &str = "/run/matscan/matscan.sock";
/// Where scans go when neither the config nor `--scans` says
/// (systemd's `StateDirectory=matscan`).
pub const DEFAULT_SCANS: &str = "/var/lib/matscan/scans";
/// The profile that estimates every parameter; always defined.
pub const FULL_PROFILE: &str = "full";

#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("{path}: cannot read the configuration: {source}")]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Syntax { path: PathBuf, message: String },
    #[error("{path}: `{key}`: {message}")]
    Invalid {
        path: PathBuf,
        key: String,
        message: String,
    },
}

/// A validated configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    pub rig: RigChoice,
    pub socket: PathBuf,
    /// The group the control socket is given (mode 0660: its members may
    /// capture); `None`: the daemon's own group.
    pub socket_group: Option<String>,
    pub scans: PathBuf,
    /// What a capture request (socket or footswitch) does while another
    /// capture runs.
    pub busy: BusyPolicy,
    pub profiles: BTreeMap<String, Profile>,
    /// The profile of a capture request that names none.
    pub default_profile: String,
    pub capture: CaptureSettings,
    pub estimate: EstimateSettings,
    pub calibration: CalibrationSettings,
}

/// `[calibration]`: what a calibration capture (`matscan calib capture`)
/// photographs.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationSettings {
    /// The printed board (`board`, `square`, `reference_to_world`); `None`
    /// when not set. The simulated rig's operator holds its own board.
    pub target: Option<CalibrationTarget>,
    /// Board poses per position, the reference placement included.
    pub shots: usize,
    /// Gray-code poses for the projector (0 on a rig without one).
    pub projector_shots: usize,
    /// Whether the board's mount has a second seat to photograph the board
    /// on at every position (`seat`).
    pub seat: bool,
    /// Frames averaged into each photo of the board resting at the
    /// reference or on the seat (`resting_frames`), and into each photo of
    /// a held board (`held_frames`).
    pub frames: BoardFrames,
    /// Positions to photograph when the rig has no calibration file yet.
    pub positions: usize,
    /// The light-calibration sphere's radius, metres (`sphere_radius`);
    /// `None` when not set. The simulated rig's operator holds its own.
    pub sphere_radius: Option<f64>,
    /// Places to photograph the sphere at.
    pub sphere_placements: usize,
    /// The white card's diffuse reflectance (`white_albedo`), from its
    /// certificate: every intensity the card measures scales with it.
    pub white_albedo: f64,
    /// The white card's roughness as the Principled BSDF reads it
    /// (`white_roughness`; 1 for a matte card).
    pub white_roughness: f64,
    /// Exposures of the white card's linearity check (`white_exposures`).
    pub white_exposures: usize,
}

impl Default for CalibrationSettings {
    fn default() -> Self {
        CalibrationSettings {
            target: None,
            shots: 8,
            projector_shots: 12,
            seat: true,
            frames: BoardFrames::DEFAULT,
            positions: 1,
            sphere_radius: None,
            sphere_placements: 6,
            white_albedo: 0.9,
            white_roughness: 1.0,
            white_exposures: 3,
        }
    }
}

/// What the worker does with a published scan after checking it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EstimateSettings {
    /// Estimate the BSDF maps into `<scan>/estimate` (default true).
    pub enabled: bool,
    /// A folder with `<param>.weights` per network; `None`: the weights
    /// built into the binary.
    pub weights: Option<PathBuf>,
}

impl Default for EstimateSettings {
    fn default() -> Self {
        EstimateSettings {
            enabled: true,
            weights: None,
        }
    }
}

/// Which rig the daemon drives.
#[derive(Debug, Clone, PartialEq)]
pub enum RigChoice {
    Simulated(SimulatedRigConfig),
    Hardware(HardwareRigConfig),
}

/// The real rig (see [`super::hardware`]): device paths, the capture size,
/// and the files that give its geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct HardwareRigConfig {
    pub camera: CameraSource,
    /// Capture size in pixels; must match the calibrated intrinsics.
    pub width: u32,
    pub height: u32,
    /// Exposure of every photo, seconds.
    pub exposure_s: f32,
    /// The light controller's serial port (`/dev/serial/by-id/...`).
    pub lights: String,
    pub baud: u32,
    pub footswitch: FootswitchSource,
    /// Linux key codes (as `evtest` shows them) that count as a press;
    /// empty: any key.
    pub footswitch_keys: Vec<u16>,
    /// `None`: the rig has no projector (no projector or checker photos).
    pub projector: Option<ProjectorSource>,
    /// The two checkerboard periods, projector pixels.
    pub checker_periods: (NonZeroU32, NonZeroU32),
    /// The rig calibration file: a scan manifest without captures.
    pub calibration: PathBuf,
    /// Where the scanner software exports the object's mesh (re-read at
    /// every capture).
    pub mesh: PathBuf,
}

/// Where the photos come from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CameraSource {
    /// A V4L2 device; prefer `/dev/v4l/by-id/...` (stable across boots).
    V4l2(String),
    /// nokhwa's portable backend (`nokhwa:<index or path>`), for cameras
    /// the V4L2 driver cannot open; it cannot lock every control.
    Nokhwa(String),
}

/// What the operator presses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FootswitchSource {
    /// An evdev node, grabbed exclusively
    /// (`/dev/input/by-id/...-event-kbd`).
    Evdev(String),
    /// Raw USB (`usb:VVVV:PPPP`): the kernel's keyboard driver is
    /// detached, so the pedal never types anywhere.
    Usb(UsbId),
    /// A named pipe (`pipe:PATH`): each line another program writes is a
    /// press (a pedal on a GPIO, a vendor tool).
    Pipe(PathBuf),
}

/// The pattern projector.
#[derive(Debug, Clone, PartialEq)]
pub enum ProjectorSource {
    /// Full screen on a DRM/KMS output (`drm` or `drm:<connector>`).
    Drm {
        card: PathBuf,
        /// `None`: the only connected output.
        connector: Option<String>,
        /// `None`: the output's preferred mode; forced when the projector
        /// reports no modes.
        mode: Option<ModeRequest>,
        /// From the flip to the projector emitting the frame.
        latency: Duration,
        gamma: f32,
    },
    /// A TI DLP LightCrafter's test-pattern generator over USB HID
    /// (`lightcrafter` or `lightcrafter:VVVV:PPPP`).
    LightCrafter { id: UsbId, settle: Duration },
}

impl std::fmt::Display for CameraSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraSource::V4l2(path) => write!(f, "{path}"),
            CameraSource::Nokhwa(selector) => write!(f, "nokhwa:{selector}"),
        }
    }
}

impl std::fmt::Display for FootswitchSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FootswitchSource::Evdev(path) => write!(f, "{path}"),
            FootswitchSource::Usb(id) => write!(f, "usb:{:04x}:{:04x}", id.vendor, id.product),
            FootswitchSource::Pipe(path) => write!(f, "pipe:{}", path.display()),
        }
    }
}

impl std::fmt::Display for ProjectorSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ProjectorSource::Drm {
                card, connector, ..
            } => write!(
                f,
                "drm {} {}",
                card.display(),
                connector.as_deref().unwrap_or("(the connected output)")
            ),
            ProjectorSource::LightCrafter { id, .. } => {
                write!(f, "lightcrafter usb:{:04x}:{:04x}", id.vendor, id.product)
            }
        }
    }
}

impl RigChoice {
    /// Whether the rig has a footswitch that can start captures (the
    /// idle daemon then keeps the rig open to listen to it).
    pub fn has_footswitch(&self) -> bool {
        match self {
            RigChoice::Hardware(_) => true,
            RigChoice::Simulated(s) => s.footswitch.is_some(),
        }
    }

    pub fn describe(&self) -> String {
        match self {
            RigChoice::Hardware(h) => format!(
                "hardware (camera {}, lights {}, footswitch {}, projector {}, calibration {}, \
                 mesh {})",
                h.camera,
                h.lights,
                h.footswitch,
                h.projector
                    .as_ref()
                    .map_or_else(|| "none".to_string(), |p| p.to_string()),
                h.calibration.display(),
                h.mesh.display()
            ),
            RigChoice::Simulated(s) => format!(
                "simulated ({} scene, {} on {}, {} positions, {}x{} px, {} spp, {}, seed {}{})",
                s.kind,
                s.geometry
                    .map_or("random geometry".to_string(), |g| g.to_string()),
                if s.turntable {
                    "a turntable"
                } else {
                    "the operator's footswitch"
                },
                s.positions,
                s.size,
                s.size,
                s.samples,
                s.frame
                    .map_or("the thesis's random framing".to_string(), |f| format!(
                        "object framed to {:.0}% of the half frame",
                        100.0 * f
                    )),
                s.seed,
                s.footswitch.as_ref().map_or_else(String::new, |p| format!(
                    ", footswitch pipe:{}",
                    p.display()
                )),
            ),
        }
    }
}

/// How far from the image centre towards its edge the simulated rig's
/// object reaches by default (see [`SimulatedRigConfig::frame`]).
pub const DEFAULT_FRAME: f64 = 0.9;

/// The simulated rig's framing from its setting: 0 keeps the thesis's
/// random aim and focal length (`None`), a share in (0, 1] frames the
/// object (see [`SimulatedRigConfig::frame`]); anything else is refused
/// with what was expected.
pub fn framing(frame: f64) -> Result<Option<f64>, String> {
    match frame {
        0.0 => Ok(None),
        f if f > 0.0 && f <= 1.0 => Ok(Some(f)),
        f => Err(format!(
            "{f}: expected the object's share of the frame in (0, 1], or 0 for the thesis's \
             random framing"
        )),
    }
}

/// The simulated rig: a generated scene rendered on demand.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedRigConfig {
    pub seed: u64,
    pub kind: SceneKind,
    /// `None`: a random shape from the seed.
    pub geometry: Option<GeometryKind>,
    /// Photo width and height.
    pub size: u32,
    pub positions: usize,
    pub samples: u32,
    /// The share of the frame the object fills: every camera aims at the
    /// object and the focal length is chosen for it, as an operator sets
    /// up a real rig (`matscan_sim::scene::frame_object`). `None`: the
    /// thesis's random aim and focal length, as the data sets use.
    pub frame: Option<f64>,
    /// A simulated scan (its folder) or rig file whose camera, poses and
    /// lights replace the generated rig (`rig_from`): calibration photos of
    /// a data set's rig, to calibrate it as a user would. Its aim is kept
    /// (no framing) and its camera scaled to `size`.
    pub rig_from: Option<PathBuf>,
    /// With a turntable the sequencer turns the object; without one it
    /// waits for the operator's footswitch press between positions.
    pub turntable: bool,
    /// The simulated pedal: a named pipe where each line written is a
    /// press (`echo > PATH`), starting a capture when idle and moving on
    /// between positions. `None`: nobody presses it.
    pub footswitch: Option<PathBuf>,
    pub faults: FaultConfig,
}

/// Faults injected into the simulated rig (for tests and demos of the
/// failure paths).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultConfig {
    pub camera_lost_after: Option<u64>,
    pub lights_silent_after: Option<u64>,
    pub dead_lights: Vec<matscan_drivers::LightId>,
    pub disk_capacity: Option<u64>,
}

/// What a capture request does while another capture runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusyPolicy {
    /// Queue it (up to `limit` waiting requests; beyond that, refuse).
    Queue { limit: usize },
    /// Refuse it.
    Refuse,
}

/// Which parameters are given (known in advance) rather than estimated.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Profile {
    pub given: BTreeSet<Param>,
}

/// How the sequencer judges and retries captures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureSettings {
    /// Extra attempts at a lit photo that looks like ambient.
    pub light_retries: u32,
    /// Mean absolute difference from ambient (linear, 1.0 = sensor white)
    /// below which a lit photo counts as "the light did not fire".
    pub min_light_difference: f32,
    /// How long to wait for the operator's press between positions on a
    /// rig without a turntable.
    pub operator_timeout: Duration,
}

impl Default for CaptureSettings {
    fn default() -> Self {
        CaptureSettings {
            light_retries: 1,
            min_light_difference: 1e-3,
            operator_timeout: Duration::from_secs(120),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    rig: String,
    socket: Option<PathBuf>,
    socket_group: Option<String>,
    scans: Option<PathBuf>,
    #[serde(default)]
    busy: Option<String>,
    queue_limit: Option<usize>,
    default_profile: Option<String>,
    #[serde(default)]
    profiles: BTreeMap<String, RawProfile>,
    #[serde(default)]
    capture: RawCapture,
    #[serde(default)]
    estimate: RawEstimate,
    simulated: Option<RawSimulated>,
    hardware: Option<RawHardware>,
    #[serde(default)]
    calibration: RawCalibration,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCalibration {
    board: Option<[u32; 2]>,
    square: Option<f64>,
    reference_to_world: Option<[f64; 16]>,
    shots: Option<usize>,
    projector_shots: Option<usize>,
    seat: Option<bool>,
    resting_frames: Option<usize>,
    held_frames: Option<usize>,
    positions: Option<usize>,
    sphere_radius: Option<f64>,
    sphere_placements: Option<usize>,
    white_albedo: Option<f64>,
    white_roughness: Option<f64>,
    white_exposures: Option<usize>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawHardware {
    camera: Option<String>,
    width: Option<u32>,
    height: Option<u32>,
    exposure_s: Option<f32>,
    lights: Option<String>,
    baud: Option<u32>,
    footswitch: Option<String>,
    #[serde(default)]
    footswitch_keys: Vec<u16>,
    projector: Option<String>,
    projector_card: Option<PathBuf>,
    projector_mode: Option<String>,
    projector_latency_ms: Option<u64>,
    projector_gamma: Option<f32>,
    checker_periods: Option<[u32; 2]>,
    calibration: Option<PathBuf>,
    mesh: Option<PathBuf>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEstimate {
    enabled: Option<bool>,
    weights: Option<PathBuf>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProfile {
    #[serde(default)]
    given: Vec<String>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCapture {
    light_retries: Option<u32>,
    min_light_difference: Option<f32>,
    operator_timeout_s: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSimulated {
    seed: Option<u64>,
    kind: Option<String>,
    geometry: Option<String>,
    size: Option<u32>,
    positions: Option<usize>,
    samples: Option<u32>,
    frame: Option<f64>,
    rig_from: Option<PathBuf>,
    turntable: Option<bool>,
    footswitch: Option<PathBuf>,
    #[serde(default)]
    faults: RawFaults,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFaults {
    camera_lost_after: Option<u64>,
    lights_silent_after: Option<u64>,
    #[serde(default)]
    dead_lights: Vec<String>,
    disk_capacity: Option<u64>,
}

impl Config {
    /// Reads and validates `path`.
    pub fn load(path: &Path) -> Result<Config, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Config::parse(&text, path)
    }

    /// Validates `text`; `path` only names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Config, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| ConfigError::Syntax {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let invalid = |key: &str, message: String| ConfigError::Invalid {
            path: path.to_path_buf(),
            key: key.to_string(),
            message,
        };
        let rig = match raw.rig.as_str() {
            "simulated" => {
                RigChoice::Simulated(simulated(raw.simulated.unwrap_or_default(), &invalid)?)
            }
            "hardware" => RigChoice::Hardware(hardware(
                raw.hardware.ok_or_else(|| {
                    invalid(
                        "hardware",
                        "rig = \"hardware\" needs a [hardware] table (camera, lights, \
                         footswitch, calibration, mesh)"
                            .into(),
                    )
                })?,
                &invalid,
            )?),
            other => {
                return Err(invalid(
                    "rig",
                    format!("unknown rig `{other}`: expected \"simulated\" or \"hardware\""),
                ))
            }
        };
        let busy = match (raw.busy.as_deref().unwrap_or("queue"), raw.queue_limit) {
            ("queue", limit) => {
                let limit = limit.unwrap_or(4);
                if limit == 0 {
                    return Err(invalid(
                        "queue_limit",
                        "expected at least 1 (use busy = \"refuse\" to queue nothing)".into(),
                    ));
                }
                BusyPolicy::Queue { limit }
            }
            ("refuse", None) => BusyPolicy::Refuse,
            ("refuse", Some(_)) => {
                return Err(invalid(
                    "queue_limit",
                    "only meaningful with busy = \"queue\"".into(),
                ))
            }
            (other, _) => {
                return Err(invalid(
                    "busy",
                    format!("`{other}`: expected \"queue\" or \"refuse\""),
                ))
            }
        };
        let mut profiles = BTreeMap::new();
        profiles.insert(FULL_PROFILE.to_string(), Profile::default());
        for (name, p) in raw.profiles {
            let mut given = BTreeSet::new();
            for g in &p.given {
                let param = g
                    .parse::<Param>()
                    .map_err(|e| invalid(&format!("profiles.{name}.given"), e.to_string()))?;
                given.insert(param);
            }
            profiles.insert(name, Profile { given });
        }
        let default_profile = raw
            .default_profile
            .unwrap_or_else(|| FULL_PROFILE.to_string());
        if !profiles.contains_key(&default_profile) {
            return Err(invalid(
                "default_profile",
                format!(
                    "no profile `{default_profile}` (defined: {})",
                    profiles.keys().cloned().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
        let defaults = CaptureSettings::default();
        let min_light_difference = raw
            .capture
            .min_light_difference
            .unwrap_or(defaults.min_light_difference);
        if !(min_light_difference.is_finite() && min_light_difference > 0.0) {
            return Err(invalid(
                "capture.min_light_difference",
                format!("{min_light_difference}: expected a positive number"),
            ));
        }
        let operator_timeout = match raw.capture.operator_timeout_s {
            None => defaults.operator_timeout,
            Some(s) if s.is_finite() && s > 0.0 && s < 1e7 => Duration::from_secs_f64(s),
            Some(s) => {
                return Err(invalid(
                    "capture.operator_timeout_s",
                    format!("{s}: expected a positive number of seconds"),
                ))
            }
        };
        let estimate = EstimateSettings {
            enabled: raw.estimate.enabled.unwrap_or(true),
            weights: raw.estimate.weights,
        };
        if let Some(w) = &estimate.weights {
            if !w.is_dir() {
                return Err(invalid(
                    "estimate.weights",
                    format!(
                        "{}: expected a folder holding <param>.weights files",
                        w.display()
                    ),
                ));
            }
        }
        let calibration = calibration(raw.calibration, &invalid)?;
        Ok(Config {
            rig,
            estimate,
            calibration,
            socket: raw.socket.unwrap_or_else(|| PathBuf::from(DEFAULT_SOCKET)),
            socket_group: match raw.socket_group {
                Some(g) if g.trim().is_empty() || g.contains('\0') => {
                    return Err(invalid("socket_group", "expected a group name".into()))
                }
                other => other,
            },
            scans: raw.scans.unwrap_or_else(|| PathBuf::from(DEFAULT_SCANS)),
            busy,
            profiles,
            default_profile,
            capture: CaptureSettings {
                light_retries: raw.capture.light_retries.unwrap_or(defaults.light_retries),
                min_light_difference,
                operator_timeout,
            },
        })
    }
}

fn calibration(
    raw: RawCalibration,
    invalid: &dyn Fn(&str, String) -> ConfigError,
) -> Result<CalibrationSettings, ConfigError> {
    let defaults = CalibrationSettings::default();
    let target = match (raw.board, raw.square) {
        (None, None) => {
            if raw.reference_to_world.is_some() {
                return Err(invalid(
                    "calibration.reference_to_world",
                    "only meaningful with calibration.board and calibration.square".into(),
                ));
            }
            None
        }
        (Some([cols, rows]), Some(square)) => {
            if cols < 3 || rows < 3 || cols == rows {
                return Err(invalid(
                    "calibration.board",
                    format!(
                        "[{cols}, {rows}]: expected the board's inner corners, two different \
                         counts of at least 3 (columns, rows), so its orientation can be told"
                    ),
                ));
            }
            if !(square.is_finite() && square > 0.0 && square < 1.0) {
                return Err(invalid(
                    "calibration.square",
                    format!("{square}: expected the edge of one square in metres (0 to 1)"),
                ));
            }
            let reference_to_world = match raw.reference_to_world {
                None => glam::DMat4::IDENTITY,
                Some(m) => {
                    let m = matscan_scan::camera::mat4_from_row_major(&m);
                    if !matscan_scan::calib_bundle::is_rigid(&m) {
                        return Err(invalid(
                            "calibration.reference_to_world",
                            "expected a rigid transform, row-major (rotation and translation, \
                             last row 0 0 0 1)"
                                .into(),
                        ));
                    }
                    m
                }
            };
            Some(CalibrationTarget {
                board: matscan_scan::calib_bundle::Chessboard { cols, rows, square },
                reference_to_world,
            })
        }
        (Some(_), None) => {
            return Err(invalid(
                "calibration.square",
                "missing: expected the edge of one printed square in metres".into(),
            ))
        }
        (None, Some(_)) => {
            return Err(invalid(
                "calibration.board",
                "missing: expected the board's inner corners, [columns, rows]".into(),
            ))
        }
    };
    let shots = raw.shots.unwrap_or(defaults.shots);
    let projector_shots = raw.projector_shots.unwrap_or(defaults.projector_shots);
    let seat = raw.seat.unwrap_or(defaults.seat);
    let frames = BoardFrames {
        resting: raw.resting_frames.unwrap_or(defaults.frames.resting),
        held: raw.held_frames.unwrap_or(defaults.frames.held),
    };
    BoardFrames::check("resting_frames", frames.resting)
        .map_err(|e| invalid("calibration.resting_frames", e))?;
    BoardFrames::check("held_frames", frames.held)
        .map_err(|e| invalid("calibration.held_frames", e))?;
    BoardPlan::new(shots, projector_shots, seat, frames)
        .map_err(|e| invalid("calibration.shots", e))?;
    let positions = raw.positions.unwrap_or(defaults.positions);
    if positions == 0 {
        return Err(invalid(
            "calibration.positions",
            "expected at least 1 rig position".into(),
        ));
    }
    if let Some(r) = raw.sphere_radius {
        if !(r.is_finite() && r > 0.0 && r < 1.0) {
            return Err(invalid(
                "calibration.sphere_radius",
                format!("{r}: expected the sphere's radius in metres (0 to 1)"),
            ));
        }
    }
    let sphere_placements = raw.sphere_placements.unwrap_or(defaults.sphere_placements);
    SpherePlan::new(sphere_placements).map_err(|e| invalid("calibration.sphere_placements", e))?;
    let white_albedo = raw.white_albedo.unwrap_or(defaults.white_albedo);
    if !(white_albedo.is_finite() && white_albedo > 0.0 && white_albedo <= 1.0) {
        return Err(invalid(
            "calibration.white_albedo",
            format!("{white_albedo}: expected the white card's reflectance, in (0, 1]"),
        ));
    }
    let white_roughness = raw.white_roughness.unwrap_or(defaults.white_roughness);
    if !(0.0..=1.0).contains(&white_roughness) {
        return Err(invalid(
            "calibration.white_roughness",
            format!("{white_roughness}: expected a roughness in [0, 1]"),
        ));
    }
    let white_exposures = raw.white_exposures.unwrap_or(defaults.white_exposures);
    WhitePlan::new(white_exposures, white_albedo, white_roughness)
        .map_err(|e| invalid("calibration.white_exposures", e))?;
    Ok(CalibrationSettings {
        target,
        shots,
        projector_shots,
        seat,
        frames,
        positions,
        sphere_radius: raw.sphere_radius,
        sphere_placements,
        white_albedo,
        white_roughness,
        white_exposures,
    })
}

fn hardware(
    raw: RawHardware,
    invalid: &dyn Fn(&str, String) -> ConfigError,
) -> Result<HardwareRigConfig, ConfigError> {
    let required = |value: Option<String>, key: &str, what: &str| {
        value.filter(|v| !v.trim().is_empty()).ok_or_else(|| {
            invalid(
                &format!("hardware.{key}"),
                format!("missing: expected {what}"),
            )
        })
    };
    let projector = projector(&raw, invalid)?;
    let camera = required(raw.camera, "camera", "the camera's V4L2 device path")?;
    let camera = match camera.strip_prefix("nokhwa:") {
        Some("") => {
            return Err(invalid(
                "hardware.camera",
                "`nokhwa:` needs a camera: `nokhwa:0` (index) or `nokhwa:/dev/video0`".into(),
            ))
        }
        Some(selector) => CameraSource::Nokhwa(selector.to_string()),
        None => CameraSource::V4l2(camera),
    };
    let lights = required(raw.lights, "lights", "the light controller's serial port")?;
    let footswitch = required(
        raw.footswitch,
        "footswitch",
        "the footswitch's evdev node, `usb:VVVV:PPPP` or `pipe:PATH`",
    )?;
    let footswitch = if let Some(id) = footswitch.strip_prefix("usb:") {
        FootswitchSource::Usb(
            id.parse::<UsbId>()
                .map_err(|e| invalid("hardware.footswitch", e.to_string()))?,
        )
    } else if footswitch.starts_with("pipe:") {
        FootswitchSource::Pipe(
            matscan_drivers::footswitch::pipe::pipe_path(&footswitch).ok_or_else(|| {
                invalid(
                    "hardware.footswitch",
                    "`pipe:` needs the named pipe's path: `pipe:/run/matscan/pedal`".into(),
                )
            })?,
        )
    } else {
        FootswitchSource::Evdev(footswitch)
    };
    let [fine, coarse] = raw.checker_periods.unwrap_or([8, 32]);
    let checker_periods = match (NonZeroU32::new(fine), NonZeroU32::new(coarse)) {
        (Some(f), Some(c)) if fine >= 2 && coarse >= 2 && fine % 2 == 0 && coarse % 2 == 0 => {
            (f, c)
        }
        _ => {
            return Err(invalid(
                "hardware.checker_periods",
                format!(
                    "[{fine}, {coarse}]: expected two even periods of at least 2 projector \
                     pixels (a period is one light and one dark square)"
                ),
            ))
        }
    };
    let calibration = raw.calibration.ok_or_else(|| {
        invalid(
            "hardware.calibration",
            "missing: expected the rig calibration file (a scan manifest)".into(),
        )
    })?;
    let mesh = raw.mesh.ok_or_else(|| {
        invalid(
            "hardware.mesh",
            "missing: expected the path the scanner software exports the mesh to".into(),
        )
    })?;
    let (width, height) = match (raw.width, raw.height) {
        (Some(w), Some(h)) if (8..=16384).contains(&w) && (8..=16384).contains(&h) => (w, h),
        (Some(w), Some(h)) => {
            return Err(invalid(
                "hardware.width",
                format!("{w}x{h}: expected 8 to 16384 pixels each"),
            ))
        }
        _ => {
            return Err(invalid(
                "hardware.width",
                "missing: expected width and height of the photos".into(),
            ))
        }
    };
    let exposure_s = raw.exposure_s.unwrap_or(0.02);
    if !(exposure_s.is_finite() && exposure_s > 0.0 && exposure_s <= 10.0) {
        return Err(invalid(
            "hardware.exposure_s",
            format!("{exposure_s}: expected seconds in (0, 10]"),
        ));
    }
    Ok(HardwareRigConfig {
        camera,
        width,
        height,
        exposure_s,
        lights,
        baud: raw.baud.unwrap_or(115_200),
        footswitch,
        footswitch_keys: raw.footswitch_keys,
        projector,
        checker_periods,
        calibration,
        mesh,
    })
}

/// `[hardware] projector` and its keys: `drm`, `drm:<connector>`,
/// `lightcrafter`, `lightcrafter:VVVV:PPPP`, `none` or absent.
fn projector(
    raw: &RawHardware,
    invalid: &dyn Fn(&str, String) -> ConfigError,
) -> Result<Option<ProjectorSource>, ConfigError> {
    let choice = raw.projector.as_deref().map(str::trim);
    let is_drm = matches!(choice, Some(c) if c == "drm" || c.starts_with("drm:"));
    let drm_only = [
        ("projector_card", raw.projector_card.is_some()),
        ("projector_mode", raw.projector_mode.is_some()),
        ("projector_gamma", raw.projector_gamma.is_some()),
    ];
    if !is_drm {
        if let Some((key, _)) = drm_only.iter().find(|(_, set)| *set) {
            return Err(invalid(
                &format!("hardware.{key}"),
                "only applies to a DRM projector (`projector = \"drm:<connector>\"`)".into(),
            ));
        }
    }
    let latency = |default_ms: u64| match raw.projector_latency_ms {
        Some(ms) if ms > 10_000 => Err(invalid(
            "hardware.projector_latency_ms",
            format!("{ms}: expected at most 10000 ms"),
        )),
        ms => Ok(Duration::from_millis(ms.unwrap_or(default_ms))),
    };
    let Some(choice) = choice else {
        return Ok(None);
    };
    if choice == "none" {
        return Ok(None);
    }
    if is_drm {
        let connector = choice
            .strip_prefix("drm:")
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(str::to_string);
        let mode = match &raw.projector_mode {
            None => None,
            Some(m) => Some(
                m.parse::<ModeRequest>()
                    .map_err(|e| invalid("hardware.projector_mode", e.to_string()))?,
            ),
        };
        let gamma = raw.projector_gamma.unwrap_or(2.2);
        if Gamma::new(gamma).is_none() {
            return Err(invalid(
                "hardware.projector_gamma",
                format!("{gamma}: expected the projector's video gamma, e.g. 2.2"),
            ));
        }
        return Ok(Some(ProjectorSource::Drm {
            card: raw
                .projector_card
                .clone()
                .unwrap_or_else(|| PathBuf::from("/dev/dri/card0")),
            connector,
            mode,
            latency: latency(100)?,
            gamma,
        }));
    }
    if choice == "lightcrafter" || choice.starts_with("lightcrafter:") {
        let id = match choice.strip_prefix("lightcrafter:") {
            None => UsbId::LIGHTCRAFTER_4500,
            Some(id) => id
                .parse::<UsbId>()
                .map_err(|e| invalid("hardware.projector", e.to_string()))?,
        };
        return Ok(Some(ProjectorSource::LightCrafter {
            id,
            settle: latency(50)?,
        }));
    }
    Err(invalid(
        "hardware.projector",
        format!(
            "`{choice}`: expected `drm`, `drm:<connector>` (e.g. `drm:HDMI-A-1`), \
             `lightcrafter`, `lightcrafter:VVVV:PPPP` or `none`"
        ),
    ))
}

fn simulated(
    raw: RawSimulated,
    invalid: &dyn Fn(&str, String) -> ConfigError,
) -> Result<SimulatedRigConfig, ConfigError> {
    let kind = match raw.kind.as_deref() {
        None => SceneKind::TwoMat,
        Some(k) => k
            .parse::<SceneKind>()
            .map_err(|e| invalid("simulated.kind", e.to_string()))?,
    };
    let geometry = match raw.geometry.as_deref() {
        None | Some("random") => None,
        Some(g) => Some(
            g.parse::<GeometryKind>()
                .map_err(|e| invalid("simulated.geometry", format!("{e} or \"random\"")))?,
        ),
    };
    let size = raw.size.unwrap_or(64);
    if !(8..=4096).contains(&size) {
        return Err(invalid(
            "simulated.size",
            format!("{size}: expected 8 to 4096 pixels"),
        ));
    }
    let positions = raw.positions.unwrap_or(2);
    if !(1..=64).contains(&positions) {
        return Err(invalid(
            "simulated.positions",
            format!("{positions}: expected 1 to 64"),
        ));
    }
    let samples = raw.samples.unwrap_or(4);
    if samples == 0 {
        return Err(invalid(
            "simulated.samples",
            "expected at least 1 path per pixel".into(),
        ));
    }
    let frame =
        framing(raw.frame.unwrap_or(DEFAULT_FRAME)).map_err(|e| invalid("simulated.frame", e))?;
    let frame = match (&raw.rig_from, raw.frame) {
        (None, _) => frame,
        (Some(_), None | Some(0.0)) => None,
        (Some(_), Some(f)) => {
            return Err(invalid(
                "simulated.frame",
                format!(
                    "{f}: a rig taken from a scan (rig_from) keeps its own aim; leave frame out"
                ),
            ))
        }
    };
    let mut dead_lights = Vec::new();
    for name in &raw.faults.dead_lights {
        let light = matscan_drivers::LightId::from_name(name).ok_or_else(|| {
            invalid(
                "simulated.faults.dead_lights",
                format!("unknown light `{name}`: expected flash0, flash1 or backlight"),
            )
        })?;
        dead_lights.push(light);
    }
    Ok(SimulatedRigConfig {
        seed: raw.seed.unwrap_or(1),
        kind,
        geometry,
        size,
        positions,
        samples,
        frame,
        rig_from: raw.rig_from,
        turntable: raw.turntable.unwrap_or(true),
        footswitch: match raw.footswitch {
            Some(p) if p.as_os_str().is_empty() => {
                return Err(invalid(
                    "simulated.footswitch",
                    "expected the path of a named pipe".into(),
                ))
            }
            other => other,
        },
        faults: FaultConfig {
            camera_lost_after: raw.faults.camera_lost_after,
            lights_silent_after: raw.faults.lights_silent_after,
            dead_lights,
            disk_capacity: raw.faults.disk_capacity,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Config, ConfigError> {
        Config::parse(text, Path::new("matscan.toml"))
    }

    #[test]
    fn the_packaged_example_config_is_valid() {
        let text = include_str!("../../../packaging/matscan.toml");
        let c = Config::parse(text, Path::new("packaging/matscan.toml")).unwrap();
        assert!(matches!(c.rig, RigChoice::Simulated(_)));
        assert!(c.profiles.contains_key("opaque"));
        // With its commented lines switched on, too.
        let on = text
            .replace("# socket_group", "socket_group")
            .replace("# footswitch", "footswitch");
        let c = Config::parse(&on, Path::new("packaging/matscan.toml")).unwrap();
        assert_eq!(c.socket_group.as_deref(), Some("scanner"));
        assert!(c.rig.has_footswitch());
    }

    #[test]
    fn the_packaged_calibration_config_is_valid() {
        let text = include_str!("../../../packaging/calib-sim.toml");
        let c = Config::parse(text, Path::new("packaging/calib-sim.toml")).unwrap();
        let RigChoice::Simulated(sim) = &c.rig else {
            panic!("a simulated rig");
        };
        assert_eq!(sim.frame, None, "the unframed, rigid head");
        assert_eq!(c.calibration.projector_shots, 12);
        assert!(!c.estimate.enabled);
    }

    #[test]
    fn minimal_config_takes_the_documented_defaults() {
        let c = parse("rig = \"simulated\"").unwrap();
        assert_eq!(c.socket, PathBuf::from(DEFAULT_SOCKET));
        assert_eq!(c.scans, PathBuf::from(DEFAULT_SCANS));
        assert_eq!(c.busy, BusyPolicy::Queue { limit: 4 });
        assert_eq!(c.default_profile, FULL_PROFILE);
        assert_eq!(c.capture, CaptureSettings::default());
        assert_eq!(c.estimate, EstimateSettings::default());
        let RigChoice::Simulated(s) = &c.rig else {
            panic!("not simulated: {:?}", c.rig);
        };
        assert_eq!(
            (s.size, s.positions, s.samples, s.turntable, s.frame),
            (64, 2, 4, true, Some(DEFAULT_FRAME))
        );
        let thesis = parse("rig = \"simulated\"\n[simulated]\nframe = 0").unwrap();
        let RigChoice::Simulated(s) = &thesis.rig else {
            panic!("not simulated: {:?}", thesis.rig);
        };
        assert_eq!(s.frame, None, "frame = 0 keeps the random framing");
    }

    #[test]
    fn profiles_name_given_parameters() {
        let c = parse(
            "rig = \"simulated\"\ndefault_profile = \"glass\"\n\
             [profiles.glass]\ngiven = [\"transmission\", \"subsurface\"]",
        )
        .unwrap();
        let given: Vec<Param> = c.profiles["glass"].given.iter().copied().collect();
        assert_eq!(given, vec![Param::Transmission, Param::Subsurface]);
        assert!(c.profiles[FULL_PROFILE].given.is_empty());
    }

    #[test]
    fn errors_name_the_file_and_the_key() {
        let cases = [
            ("rig = \"v4l2\"", "`rig`: unknown rig `v4l2`"),
            ("rig = \"hardware\"", "`hardware`: rig = \"hardware\" needs a [hardware]"),
            (
                "rig = \"hardware\"\n[hardware]\ncamera = \"/dev/video0\"",
                "`hardware.lights`: missing",
            ),
            (
                "rig = \"hardware\"\n[hardware]\ncamera = \"/dev/video0\"\nlights = \"/dev/ttyACM0\"\n\
                 footswitch = \"/dev/input/event3\"\ncalibration = \"/etc/matscan/rig.toml\"\n\
                 mesh = \"/x.ply\"\nwidth = 1920",
                "`hardware.width`: missing",
            ),
            ("rig = \"simulated\"\nbusy = \"drop\"", "`busy`: `drop`"),
            (
                "rig = \"simulated\"\n[profiles.x]\ngiven = [\"shininess\"]",
                "`profiles.x.given`: unknown parameter `shininess`",
            ),
            (
                "rig = \"simulated\"\ndefault_profile = \"nope\"",
                "no profile `nope`",
            ),
            (
                "rig = \"simulated\"\n[simulated]\nsize = 2",
                "`simulated.size`: 2",
            ),
            (
                "rig = \"simulated\"\n[simulated]\nframe = 1.5",
                "`simulated.frame`: 1.5: expected the object's share",
            ),
            (
                "rig = \"simulated\"\n[simulated.faults]\ndead_lights = [\"flash7\"]",
                "unknown light `flash7`",
            ),
            (
                "rig = \"simulated\"\nsockett = \"/x\"",
                "unknown field `sockett`",
            ),
            ("socket = \"/x\"", "missing field `rig`"),
            (
                "rig = \"simulated\"\n[estimate]\nweights = \"/nonexistent/w\"",
                "`estimate.weights`: /nonexistent/w: expected a folder",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nboard = [9, 6]",
                "`calibration.square`: missing",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nboard = [6, 6]\nsquare = 0.03",
                "`calibration.board`: [6, 6]: expected the board's inner corners",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nboard = [9, 6]\nsquare = 30",
                "`calibration.square`: 30: expected the edge of one square in metres",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nboard = [9, 6]\nsquare = 0.03\n\
                 reference_to_world = [2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]",
                "`calibration.reference_to_world`: expected a rigid transform",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nresting_frames = 0",
                "`calibration.resting_frames`: resting_frames = 0: expected 1 to 64",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nheld_frames = 65",
                "`calibration.held_frames`: held_frames = 65: expected 1 to 64",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nshots = 0",
                "`calibration.shots`: shots = 0",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nsphere_radius = 0",
                "`calibration.sphere_radius`: 0: expected the sphere's radius",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nsphere_placements = 1",
                "`calibration.sphere_placements`: 1: expected 2 to 64",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nwhite_albedo = 1.2",
                "`calibration.white_albedo`: 1.2: expected the white card's reflectance",
            ),
            (
                "rig = \"simulated\"\n[calibration]\nwhite_exposures = 9",
                "`calibration.white_exposures`: 9: expected 1 to 6",
            ),
            (
                "rig = \"simulated\"\n[simulated]\nrig_from = \"scan\"\nframe = 0.8",
                "`simulated.frame`: 0.8: a rig taken from a scan (rig_from) keeps its own aim",
            ),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with("matscan.toml: "), "{e}");
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }

    #[test]
    fn a_hardware_rig_takes_its_paths_and_documented_defaults() {
        let c = parse(
            "rig = \"hardware\"\n[hardware]\ncamera = \"/dev/v4l/by-id/cam\"\n\
             lights = \"/dev/serial/by-id/lights\"\nfootswitch = \"/dev/input/by-id/fs\"\n\
             calibration = \"/etc/matscan/rig.toml\"\nmesh = \"/var/lib/matscan/object.ply\"\n\
             width = 1920\nheight = 1080\nfootswitch_keys = [30]",
        )
        .unwrap();
        let RigChoice::Hardware(h) = &c.rig else {
            panic!("not hardware: {:?}", c.rig);
        };
        assert_eq!(h.camera, CameraSource::V4l2("/dev/v4l/by-id/cam".into()));
        assert_eq!(
            h.footswitch,
            FootswitchSource::Evdev("/dev/input/by-id/fs".into())
        );
        assert_eq!(h.projector, None, "no projector unless configured");
        assert_eq!(
            (h.checker_periods.0.get(), h.checker_periods.1.get()),
            (8, 32)
        );
        assert_eq!((h.width, h.height, h.baud), (1920, 1080, 115_200));
        assert_eq!(h.exposure_s, 0.02);
        assert_eq!(h.footswitch_keys, vec![30]);
        assert_eq!(h.mesh, PathBuf::from("/var/lib/matscan/object.ply"));
        assert!(c
            .rig
            .describe()
            .starts_with("hardware (camera /dev/v4l/by-id/cam"));
    }

    const HARDWARE: &str = "rig = \"hardware\"\n[hardware]\ncamera = \"/dev/v4l/by-id/cam\"\n\
         lights = \"/dev/ttyACM0\"\nfootswitch = \"/dev/input/by-id/fs\"\n\
         calibration = \"/etc/matscan/rig.toml\"\nmesh = \"/tmp/object.ply\"\n\
         width = 1920\nheight = 1080\n";

    fn hardware_with(extra: &str) -> Result<HardwareRigConfig, ConfigError> {
        let c = parse(&format!("{HARDWARE}{extra}"))?;
        match c.rig {
            RigChoice::Hardware(h) => Ok(h),
            other => panic!("not hardware: {other:?}"),
        }
    }

    #[test]
    fn projector_footswitch_and_camera_sources_parse_with_their_defaults() {
        let h = hardware_with(
            "projector = \"drm:HDMI-A-1\"\nprojector_mode = \"1280x800@60\"\nfootswitch_keys = [48]\n",
        )
        .unwrap();
        let Some(ProjectorSource::Drm {
            card,
            connector,
            mode,
            latency,
            gamma,
        }) = &h.projector
        else {
            panic!("not drm: {:?}", h.projector);
        };
        assert_eq!(card, &PathBuf::from("/dev/dri/card0"));
        assert_eq!(connector.as_deref(), Some("HDMI-A-1"));
        assert_eq!(mode, &Some("1280x800@60".parse::<ModeRequest>().unwrap()));
        assert_eq!((*latency, *gamma), (Duration::from_millis(100), 2.2));

        let h =
            hardware_with("projector = \"drm\"\nprojector_card = \"/dev/dri/card1\"\n").unwrap();
        assert!(matches!(
            &h.projector,
            Some(ProjectorSource::Drm { card, connector: None, mode: None, .. })
                if card == &PathBuf::from("/dev/dri/card1")
        ));

        let h = hardware_with("projector = \"lightcrafter\"\nprojector_latency_ms = 80\n").unwrap();
        assert_eq!(
            h.projector,
            Some(ProjectorSource::LightCrafter {
                id: UsbId::LIGHTCRAFTER_4500,
                settle: Duration::from_millis(80)
            })
        );
        assert_eq!(
            hardware_with("projector = \"none\"\n").unwrap().projector,
            None
        );

        let c = parse(&HARDWARE.replace("/dev/input/by-id/fs", "usb:0c45:7403")).unwrap();
        let RigChoice::Hardware(h) = &c.rig else {
            panic!("not hardware")
        };
        assert_eq!(
            h.footswitch,
            FootswitchSource::Usb(UsbId {
                vendor: 0x0c45,
                product: 0x7403
            })
        );
        assert!(
            c.rig.describe().contains("footswitch usb:0c45:7403"),
            "{}",
            c.rig.describe()
        );
        let c = parse(&HARDWARE.replace("/dev/v4l/by-id/cam", "nokhwa:0")).unwrap();
        let RigChoice::Hardware(h) = &c.rig else {
            panic!("not hardware")
        };
        assert_eq!(h.camera, CameraSource::Nokhwa("0".into()));
        let h = hardware_with("checker_periods = [4, 16]\n").unwrap();
        assert_eq!(
            (h.checker_periods.0.get(), h.checker_periods.1.get()),
            (4, 16)
        );
    }

    #[test]
    fn bad_projector_footswitch_and_period_settings_name_the_key() {
        let cases: [(&str, &str, &str); 7] = [
            (
                "projector = \"vga\"\n",
                "hardware.projector",
                "expected `drm`",
            ),
            (
                "projector = \"drm\"\nprojector_mode = \"big\"\n",
                "hardware.projector_mode",
                "big",
            ),
            (
                "projector = \"drm\"\nprojector_gamma = -1.0\n",
                "hardware.projector_gamma",
                "-1",
            ),
            (
                "projector_mode = \"1280x800\"\n",
                "hardware.projector_mode",
                "only applies to a DRM projector",
            ),
            (
                "projector = \"lightcrafter:nope\"\n",
                "hardware.projector",
                "nope",
            ),
            (
                "checker_periods = [7, 32]\n",
                "hardware.checker_periods",
                "[7, 32]: expected two even periods",
            ),
            (
                "projector = \"drm\"\nprojector_latency_ms = 60000\n",
                "hardware.projector_latency_ms",
                "at most 10000",
            ),
        ];
        for (extra, key, want) in cases {
            let e = hardware_with(extra).unwrap_err().to_string();
            assert!(e.contains(&format!("`{key}`")), "{extra:?}: {e}");
            assert!(e.contains(want), "{extra:?}: {e}");
        }
        let e = parse(&HARDWARE.replace("/dev/input/by-id/fs", "usb:12"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`hardware.footswitch`") && e.contains("12"),
            "{e}"
        );
        let e = parse(&HARDWARE.replace("/dev/v4l/by-id/cam", "nokhwa:"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`hardware.camera`") && e.contains("nokhwa:0"),
            "{e}"
        );
    }
}
