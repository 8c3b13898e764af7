//! The simulated rig renders what the lights and projector are doing, and
//! its injected faults give the documented errors.

use super::*;
use crate::{Checker, Level};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::num::NonZeroU32;

fn scene() -> Scene {
    generate(&SceneOptions {
        seed: 3,
        kind: SceneKind::TwoMat,
        geometry: GeometrySource::Kind(GeometryKind::ALL[0]),
        width: 64,
        height: 64,
        positions: 2,
        map_size: 16,
    })
}

fn config(faults: SimFaults) -> SimConfig {
    SimConfig {
        width: 24,
        height: 24,
        samples: 2,
        faults,
        ..SimConfig::default()
    }
}

fn mean(frame: &crate::Frame) -> f32 {
    let n = frame.rgb.data.len() as f32;
    frame
        .rgb
        .data
        .iter()
        .map(|p| p[0] + p[1] + p[2])
        .sum::<f32>()
        / (3.0 * n)
}

#[test]
fn flash_on_is_brighter_than_ambient_and_forgetting_it_gives_ambient() {
    let mut rig = SimulatedRig::new(scene(), config(SimFaults::default())).unwrap();
    assert_eq!(rig.camera.resolution(), (24, 24));
    let ambient = rig.camera.capture().unwrap();
    rig.lights.on(LightId::Flash0, Level::FULL).unwrap();
    let lit = rig.camera.capture().unwrap();
    assert!(
        mean(&lit) > mean(&ambient) * 1.05 + 1e-4,
        "{} vs {}",
        mean(&lit),
        mean(&ambient)
    );
    rig.lights.off(LightId::Flash0).unwrap();
    let forgot = rig.camera.capture().unwrap();
    assert_eq!(
        forgot.rgb, ambient.rgb,
        "a flash that is off must not light the photo"
    );
    assert!(forgot.sequence > lit.sequence && lit.sequence > ambient.sequence);
    assert!(ambient
        .rgb
        .data
        .iter()
        .flatten()
        .all(|v| v.is_finite() && *v >= 0.0));
}

#[test]
fn half_level_adds_about_half_the_flash() {
    let mut rig = SimulatedRig::new(scene(), config(SimFaults::default())).unwrap();
    let ambient = mean(&rig.camera.capture().unwrap());
    rig.lights.on(LightId::Flash1, Level::FULL).unwrap();
    let full = mean(&rig.camera.capture().unwrap()) - ambient;
    rig.lights
        .on(LightId::Flash1, Level::new(0.5).unwrap())
        .unwrap();
    let half = mean(&rig.camera.capture().unwrap()) - ambient;
    assert!(full > 0.0);
    // Duty 128/255, up to saturation (which only lowers `full`).
    assert!(
        half >= 0.45 * full && half <= 0.51 * full + 1e-6,
        "half {half} full {full}"
    );
}

#[test]
fn photos_sum_each_emitters_light_and_a_position_renders_its_emitters_once() {
    let config = SimConfig {
        saturate: false,
        ..config(SimFaults::default())
    };
    let mut rig = SimulatedRig::new(scene(), config).unwrap();
    let ambient = rig.camera.capture().unwrap().rgb;
    rig.lights.on(LightId::Flash0, Level::FULL).unwrap();
    let flash0 = rig.camera.capture().unwrap().rgb;
    rig.lights.on(LightId::Flash1, Level::FULL).unwrap();
    let both = rig.camera.capture().unwrap().rgb;
    rig.lights.off(LightId::Flash0).unwrap();
    let flash1 = rig.camera.capture().unwrap().rgb;
    // Light adds: both flashes are each flash's light over one ambient.
    let mut largest = 0.0f32;
    for i in 0..ambient.data.len() {
        for c in 0..3 {
            let sum = flash0.data[i][c] + flash1.data[i][c] - ambient.data[i][c];
            largest = largest.max((both.data[i][c] - sum).abs());
        }
    }
    assert!(largest < 1e-5, "{largest}");
    // A pattern first shown at this position adds its light to the same
    // ambient; the next position renders it in its own first pass.
    rig.lights.off(LightId::Flash1).unwrap();
    rig.projector
        .show(ProjectorPattern::Uniform(Level::FULL))
        .unwrap();
    let uniform = rig.camera.capture().unwrap().rgb;
    assert!(uniform
        .data
        .iter()
        .zip(&ambient.data)
        .all(|(u, a)| (0..3).all(|c| u[c] >= a[c])));
    assert_eq!(rig.camera.patterns_seen.len(), 1);
    rig.positioner.advance().unwrap();
    let cache = |rig: &SimulatedRig| {
        let c = rig.camera.cache.as_ref().unwrap();
        let patterns = c
            .emitters
            .iter()
            .filter(|(e, _)| matches!(e, Emitter::Projector(_)))
            .count();
        (c.position, c.emitters.len() - patterns, patterns)
    };
    rig.projector.show(ProjectorPattern::Black).unwrap();
    rig.camera.capture().unwrap();
    assert_eq!(cache(&rig), (1, 3, 1), "every light and the seen pattern");
}

#[test]
fn projector_pattern_and_position_change_the_photo() {
    let mut rig = SimulatedRig::new(scene(), config(SimFaults::default())).unwrap();
    let dark = rig.camera.capture().unwrap();
    rig.projector
        .show(ProjectorPattern::Checker(Checker {
            period_px: NonZeroU32::new(16).unwrap(),
            phase_px: [0, 0],
            low: Level::ZERO,
            high: Level::FULL,
        }))
        .unwrap();
    let checker = rig.camera.capture().unwrap();
    assert!(mean(&checker) > mean(&dark));
    rig.projector.show(ProjectorPattern::Black).unwrap();
    assert_eq!(rig.camera.capture().unwrap().rgb, dark.rgb);
    assert_eq!(rig.positioner.count(), 2);
    assert_eq!(rig.positioner.advance().unwrap(), 1);
    assert_ne!(rig.camera.capture().unwrap().rgb, dark.rgb);
    assert_eq!(
        rig.positioner.advance().unwrap(),
        0,
        "wraps after the last position"
    );
}

#[test]
fn a_flash_that_does_not_fire_acknowledges_but_leaves_the_photo_ambient() {
    let faults = SimFaults {
        board: BoardFaults {
            dead_lights: vec![LightId::Flash0],
            ..BoardFaults::default()
        },
        ..SimFaults::default()
    };
    let mut rig = SimulatedRig::new(scene(), config(faults)).unwrap();
    let ambient = rig.camera.capture().unwrap();
    rig.lights.on(LightId::Flash0, Level::FULL).unwrap();
    assert_eq!(
        rig.lights.state(LightId::Flash0),
        LightState::On(Level::FULL)
    );
    assert_eq!(rig.camera.capture().unwrap().rgb, ambient.rgb);
}

#[test]
fn camera_lost_after_n_frames() {
    let faults = SimFaults {
        camera_lost_after: Some(1),
        ..SimFaults::default()
    };
    let mut rig = SimulatedRig::new(scene(), config(faults)).unwrap();
    rig.camera.capture().unwrap();
    let err = rig.camera.capture().unwrap_err();
    assert!(
        matches!(err, DriverError::CameraLost { frames: 1, .. }),
        "{err}"
    );
    assert!(err.to_string().contains(CAMERA_ID));
}

#[test]
fn serial_timeout_names_the_light_port() {
    // HELLO and ALLOFF at connect, then silence.
    let faults = SimFaults {
        board: BoardFaults {
            silent_after: Some(2),
            ..BoardFaults::default()
        },
        ..SimFaults::default()
    };
    let mut rig = SimulatedRig::new(scene(), config(faults)).unwrap();
    let err = rig.lights.on(LightId::Backlight, Level::FULL).unwrap_err();
    assert!(matches!(err, DriverError::Timeout { .. }), "{err}");
    assert!(err.to_string().contains(LIGHTS_ID), "{err}");
}

#[test]
fn full_disk_refuses_the_write_that_does_not_fit() {
    let faults = SimFaults {
        disk_capacity: Some(100),
        ..SimFaults::default()
    };
    let rig = SimulatedRig::new(scene(), config(faults)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    rig.disk.write(&dir.path().join("a"), &[1; 60]).unwrap();
    let b = dir.path().join("b");
    let err = rig.disk.write(&b, &[1; 60]).unwrap_err();
    assert!(
        matches!(
            err,
            DriverError::DiskFull {
                written: 40,
                wanted: 60,
                ..
            }
        ),
        "{err}"
    );
    assert!(!b.exists());
    assert_eq!(rig.disk.used(), 60);
}

#[test]
fn footswitch_presses_arrive_and_silence_times_out() {
    let mut rig = SimulatedRig::new(scene(), config(SimFaults::default())).unwrap();
    assert_eq!(rig.trigger.wait(Duration::from_millis(1)).unwrap(), None);
    rig.footswitch.press();
    assert!(rig
        .trigger
        .wait(Duration::from_millis(1))
        .unwrap()
        .is_some());
    let SimulatedRig {
        mut trigger,
        footswitch,
        ..
    } = rig;
    drop(footswitch);
    assert!(matches!(
        trigger.wait(Duration::from_millis(1)),
        Err(DriverError::Disconnected { .. })
    ));
}

#[test]
fn the_operator_holds_a_board_in_the_objects_place_and_takes_it_away() {
    let config = SimConfig {
        width: 64,
        height: 64,
        ..config(SimFaults::default())
    };
    let mut rig = SimulatedRig::new(scene(), config).unwrap();
    rig.lights.on(LightId::Flash0, Level::FULL).unwrap();
    let object = rig.camera.capture().unwrap().rgb;
    rig.hand.place(0, TargetPlacement::Reference).unwrap();
    let board = rig.camera.capture().unwrap().rgb;
    let changed = object
        .data
        .iter()
        .zip(&board.data)
        .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3))
        .count();
    assert!(
        changed > object.data.len() / 10,
        "the board replaces the object in {changed} of {} pixels",
        object.data.len()
    );
    // A Gray-code pose: every stripe image renders in the placement's first
    // pass, so showing them one by one renders nothing more.
    rig.hand.place(0, TargetPlacement::InProjectorView).unwrap();
    rig.camera.capture().unwrap();
    let codes = GrayCode::sequence(1024, 768);
    let cached = |rig: &SimulatedRig| rig.camera.cache.as_ref().unwrap().emitters.len();
    let first_pass = cached(&rig);
    assert_eq!(
        first_pass,
        rig.camera.lights_of(0).len() + codes.len(),
        "every rig light and every stripe image"
    );
    for code in codes.iter().take(3) {
        rig.projector
            .show(ProjectorPattern::GrayCode(*code))
            .unwrap();
        rig.camera.capture().unwrap();
    }
    assert_eq!(cached(&rig), first_pass);
    rig.projector.show(ProjectorPattern::Black).unwrap();
    // Taken away, the object is photographed as before.
    rig.hand.remove();
    assert_eq!(rig.camera.capture().unwrap().rgb, object);
    // A position the rig does not have is refused, naming the operator.
    let err = rig.hand.place(7, TargetPlacement::HandHeld).unwrap_err();
    assert!(err.to_string().contains(HAND_ID), "{err}");
}

#[test]
fn the_operator_holds_the_sphere_before_the_backlight_and_its_photos_show_the_projector() {
    let config = SimConfig {
        width: 48,
        height: 48,
        ..config(SimFaults::default())
    };
    let mut rig = SimulatedRig::new(scene(), config).unwrap();
    assert!(rig.hand.sphere_radius() > 0.0);
    rig.hand.place(0, TargetPlacement::Sphere).unwrap();
    rig.lights.on(LightId::Backlight, Level::FULL).unwrap();
    let backlit = rig.camera.capture().unwrap().rgb;
    rig.lights.off(LightId::Backlight).unwrap();
    let ambient = rig.camera.capture().unwrap().rgb;
    // The panel lights most of the photo; the sphere before it stays dark.
    let lit = backlit
        .data
        .iter()
        .zip(&ambient.data)
        .filter(|(b, a)| b[1] - a[1] > 0.01)
        .count();
    let total = backlit.data.len();
    assert!(lit > total / 2 && lit < total, "{lit} of {total} lit");
    // The projector's white field was rendered with the place's first pass.
    let cached = rig.camera.cache.as_ref().unwrap().emitters.len();
    rig.projector
        .show(ProjectorPattern::Uniform(Level::FULL))
        .unwrap();
    rig.camera.capture().unwrap();
    assert_eq!(rig.camera.cache.as_ref().unwrap().emitters.len(), cached);
}

#[test]
fn a_mean_of_frames_draws_fresh_noise_and_leaves_the_next_capture_as_it_was() {
    let mut rig = SimulatedRig::new(scene(), config(SimFaults::default())).unwrap();
    rig.lights.on(LightId::Flash0, Level::FULL).unwrap();
    let single = rig.camera.capture().unwrap();
    let averaged = rig.camera.capture_mean(8).unwrap();
    let again = rig.camera.capture().unwrap();
    assert_eq!(again.rgb, single.rgb, "the placement's render is kept");
    // Two paths per pixel: the frames' noise differs, the light does not.
    let spread = |f: &crate::Frame| {
        let m = mean(f);
        let n = f.rgb.data.len() as f32;
        (f.rgb.data.iter().map(|p| (p[1] - m).powi(2)).sum::<f32>() / n).sqrt()
    };
    assert_ne!(averaged.rgb, single.rgb);
    assert!(averaged.rgb.data.iter().flatten().all(|v| v.is_finite()));
    assert!(
        (mean(&averaged) / mean(&single) - 1.0).abs() < 0.1,
        "{} vs {}",
        mean(&averaged),
        mean(&single)
    );
    assert!(spread(&averaged) < spread(&single), "the mean is smoother");
}
