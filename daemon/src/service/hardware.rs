//! `rig = "hardware"`: the real drivers behind the sequencer's traits — a
//! V4L2 or nokhwa camera, the serial light controller (two flashes and the
//! backlight panel), the footswitch (evdev, raw USB or a named pipe), the
//! projector (DRM/KMS or a LightCrafter, optional) — and the rig's geometry from files the
//! scanner PC keeps: a rig calibration file and the object's mesh as the
//! 3D scanner's software exports it.
//!
//! The rig calibration file is a scan manifest (`scan.toml` of the scan
//! format) without captures: `units`, `[camera]` intrinsics and one
//! `[[positions]]` entry per position with its `camera_to_world` and its
//! lights (flashes `flash0` and `flash1` as point lights, optionally
//! `backlight` and a projector). Reusing the manifest means one parser, one
//! set of validated error messages, and that a calibrated scan's own
//! `scan.toml` serves as the rig file. Captures in it are ignored.
//!
//! The mesh is re-read at every capture ([`RigDevices::reload_mesh`] with
//! `mesh_source`), since the scanner software writes each new object's mesh
//! to the same path before the operator presses the footswitch.
//!
//! A rig without a projector (`projector` unset) gets a capture plan
//! without projector photos, with that reason, and the estimator skips
//! subsurface (no checker capture). The cameras, the projectors and the
//! raw USB footswitch need the `hardware` feature (libclang at build
//! time); a build without it says so when the rig is opened, and the
//! daemon keeps serving. The serial lights and the evdev and named-pipe
//! footswitches build everywhere.
//!
//! Boundaries: opens devices and reads files; takes no photo.

use super::config::{CameraSource, FootswitchSource, HardwareRigConfig, ProjectorSource};
use super::sequencer::{PositionPose, RigDevices, RigGeometry};
use matscan_drivers::footswitch::evdev::EvdevFootswitch;
use matscan_drivers::lights::{open_lights, HostConfig};
use matscan_drivers::{Camera, DriverError, Projector, Trigger};
use matscan_scan::{LightKind, Manifest, Mesh, ScanError};
use std::path::{Path, PathBuf};

/// Opening the hardware rig failed.
#[derive(Debug, thiserror::Error)]
pub enum HardwareError {
    #[error("rig calibration {path}: {source}")]
    Calibration {
        path: PathBuf,
        #[source]
        source: ScanError,
    },
    #[error("rig calibration {path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("object mesh {path}: {source}")]
    Mesh {
        path: PathBuf,
        #[source]
        source: ScanError,
    },
    #[error(transparent)]
    Driver(#[from] DriverError),
    /// The simulated rig's scene could not be framed.
    #[error("simulated.frame: {0}")]
    Framing(#[from] matscan_sim::scene::FramingError),
}

/// The rig's geometry: the calibration file's cameras and lights with the
/// mesh at `config.mesh`.
pub fn load_geometry(config: &HardwareRigConfig) -> Result<RigGeometry, HardwareError> {
    let mut geometry = load_geometry_without_mesh(config)?;
    geometry.mesh = read_mesh(&config.mesh)?;
    Ok(geometry)
}

/// The calibration file's cameras and lights, validated, with no mesh.
fn load_geometry_without_mesh(config: &HardwareRigConfig) -> Result<RigGeometry, HardwareError> {
    let path = &config.calibration;
    let (manifest, _warnings) =
        Manifest::read_rig(path).map_err(|source| HardwareError::Calibration {
            path: path.clone(),
            source,
        })?;
    let invalid = |message: String| HardwareError::Invalid {
        path: path.clone(),
        message,
    };
    if manifest.positions.is_empty() {
        return Err(invalid(
            "no [[positions]]: expected one per rig position".into(),
        ));
    }
    let (cw, ch) = (manifest.camera.width, manifest.camera.height);
    if (cw, ch) != (config.width, config.height) {
        return Err(invalid(format!(
            "the calibrated camera is {cw}x{ch}, the configured capture size \
             (hardware.width, hardware.height) is {}x{}",
            config.width, config.height
        )));
    }
    for position in &manifest.positions {
        for flash in ["flash0", "flash1"] {
            let found = position.lights.iter().find(|l| l.name == flash);
            if !matches!(found.map(|l| &l.kind), Some(LightKind::Point { .. })) {
                return Err(invalid(format!(
                    "position `{}`: expected a point light named `{flash}` (the light \
                     controller's flash channel)",
                    position.name
                )));
            }
        }
    }
    if config.projector.is_some() {
        for position in &manifest.positions {
            let has = position
                .lights
                .iter()
                .any(|l| matches!(l.kind, LightKind::Projector { .. }));
            if !has {
                return Err(invalid(format!(
                    "position `{}`: hardware.projector is set, but no light of kind \
                     `projector` is calibrated here (add its pose and intrinsics, or remove \
                     hardware.projector)",
                    position.name
                )));
            }
        }
    }
    Ok(RigGeometry {
        name: manifest.name.clone(),
        mesh: Mesh::default(),
        intrinsics: manifest.camera,
        positions: manifest
            .positions
            .iter()
            .map(|p| PositionPose {
                name: p.name.clone(),
                camera_to_world: p.camera_to_world,
                lights: p.lights.clone(),
                exposure_s: config.exposure_s,
            })
            .collect(),
        checker_periods: config.checker_periods,
    })
}

/// The object's mesh at `path` (PLY or OBJ, as the contract reads them).
fn read_mesh(path: &Path) -> Result<Mesh, HardwareError> {
    matscan_scan::mesh_io::read_mesh(path).map_err(|source| HardwareError::Mesh {
        path: path.to_path_buf(),
        source,
    })
}

/// The devices of a hardware rig besides its light controller, which is
/// always the serial board at `config.lights`.
pub struct Devices {
    pub camera: Box<dyn Camera>,
    pub projector: Option<Box<dyn Projector>>,
    pub trigger: Box<dyn Trigger>,
}

/// Opens every device of the hardware rig; the geometry first, since a
/// wrong file is the likeliest mistake and needs no device.
pub fn open(config: &HardwareRigConfig) -> Result<RigDevices, HardwareError> {
    let geometry = load_geometry(config)?;
    let camera = open_camera(&config.camera, config)?;
    let projector = match &config.projector {
        None => None,
        Some(source) => {
            let projector = open_projector(source)?;
            check_projector_size(config, &geometry, projector.as_ref())?;
            Some(projector)
        }
    };
    let trigger = open_footswitch(&config.footswitch, &config.footswitch_keys)?;
    let devices = Devices {
        camera,
        projector,
        trigger,
    };
    assemble(config, geometry, devices)
}

/// Opens every device of the hardware rig for a calibration capture. The
/// geometry is the calibration file's when it exists (its positions and
/// exposure); a rig calibrated for the first time has none, and is
/// photographed at `positions` positions named `p0`, `p1`, ... The object's
/// mesh is not read: a calibration photographs a board.
pub fn open_for_calibration(
    config: &HardwareRigConfig,
    positions: usize,
) -> Result<RigDevices, HardwareError> {
    let geometry = if config.calibration.exists() {
        load_geometry_without_mesh(config)?
    } else {
        tracing::info!(
            "{} does not exist yet: photographing the board at {positions} position(s)",
            config.calibration.display()
        );
        uncalibrated_geometry(config, positions)
    };
    let camera = open_camera(&config.camera, config)?;
    let projector = match &config.projector {
        None => None,
        Some(source) => Some(open_projector(source)?),
    };
    let trigger = open_footswitch(&config.footswitch, &config.footswitch_keys)?;
    let mut rig = assemble(
        config,
        geometry,
        Devices {
            camera,
            projector,
            trigger,
        },
    )?;
    rig.mesh_source = None;
    Ok(rig)
}

/// A rig without calibration: `positions` positions at the configured
/// exposure, nothing known of their poses or lights.
fn uncalibrated_geometry(config: &HardwareRigConfig, positions: usize) -> RigGeometry {
    let f = f64::from(config.width.max(config.height));
    RigGeometry {
        name: "uncalibrated rig".into(),
        mesh: Mesh::default(),
        intrinsics: matscan_scan::Intrinsics {
            width: config.width,
            height: config.height,
            fx: f,
            fy: f,
            cx: f64::from(config.width) / 2.0,
            cy: f64::from(config.height) / 2.0,
            distortion: [0.0; 5],
        },
        positions: (0..positions.max(1))
            .map(|i| PositionPose {
                name: format!("p{i}"),
                camera_to_world: glam::DMat4::IDENTITY,
                lights: Vec::new(),
                exposure_s: config.exposure_s,
            })
            .collect(),
        checker_periods: config.checker_periods,
    }
}

/// The hardware rig with `devices` standing in for the configured camera,
/// projector and footswitch; the geometry files and the light controller's
/// serial port are the configured ones. The end-to-end test drives the
/// real serial driver this way against a board on a pseudo-terminal.
pub fn open_with(
    config: &HardwareRigConfig,
    devices: Devices,
) -> Result<RigDevices, HardwareError> {
    let geometry = load_geometry(config)?;
    assemble(config, geometry, devices)
}

fn assemble(
    config: &HardwareRigConfig,
    geometry: RigGeometry,
    devices: Devices,
) -> Result<RigDevices, HardwareError> {
    let lights = open_lights(&config.lights, config.baud, HostConfig::default())?;
    Ok(RigDevices {
        camera: devices.camera,
        lights: Box::new(lights),
        projector: devices.projector,
        positioner: None,
        trigger: Some(devices.trigger),
        disk: None,
        geometry,
        truth: None,
        mesh_source: Some(config.mesh.clone()),
        calibration_target: None,
        hand: None,
        sphere_radius: None,
    })
}

/// The error of a device this build cannot drive.
#[cfg(not(feature = "hardware"))]
fn not_built(device: String, what: &str) -> HardwareError {
    HardwareError::Driver(DriverError::InvalidSetting {
        device,
        reason: format!(
            "this matscan was built without {what}; rebuild with \
             `cargo build --release -p matscan --features hardware` (needs libclang-dev)"
        ),
    })
}

#[cfg(feature = "hardware")]
fn open_camera(
    source: &CameraSource,
    config: &HardwareRigConfig,
) -> Result<Box<dyn Camera>, HardwareError> {
    use matscan_drivers::camera::nokhwa::{CameraSelector, NokhwaCamera, NokhwaConfig};
    use matscan_drivers::camera::v4l2::{V4l2Camera, V4l2Config};
    Ok(match source {
        CameraSource::V4l2(path) => Box::new(V4l2Camera::open(V4l2Config::new(
            path,
            config.width,
            config.height,
        ))?),
        CameraSource::Nokhwa(selector) => Box::new(NokhwaCamera::open(NokhwaConfig::new(
            CameraSelector::parse(selector),
            config.width,
            config.height,
        ))?),
    })
}

#[cfg(not(feature = "hardware"))]
fn open_camera(
    source: &CameraSource,
    _config: &HardwareRigConfig,
) -> Result<Box<dyn Camera>, HardwareError> {
    let what = match source {
        CameraSource::V4l2(_) => "V4L2 support",
        CameraSource::Nokhwa(_) => "the nokhwa camera backend",
    };
    Err(not_built(source.to_string(), what))
}

#[cfg(feature = "hardware")]
fn open_projector(source: &ProjectorSource) -> Result<Box<dyn Projector>, HardwareError> {
    use matscan_drivers::projector::kms::{DrmConfig, DrmProjector};
    use matscan_drivers::projector::lightcrafter::{LightCrafter, LightCrafterConfig};
    Ok(match source {
        ProjectorSource::Drm {
            card,
            connector,
            mode,
            latency,
            gamma,
        } => Box::new(DrmProjector::open(DrmConfig {
            connector: connector.clone(),
            mode: *mode,
            latency: *latency,
            gamma: *gamma,
            ..DrmConfig::new(card)
        })?),
        ProjectorSource::LightCrafter { id, settle } => {
            Box::new(LightCrafter::open(LightCrafterConfig {
                id: *id,
                settle: *settle,
                ..LightCrafterConfig::default()
            })?)
        }
    })
}

#[cfg(not(feature = "hardware"))]
fn open_projector(source: &ProjectorSource) -> Result<Box<dyn Projector>, HardwareError> {
    let what = match source {
        ProjectorSource::Drm { .. } => "DRM/KMS projector support",
        ProjectorSource::LightCrafter { .. } => "USB (LightCrafter) support",
    };
    Err(not_built(source.to_string(), what))
}

fn open_footswitch(
    source: &FootswitchSource,
    keys: &[u16],
) -> Result<Box<dyn Trigger>, HardwareError> {
    match source {
        FootswitchSource::Evdev(path) => Ok(Box::new(EvdevFootswitch::open(path, keys.to_vec())?)),
        #[cfg(feature = "hardware")]
        FootswitchSource::Usb(id) => Ok(Box::new(
            matscan_drivers::footswitch::usb::UsbFootswitch::open(*id, keys.to_vec())?,
        )),
        #[cfg(not(feature = "hardware"))]
        FootswitchSource::Usb(_) => Err(not_built(source.to_string(), "raw USB support")),
        FootswitchSource::Pipe(path) => Ok(Box::new(
            matscan_drivers::footswitch::pipe::PipeTrigger::open(path)?,
        )),
    }
}

/// The projector must show the resolution its calibration describes, or
/// every checker square lands somewhere else than the estimator assumes.
fn check_projector_size(
    config: &HardwareRigConfig,
    geometry: &RigGeometry,
    projector: &dyn Projector,
) -> Result<(), HardwareError> {
    let shown = projector.resolution();
    for position in &geometry.positions {
        for light in &position.lights {
            if let LightKind::Projector { intrinsics, .. } = &light.kind {
                if (intrinsics.width, intrinsics.height) != shown {
                    return Err(HardwareError::Invalid {
                        path: config.calibration.clone(),
                        message: format!(
                            "position `{}`: the projector `{}` is calibrated at {}x{}, but {} \
                             shows {}x{} (set hardware.projector_mode or recalibrate)",
                            position.name,
                            light.name,
                            intrinsics.width,
                            intrinsics.height,
                            projector.id(),
                            shown.0,
                            shown.1
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
    use std::num::NonZeroU32;

    /// The simulated scene the rig files of these tests describe.
    fn rig_scene() -> matscan_sim::scene::Scene {
        generate(&SceneOptions {
            seed: 3,
            kind: SceneKind::TwoMat,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: 32,
            height: 32,
            positions: 2,
            map_size: 8,
        })
    }

    /// A rig calibration file and a mesh written from a simulated scene,
    /// as a scanner PC would keep them.
    fn rig_files(dir: &Path) -> HardwareRigConfig {
        let scene = rig_scene();
        let geometry = super::super::rig::geometry_of(&scene, 32);
        let manifest = Manifest {
            units: "m".into(),
            name: "rig".into(),
            created: "2026-11-23T00:00:00Z".into(),
            camera: geometry.intrinsics,
            positions: geometry
                .positions
                .iter()
                .map(|p| matscan_scan::Position {
                    name: p.name.clone(),
                    camera_to_world: p.camera_to_world,
                    lights: p.lights.clone(),
                    captures: vec![],
                    white_reference_mask: None,
                })
                .collect(),
        };
        let calibration = dir.join("rig.toml");
        std::fs::write(&calibration, manifest.to_toml()).unwrap();
        let mesh = dir.join("object.ply");
        matscan_scan::mesh_io::write_ply(&mesh, &scene.mesh).unwrap();
        HardwareRigConfig {
            camera: CameraSource::V4l2("/dev/v4l/by-id/usb-test-video-index0".into()),
            width: 32,
            height: 32,
            exposure_s: 0.02,
            lights: dir.join("no-such-serial-port").display().to_string(),
            baud: 115_200,
            footswitch: FootswitchSource::Evdev("/dev/input/by-id/no-such-footswitch".into()),
            footswitch_keys: vec![],
            projector: None,
            checker_periods: (NonZeroU32::new(8).unwrap(), NonZeroU32::new(32).unwrap()),
            calibration,
            mesh,
        }
    }

    #[test]
    fn the_rig_file_and_mesh_give_the_geometry_of_every_position() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let g = load_geometry(&config).unwrap();
        assert_eq!(g.positions.len(), 2);
        assert_eq!(g.positions[1].name, "p1");
        assert_eq!((g.intrinsics.width, g.intrinsics.height), (32, 32));
        assert!(g.positions.iter().all(|p| p.exposure_s == 0.02));
        assert!(g.mesh.triangle_count() > 100, "{}", g.mesh.triangle_count());
    }

    #[test]
    fn a_rig_file_without_a_flash_or_of_the_wrong_size_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let text = std::fs::read_to_string(&config.calibration).unwrap();
        let wrong_size = HardwareRigConfig {
            width: 64,
            ..config.clone()
        };
        let e = load_geometry(&wrong_size).unwrap_err().to_string();
        assert!(
            e.contains("rig.toml") && e.contains("32x32") && e.contains("64x32"),
            "{e}"
        );

        std::fs::write(
            &config.calibration,
            text.replace("\"flash1\"", "\"flash9\""),
        )
        .unwrap();
        let e = load_geometry(&config).unwrap_err().to_string();
        assert!(e.contains("rig.toml"), "{e}");
        assert!(e.contains("point light named `flash1`"), "{e}");
    }

    /// A hardware rig's geometry and projector without any other device,
    /// to ask what it can capture.
    fn device_less(geometry: RigGeometry, projector: Option<Box<dyn Projector>>) -> RigDevices {
        RigDevices {
            camera: Box::new(NoCamera),
            lights: Box::new(NoLights),
            projector,
            positioner: None,
            trigger: None,
            disk: None,
            geometry,
            truth: None,
            mesh_source: None,
            calibration_target: None,
            hand: None,
            sphere_radius: None,
        }
    }

    /// A projector of a fixed resolution that shows uniform levels only.
    struct FixedProjector((u32, u32));

    impl Projector for FixedProjector {
        fn id(&self) -> &str {
            "drm:/dev/dri/card0:HDMI-A-1"
        }
        fn resolution(&self) -> (u32, u32) {
            self.0
        }
        fn show(&mut self, _: matscan_drivers::ProjectorPattern) -> Result<(), DriverError> {
            Ok(())
        }
        fn pattern(&self) -> matscan_drivers::ProjectorPattern {
            matscan_drivers::ProjectorPattern::Black
        }
        fn can_show(&self, pattern: &matscan_drivers::ProjectorPattern) -> bool {
            !matches!(pattern, matscan_drivers::ProjectorPattern::Checker(_))
        }
    }

    #[test]
    fn a_projector_that_cannot_show_checkers_gets_a_plan_without_them() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let geometry = load_geometry(&config).unwrap();
        let rig = device_less(geometry, Some(Box::new(FixedProjector((32, 32)))));
        let caps = rig.capabilities();
        assert!(
            caps.projector && !caps.checkers && caps.backlight,
            "{caps:?}"
        );
        let plan = crate::service::plan::plan(
            &crate::service::config::Profile::default(),
            rig.geometry.checker_periods,
            caps,
        );
        let names: Vec<&str> = plan.captures.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            ["ambient", "flash0", "flash1", "projector", "backlight"]
        );
    }

    #[test]
    fn a_projector_showing_another_resolution_than_calibrated_is_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let geometry = load_geometry(&config).unwrap();
        let calibrated = geometry.positions[0]
            .lights
            .iter()
            .find_map(|l| match &l.kind {
                LightKind::Projector { intrinsics, .. } => {
                    Some((intrinsics.width, intrinsics.height))
                }
                _ => None,
            })
            .expect("the simulated rig file calibrates a projector");
        assert!(check_projector_size(&config, &geometry, &FixedProjector(calibrated)).is_ok());
        let e = check_projector_size(&config, &geometry, &FixedProjector((1280, 800)))
            .unwrap_err()
            .to_string();
        let want = format!("calibrated at {}x{}", calibrated.0, calibrated.1);
        assert!(e.contains("rig.toml") && e.contains(&want), "{e}");
        assert!(e.contains("HDMI-A-1 shows 1280x800"), "{e}");
    }

    #[test]
    fn a_configured_projector_without_a_calibrated_one_is_refused_naming_the_position() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let text = std::fs::read_to_string(&config.calibration).unwrap();
        let (manifest, _) = Manifest::parse_rig(&text, &config.calibration).unwrap();
        let without: Vec<_> = manifest
            .positions
            .iter()
            .map(|p| matscan_scan::Position {
                lights: p
                    .lights
                    .iter()
                    .filter(|l| !matches!(l.kind, LightKind::Projector { .. }))
                    .cloned()
                    .collect(),
                ..p.clone()
            })
            .collect();
        let manifest = Manifest {
            positions: without,
            ..manifest
        };
        std::fs::write(&config.calibration, manifest.to_toml()).unwrap();
        assert!(
            load_geometry(&config).is_ok(),
            "no projector configured: fine"
        );
        let with_projector = HardwareRigConfig {
            projector: Some(ProjectorSource::LightCrafter {
                id: matscan_drivers::usb::UsbId::LIGHTCRAFTER_4500,
                settle: std::time::Duration::from_millis(50),
            }),
            ..config
        };
        let e = load_geometry(&with_projector).unwrap_err().to_string();
        assert!(
            e.contains("position `p0`") && e.contains("kind `projector`"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_mesh_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let config = HardwareRigConfig {
            mesh: dir.path().join("gone.ply"),
            ..rig_files(dir.path())
        };
        let e = load_geometry(&config).unwrap_err().to_string();
        assert!(e.starts_with("object mesh "), "{e}");
        assert!(e.contains("gone.ply"), "{e}");
    }

    #[test]
    fn opening_names_the_first_device_that_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let e = match open(&config) {
            Ok(_) => panic!("no device exists, yet the rig opened"),
            Err(e) => e.to_string(),
        };
        if cfg!(feature = "hardware") {
            assert!(e.contains("usb-test-video-index0"), "{e}");
        } else {
            assert!(e.contains("usb-test-video-index0"), "{e}");
            assert!(e.contains("--features hardware"), "{e}");
        }
    }

    #[test]
    fn a_rig_without_projector_plans_no_projector_photo() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let geometry = load_geometry(&config).unwrap();
        let has_backlight = geometry
            .positions
            .iter()
            .all(|p| p.lights.iter().any(|l| l.kind == LightKind::Backlight));
        assert!(has_backlight, "the simulated rig file has a backlight");
        // The capabilities a hardware rig reports, without opening devices.
        let rig = device_less(geometry, None);
        let caps = rig.capabilities();
        assert!(!caps.projector && caps.backlight, "{caps:?}");
    }

    #[test]
    fn reload_mesh_picks_up_the_scanners_new_export() {
        let dir = tempfile::tempdir().unwrap();
        let config = rig_files(dir.path());
        let geometry = load_geometry(&config).unwrap();
        let first = geometry.mesh.triangle_count();
        let mut rig = RigDevices {
            mesh_source: Some(config.mesh.clone()),
            ..device_less(geometry, None)
        };
        let other = generate(&SceneOptions {
            seed: 9,
            kind: SceneKind::TwoMat,
            geometry: GeometrySource::Kind(GeometryKind::Torus),
            width: 32,
            height: 32,
            positions: 1,
            map_size: 8,
        });
        matscan_scan::mesh_io::write_ply(&config.mesh, &other.mesh).unwrap();
        rig.reload_mesh().unwrap();
        assert_eq!(
            rig.geometry.mesh.triangle_count(),
            other.mesh.triangle_count()
        );
        assert_ne!(rig.geometry.mesh.triangle_count(), first);
        std::fs::remove_file(&config.mesh).unwrap();
        let e = rig.reload_mesh().unwrap_err().to_string();
        assert!(e.contains("object.ply"), "{e}");
    }

    struct NoCamera;
    impl Camera for NoCamera {
        fn id(&self) -> &str {
            "none"
        }
        fn resolution(&self) -> (u32, u32) {
            (0, 0)
        }
        fn lock(&mut self, _: matscan_drivers::CameraSettings) -> Result<(), DriverError> {
            Ok(())
        }
        fn settings(&self) -> matscan_drivers::CameraSettings {
            matscan_drivers::CameraSettings::default()
        }
        fn scene_changed(&mut self, _: std::time::Duration) {}
        fn capture(&mut self) -> Result<matscan_drivers::Frame, DriverError> {
            Err(DriverError::InvalidSetting {
                device: "none".into(),
                reason: "no camera".into(),
            })
        }
    }

    struct NoLights;
    impl matscan_drivers::LightController for NoLights {
        fn id(&self) -> &str {
            "none"
        }
        fn set(
            &mut self,
            _: matscan_drivers::LightId,
            _: matscan_drivers::LightState,
        ) -> Result<(), DriverError> {
            Ok(())
        }
        fn all_off(&mut self) -> Result<(), DriverError> {
            Ok(())
        }
        fn state(&self, _: matscan_drivers::LightId) -> matscan_drivers::LightState {
            matscan_drivers::LightState::Off
        }
    }

    /// The hardware rig as the daemon opens it, with the serial light
    /// controller on a real tty: the simulated board serves a
    /// pseudo-terminal's master end, the real `serialport` driver opens the
    /// slave by its /dev/pts path, and the simulated camera renders what
    /// the board's outputs and the projector really do.
    #[test]
    fn the_hardware_rig_captures_a_full_bundle_through_the_serial_board_on_a_tty() {
        use crate::service::config::Profile;
        use crate::service::plan::plan;
        use crate::service::sequencer::RunSettings;
        use matscan_drivers::lights::pty_pair;
        use matscan_drivers::sim_rig::{SimBench, SimConfig};
        use matscan_drivers::LightId;
        use std::time::Duration;

        let dir = tempfile::tempdir().unwrap();
        let (master, slave) = pty_pair().expect("openpty");
        let tty = slave.tty_path().expect("the pty slave's path");
        assert!(
            tty.starts_with("/dev/pts") || tty.starts_with("/proc/self/fd"),
            "{}",
            tty.display()
        );
        let config = HardwareRigConfig {
            lights: tty.display().to_string(),
            ..rig_files(dir.path())
        };
        let bench = SimBench::new(
            rig_scene(),
            SimConfig {
                width: 32,
                height: 32,
                samples: 1,
                ..SimConfig::default()
            },
            Box::new(master),
        )
        .unwrap();
        let button = bench.footswitch.clone();
        let board = bench.board;
        let mut rig = open_with(
            &config,
            Devices {
                camera: Box::new(bench.camera),
                projector: Some(Box::new(bench.projector)),
                trigger: Box::new(bench.trigger),
            },
        )
        .unwrap();
        let caps = rig.capabilities();
        assert!(caps.projector && caps.backlight, "{caps:?}");
        let plan = plan(&Profile::default(), rig.geometry.checker_periods, caps);
        assert!(plan.left_out.is_empty(), "{:?}", plan.left_out);
        let target = dir.path().join("scan-0001");
        let settings = RunSettings {
            light_retries: 1,
            min_light_difference: 1e-3,
            operator_timeout: Duration::from_secs(20),
        };
        // The operator presses at p1 (the object stays put: one scene).
        let outcome = crate::service::sequencer::capture_with_operator(
            &mut rig,
            &plan,
            &target,
            &settings,
            button,
            || {},
        )
        .unwrap();
        assert_eq!(outcome.positions, 2);
        assert_eq!(outcome.photos, 2 * plan.captures.len());
        assert_eq!(outcome.retries, 0, "every flash fired the first time");

        let bundle = matscan_scan::Bundle::open(&target).unwrap();
        let names: Vec<&str> = bundle.manifest.positions[1]
            .captures
            .iter()
            .map(|c| c.name.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "ambient",
                "flash0",
                "flash1",
                "projector",
                "backlight",
                "checker_8",
                "checker_32"
            ]
        );
        let mean = |name: &str| {
            let rgb = bundle.read_photo("p1", name).unwrap();
            rgb.data.iter().map(|p| p[0] + p[1] + p[2]).sum::<f32>() / rgb.data.len() as f32
        };
        let ambient = mean("ambient");
        for lit in ["flash0", "flash1", "projector", "backlight"] {
            assert!(
                mean(lit) > ambient + 1e-3,
                "{lit}: {} vs {ambient}",
                mean(lit)
            );
        }
        // Every command crossed the tty and the board ends dark.
        drop(rig);
        let board = board.board();
        assert!(board.executed() >= 2 * 4, "{} commands", board.executed());
        for light in LightId::ALL {
            assert_eq!(board.output(light), 0, "{light:?} left on");
        }
        drop(slave);
    }
}
