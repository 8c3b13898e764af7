//! The daemon's TOML configuration: parsed strictly (unknown keys are
//! errors, since a misspelt safety setting must not be silently ignored),
//! validated into types that cannot hold a wrong value, with defaults
//! documented on each field and in `docs/daemon-protocol.md`.
//!
//! Boundaries: reads text; opens no device and no socket.

use matscan_scan::Param;
use matscan_sim::scene::{GeometryKind, SceneKind};
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
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
    pub scans: PathBuf,
    pub busy: BusyPolicy,
    pub profiles: BTreeMap<String, Profile>,
    /// The profile of a capture request that names none.
    pub default_profile: String,
    pub capture: CaptureSettings,
    pub estimate: EstimateSettings,
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
    /// V4L2 device; prefer `/dev/v4l/by-id/...` (stable across boots).
    pub camera: String,
    /// Capture size in pixels; must match the calibrated intrinsics.
    pub width: u32,
    pub height: u32,
    /// Exposure of every photo, seconds.
    pub exposure_s: f32,
    /// The light controller's serial port (`/dev/serial/by-id/...`).
    pub lights: String,
    pub baud: u32,
    /// The footswitch's evdev node (`/dev/input/by-id/...-event-kbd`).
    pub footswitch: String,
    /// Key codes that count as a press; empty: any key.
    pub footswitch_keys: Vec<u16>,
    /// The rig calibration file: a scan manifest without captures.
    pub calibration: PathBuf,
    /// Where the scanner software exports the object's mesh (re-read at
    /// every capture).
    pub mesh: PathBuf,
}

impl RigChoice {
    pub fn describe(&self) -> String {
        match self {
            RigChoice::Hardware(h) => format!(
                "hardware (camera {}, lights {}, footswitch {}, calibration {}, mesh {})",
                h.camera,
                h.lights,
                h.footswitch,
                h.calibration.display(),
                h.mesh.display()
            ),
            RigChoice::Simulated(s) => format!(
                "simulated ({} scene, {} on {}, {} positions, {}x{} px, {})",
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
                format_args!("seed {}", s.seed),
            ),
        }
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
    /// With a turntable the sequencer turns the object; without one it
    /// waits for the operator's footswitch press between positions.
    pub turntable: bool,
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
    turntable: Option<bool>,
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
        Ok(Config {
            rig,
            estimate,
            socket: raw.socket.unwrap_or_else(|| PathBuf::from(DEFAULT_SOCKET)),
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
    let camera = required(raw.camera, "camera", "the camera's V4L2 device path")?;
    let lights = required(raw.lights, "lights", "the light controller's serial port")?;
    let footswitch = required(raw.footswitch, "footswitch", "the footswitch's evdev node")?;
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
        calibration,
        mesh,
    })
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
        turntable: raw.turntable.unwrap_or(true),
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
            (s.size, s.positions, s.samples, s.turntable),
            (64, 2, 4, true)
        );
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
        assert_eq!(h.camera, "/dev/v4l/by-id/cam");
        assert_eq!((h.width, h.height, h.baud), (1920, 1080, 115_200));
        assert_eq!(h.exposure_s, 0.02);
        assert_eq!(h.footswitch_keys, vec![30]);
        assert_eq!(h.mesh, PathBuf::from("/var/lib/matscan/object.ply"));
        assert!(c
            .rig
            .describe()
            .starts_with("hardware (camera /dev/v4l/by-id/cam"));
    }
}
