//! Opens the configured rig: for `rig = "hardware"`, the real drivers (see
//! [`super::hardware`]); for `rig = "simulated"`, a scene generated
//! from the config's seed behind the drivers' simulated rig, whose
//! geometry and calibration come from that same scene, and whose material
//! becomes the scan's truth maps (so estimates of simulated scans report
//! their error).
//!
//! Boundaries: builds a [`RigDevices`]; takes no photo.

use super::config::{CalibrationSettings, RigChoice, SimulatedRigConfig};
use super::hardware::HardwareError;
use super::sequencer::{CalibrationTarget, PositionPose, RigDevices, RigGeometry, TruthSource};
use matscan_drivers::lights::BoardFaults;
use matscan_drivers::sim_rig::{SimConfig, SimFaults, SimulatedRig};
use matscan_drivers::DriverError;
use matscan_scan::bundle::BundleWriter;
use matscan_sim::render::bundle_writer::checker_periods;
use matscan_sim::scene::{
    frame_object, generate, rig_to_manifest_lights, GeometrySource, Scene, SceneOptions,
};
use std::num::NonZeroU32;

/// Opens the rig `choice` names.
pub fn open(choice: &RigChoice) -> Result<RigDevices, HardwareError> {
    match choice {
        RigChoice::Simulated(c) => open_simulated(c),
        RigChoice::Hardware(c) => super::hardware::open(c),
    }
}

/// Opens the rig `choice` names for a calibration capture: a hardware rig
/// whose calibration file does not exist yet is photographed at the
/// `[calibration]` positions.
pub fn open_for_calibration(
    choice: &RigChoice,
    calibration: &CalibrationSettings,
) -> Result<RigDevices, HardwareError> {
    match choice {
        RigChoice::Simulated(c) => open_simulated(c),
        RigChoice::Hardware(c) => super::hardware::open_for_calibration(c, calibration.positions),
    }
}

/// The scene the simulated rig of `c` photographs: generated from its
/// seed, kind and geometry, its cameras framed on the object where `c`
/// asks for it, or under the rig of `c.rig_from` (a simulated scan's, its
/// camera scaled to the photo size).
pub fn simulated_scene(c: &SimulatedRigConfig) -> Result<Scene, HardwareError> {
    let mut scene = generate(&SceneOptions {
        seed: c.seed,
        kind: c.kind,
        geometry: c
            .geometry
            .map_or(GeometrySource::Random, GeometrySource::Kind),
        width: c.size,
        height: c.size,
        positions: c.positions,
        map_size: 64,
    });
    if let Some(fill) = c.frame {
        frame_object(&mut scene, fill)?;
    }
    if let Some(path) = &c.rig_from {
        let file = if path.is_dir() {
            path.join(matscan_scan::bundle::MANIFEST_FILE)
        } else {
            path.clone()
        };
        let (manifest, _) = matscan_scan::Manifest::read_rig(&file).map_err(|source| {
            HardwareError::Calibration {
                path: file.clone(),
                source,
            }
        })?;
        let mut rig = matscan_sim::scene::rig_from_manifest(&manifest).map_err(|message| {
            HardwareError::Invalid {
                path: file.clone(),
                message,
            }
        })?;
        if rig.intrinsics.width != rig.intrinsics.height {
            return Err(HardwareError::Invalid {
                path: file,
                message: "the simulated rig's photos are square; this camera is not".into(),
            });
        }
        rig.intrinsics = rig.intrinsics.scaled_to(c.size, c.size);
        scene.rig = rig;
    }
    Ok(scene)
}

fn open_simulated(c: &SimulatedRigConfig) -> Result<RigDevices, HardwareError> {
    let scene = simulated_scene(c)?;
    let geometry = geometry_of(&scene, c.size);
    let truth = SceneTruth(scene.clone());
    let config = SimConfig {
        width: c.size,
        height: c.size,
        samples: c.samples,
        seed: c.seed,
        faults: SimFaults {
            camera_lost_after: c.faults.camera_lost_after,
            board: BoardFaults {
                silent_after: c.faults.lights_silent_after,
                dead_lights: c.faults.dead_lights.clone(),
                ..BoardFaults::default()
            },
            disk_capacity: c.faults.disk_capacity,
        },
        ..SimConfig::default()
    };
    let rig = SimulatedRig::new(scene, config)?;
    let positioner: Option<Box<dyn matscan_drivers::Positioner>> = if c.turntable {
        Some(Box::new(rig.positioner))
    } else {
        None
    };
    let trigger: Option<Box<dyn matscan_drivers::Trigger>> = match &c.footswitch {
        // The pedal as a named pipe: a test or a demo presses it.
        Some(pipe) => Some(Box::new(
            matscan_drivers::footswitch::pipe::PipeTrigger::open(pipe)?,
        )),
        // Nobody turns the simulated object without a turntable, and
        // nothing presses its footswitch: the sequencer waits for the
        // press and times out with a clear error.
        None if !c.turntable => Some(Box::new(UnpressedFootswitch {
            trigger: rig.trigger,
            _button: rig.footswitch,
        })),
        None => None,
    };
    let calibration_target = Some(CalibrationTarget {
        board: *rig.hand.board(),
        reference_to_world: rig.hand.reference_to_world(),
    });
    let sphere_radius = Some(rig.hand.sphere_radius());
    Ok(RigDevices {
        calibration_target,
        sphere_radius,
        hand: Some(Box::new(rig.hand)),
        camera: Box::new(rig.camera),
        lights: Box::new(rig.lights),
        projector: Some(Box::new(rig.projector)),
        positioner,
        trigger,
        disk: Some(Box::new(rig.disk)),
        geometry,
        truth: Some(Box::new(truth)),
        mesh_source: None,
    })
}

/// The simulated scene's material, rendered as the contract's truth maps.
struct SceneTruth(Scene);

impl TruthSource for SceneTruth {
    fn write(&self, writer: &BundleWriter, index: usize, position: &str) -> Result<(), String> {
        let renderer = matscan_sim::render::Renderer::new(&self.0).map_err(|e| e.to_string())?;
        let maps = renderer.render_truth(index).map_err(|e| e.to_string())?;
        matscan_sim::render::write_truth(writer, position, &maps).map_err(|e| e.to_string())
    }

    fn rig(&self) -> Option<matscan_scan::Manifest> {
        Some(matscan_sim::calib_target::truth_rig(&self.0.rig))
    }
}

/// The simulated footswitch with its button kept alive, so that waiting
/// on it times out (no press) rather than failing as unplugged.
struct UnpressedFootswitch {
    trigger: matscan_drivers::sim_rig::SimTrigger,
    _button: matscan_drivers::sim_rig::FootswitchButton,
}

impl matscan_drivers::Trigger for UnpressedFootswitch {
    fn id(&self) -> &str {
        self.trigger.id()
    }

    fn wait(
        &mut self,
        timeout: std::time::Duration,
    ) -> Result<Option<matscan_drivers::Press>, DriverError> {
        self.trigger.wait(timeout)
    }
}

/// The manifest geometry of `scene` photographed at `size` x `size`
/// (intrinsics scaled as the simulated camera scales them).
pub fn geometry_of(scene: &Scene, size: u32) -> RigGeometry {
    let intrinsics = scene.rig.intrinsics.scaled_to(size, size);
    let mut scaled = scene.clone();
    scaled.rig.intrinsics = intrinsics;
    let (small, large) = checker_periods(&scaled);
    let period = |p: u32| NonZeroU32::new(p.max(2)).unwrap_or(NonZeroU32::MIN);
    RigGeometry {
        name: scene.name.clone(),
        mesh: scene.mesh.clone(),
        intrinsics,
        positions: scene
            .rig
            .positions
            .iter()
            .map(|p| PositionPose {
                name: p.name.clone(),
                camera_to_world: p.camera_to_world,
                lights: rig_to_manifest_lights(p),
                exposure_s: p.exposure_s,
            })
            .collect(),
        checker_periods: (period(small), period(large)),
    }
}
