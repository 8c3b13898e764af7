//! The sequencer on the simulated rig: the bundle it publishes, the plan's
//! omissions, a flash that does not fire, the operator's press.

use super::*;
use crate::service::config::{FaultConfig, Profile, RigChoice, SimulatedRigConfig};
use crate::service::plan::plan;
use matscan_drivers::sim_rig::FootswitchButton;
use matscan_scan::calib_bundle::BoardFrames;
use matscan_scan::{Bundle, CaptureRole, Param};
use matscan_sim::scene::SceneKind;

fn sim(positions: usize, turntable: bool, faults: FaultConfig) -> RigChoice {
    RigChoice::Simulated(SimulatedRigConfig {
        seed: 2,
        kind: SceneKind::TwoMat,
        geometry: Some(matscan_sim::scene::GeometryKind::Sphere),
        size: 24,
        positions,
        samples: 1,
        frame: None,
        rig_from: None,
        turntable,
        footswitch: None,
        faults,
    })
}

fn settings() -> RunSettings {
    RunSettings {
        light_retries: 1,
        min_light_difference: 1e-3,
        operator_timeout: Duration::from_secs(20),
    }
}

fn run(
    rig: &mut RigDevices,
    profile: &Profile,
    target: &Path,
) -> Result<CaptureOutcome, CaptureError> {
    let plan = plan(profile, rig.geometry.checker_periods, rig.capabilities());
    let mut seen = Vec::new();
    let out = rig.capture(
        &plan,
        "profile = \"test\"\n",
        target,
        &settings(),
        &|| false,
        &mut |p| seen.push(p),
    );
    if out.is_ok() {
        assert_eq!(seen.len(), seen.last().unwrap().total);
        assert_eq!(seen[0].what, "p0/ambient");
    }
    out
}

#[test]
fn two_positions_on_the_turntable_give_a_valid_bundle_with_every_role() {
    let dir = tempfile::tempdir().unwrap();
    let mut rig = crate::service::rig::open(&sim(2, true, FaultConfig::default())).unwrap();
    let target = dir.path().join("scan-0001");
    let out = run(&mut rig, &Profile::default(), &target).unwrap();
    assert_eq!((out.positions, out.photos, out.retries), (2, 14, 0));
    let bundle = Bundle::open(&target).unwrap();
    bundle.verify_images().unwrap();
    let m = &bundle.manifest;
    assert_eq!((m.camera.width, m.camera.height), (24, 24));
    assert_eq!(m.positions.len(), 2);
    let p0 = &m.positions[0];
    let roles: Vec<CaptureRole> = p0.captures_with_role().map(|(_, r)| r).collect();
    assert_eq!(roles[0], CaptureRole::Ambient);
    assert_eq!(
        roles
            .iter()
            .filter(|r| matches!(r, CaptureRole::Lit { .. }))
            .count(),
        3
    );
    assert!(roles.contains(&CaptureRole::Backlit));
    assert_eq!(
        roles
            .iter()
            .filter(|r| matches!(r, CaptureRole::Pattern { .. }))
            .count(),
        2
    );
    // The turntable really turned: the two positions' photos differ.
    let a = bundle.read_photo("p0", "ambient").unwrap();
    let b = bundle.read_photo("p1", "ambient").unwrap();
    assert!(mean_abs_difference(&a, &b) > 1e-3);
    // And it is back home for the next scan.
    assert_eq!(rig.positioner.as_ref().unwrap().position(), 0);
    assert!(target.join(CAPTURE_INFO_FILE).exists());
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
    assert_eq!(names.len(), 1, "only the published scan, no temporary left");
}

#[test]
fn a_profile_with_given_transmission_and_subsurface_takes_no_backlit_or_checker_photo() {
    let dir = tempfile::tempdir().unwrap();
    let mut rig = crate::service::rig::open(&sim(1, true, FaultConfig::default())).unwrap();
    let profile = Profile {
        given: [Param::Transmission, Param::Subsurface]
            .into_iter()
            .collect(),
    };
    let target = dir.path().join("scan-0001");
    let out = run(&mut rig, &profile, &target).unwrap();
    assert_eq!(out.photos, 4);
    assert_eq!(out.left_out.len(), 2);
    let bundle = Bundle::open(&target).unwrap();
    let p0 = &bundle.manifest.positions[0];
    assert!(p0.backlit().is_none());
    assert_eq!(p0.pattern_captures().count(), 0);
    assert!(!target.join("views/p0/backlight.exr").exists());
}

#[test]
fn a_dead_flash_is_retried_then_fails_naming_it_and_publishes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let faults = FaultConfig {
        dead_lights: vec![LightId::Flash1],
        ..FaultConfig::default()
    };
    let mut rig = crate::service::rig::open(&sim(1, true, faults)).unwrap();
    let target = dir.path().join("scan-0001");
    let err = run(&mut rig, &Profile::default(), &target).unwrap_err();
    match &err {
        CaptureError::LightDidNotFire {
            light,
            capture,
            attempts,
            ..
        } => {
            assert_eq!(
                (light.as_str(), capture.as_str(), *attempts),
                ("flash1", "flash1", 2)
            );
        }
        other => panic!("expected LightDidNotFire, got {other}"),
    }
    assert!(
        err.to_string().contains("light `flash1` did not fire"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// A two-position simulated rig without turntable: the rig, the turntable
/// the "operator" turns by hand, and the footswitch's button.
fn hand_turned_rig() -> (
    RigDevices,
    matscan_drivers::sim_rig::SimPositioner,
    FootswitchButton,
) {
    hand_turned_rig_with(matscan_drivers::sim_rig::SimFaults::default())
}

/// [`hand_turned_rig`] with the simulated devices' `faults`.
fn hand_turned_rig_with(
    faults: matscan_drivers::sim_rig::SimFaults,
) -> (
    RigDevices,
    matscan_drivers::sim_rig::SimPositioner,
    FootswitchButton,
) {
    let RigChoice::Simulated(c) = sim(2, false, FaultConfig::default()) else {
        unreachable!("sim() makes a simulated rig");
    };
    let scene = matscan_sim::scene::generate(&matscan_sim::scene::SceneOptions {
        seed: c.seed,
        kind: c.kind,
        geometry: matscan_sim::scene::GeometrySource::Kind(c.geometry.unwrap()),
        width: c.size,
        height: c.size,
        positions: 2,
        map_size: 16,
    });
    let geometry = crate::service::rig::geometry_of(&scene, c.size);
    let sim_rig = matscan_drivers::sim_rig::SimulatedRig::new(
        scene,
        matscan_drivers::sim_rig::SimConfig {
            width: c.size,
            height: c.size,
            samples: 1,
            faults,
            ..Default::default()
        },
    )
    .unwrap();
    let button: FootswitchButton = sim_rig.footswitch.clone();
    let rig = RigDevices {
        camera: Box::new(sim_rig.camera),
        lights: Box::new(sim_rig.lights),
        projector: Some(Box::new(sim_rig.projector)),
        positioner: None,
        trigger: Some(Box::new(sim_rig.trigger)),
        disk: None,
        geometry,
        truth: None,
        mesh_source: None,
        calibration_target: None,
        hand: None,
        sphere_radius: None,
    };
    (rig, sim_rig.positioner, button)
}

#[test]
fn without_a_turntable_the_sequencer_waits_for_the_operators_press() {
    let dir = tempfile::tempdir().unwrap();
    let (mut rig, mut turntable, button) = hand_turned_rig();
    let plan = plan(
        &Profile::default(),
        rig.geometry.checker_periods,
        rig.capabilities(),
    );
    let target = dir.path().join("scan-0001");
    let out = capture_with_operator(&mut rig, &plan, &target, &settings(), button, move || {
        turntable.advance().unwrap();
    });
    let out = out.unwrap();
    assert_eq!(out.positions, 2);
    let bundle = Bundle::open(&target).unwrap();
    let a = bundle.read_photo("p0", "ambient").unwrap();
    let b = bundle.read_photo("p1", "ambient").unwrap();
    assert!(
        mean_abs_difference(&a, &b) > 1e-3,
        "p1 was taken after the turn"
    );
}

#[test]
fn a_press_made_before_the_wait_does_not_move_on_and_is_counted() {
    let dir = tempfile::tempdir().unwrap();
    let (mut rig, _turntable, button) = hand_turned_rig();
    // Pressed before the capture (as during p0's photos): the object has
    // not been moved, so it must not count as "in place".
    button.press();
    button.press();
    let plan = plan(
        &Profile::default(),
        rig.geometry.checker_periods,
        rig.capabilities(),
    );
    let quick = RunSettings {
        operator_timeout: Duration::from_millis(600),
        ..settings()
    };
    let err = rig
        .capture(
            &plan,
            "",
            &dir.path().join("scan-0001"),
            &quick,
            &|| false,
            &mut |_| {},
        )
        .unwrap_err();
    assert!(
        matches!(&err, CaptureError::OperatorTimeout { waiting_for, .. } if waiting_for.ends_with("position p1")),
        "{err}"
    );
    assert!(!dir.path().join("scan-0001").exists());

    // An early press again, then presses once p0's photos are done: the
    // sequencer moves on, and reports the early press.
    button.press();
    let target = dir.path().join("scan-0002");
    let out = capture_with_operator(&mut rig, &plan, &target, &settings(), button, || {});
    let out = out.unwrap();
    assert_eq!(out.positions, 2);
    assert!(out.presses_during >= 1, "{out:?}");
}

#[test]
fn without_a_press_the_capture_times_out_naming_the_footswitch() {
    let dir = tempfile::tempdir().unwrap();
    let mut rig = crate::service::rig::open(&sim(2, false, FaultConfig::default())).unwrap();
    let plan = plan(
        &Profile::default(),
        rig.geometry.checker_periods,
        rig.capabilities(),
    );
    let s = RunSettings {
        operator_timeout: Duration::from_millis(300),
        ..settings()
    };
    let target = dir.path().join("scan-0001");
    let err = rig
        .capture(&plan, "", &target, &s, &|| false, &mut |_| {})
        .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("sim:footswitch: no press within"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

/// Presses `button` every 50 ms until `run` returns: an operator who is
/// always ready (presses during photos are ignored by the sequencer).
fn with_ready_operator<T>(button: FootswitchButton, run: impl FnOnce() -> T) -> T {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let finished = Arc::new(AtomicBool::new(false));
    let presser = {
        let finished = finished.clone();
        std::thread::spawn(move || {
            while !finished.load(Ordering::SeqCst) {
                button.press();
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    let out = run();
    finished.store(true, Ordering::SeqCst);
    presser.join().expect("the operator thread");
    out
}

fn board_target() -> CalibrationTarget {
    CalibrationTarget {
        board: matscan_scan::calib_bundle::Chessboard {
            cols: 9,
            rows: 6,
            square: 0.02,
        },
        reference_to_world: glam::DMat4::IDENTITY,
    }
}

#[test]
fn a_calibration_prompts_the_operator_for_each_board_pose_and_publishes_the_bundle() {
    use matscan_scan::calib_bundle::{BoardPlacement, CalibManifest, SEAT};
    let dir = tempfile::tempdir().unwrap();
    let (mut rig, _turntable, button) = hand_turned_rig();
    rig.calibration_target = Some(board_target());
    let target = dir.path().join("calib-0001");
    let mut prompts = Vec::new();
    let frames = BoardFrames {
        resting: 2,
        held: 2,
    };
    let plan = CalibrationPlan::Board(BoardPlan::new(3, 1, true, frames).unwrap());
    let out = with_ready_operator(button, || {
        rig.capture_calibration(
            plan,
            &target,
            &settings(),
            &|| false,
            &mut |p| prompts.push(p.to_string()),
            &mut |_| {},
        )
    })
    .unwrap();
    // 2 positions x (3 poses and the second seat), then one Gray-code pose
    // at p0: the flash photo and 2 x (10 + 10) stripe images of the
    // 1024 x 768 projector.
    assert_eq!((out.positions, out.shots, out.graycode_shots), (2, 9, 1));
    assert_eq!(out.photos, 8 + 41);
    // A prompt per pose, and one to move on to p1 (no turntable).
    assert_eq!(prompts.len(), 10, "{prompts:?}");
    assert!(prompts[0].contains("reference placement"), "{prompts:?}");
    assert!(prompts[1].contains("second seat"), "{prompts:?}");
    // Frames averaged into a held photo need the board propped still.
    assert!(
        prompts[2].starts_with("prop the board on its stand at a new pose")
            && prompts[2].contains("pose 2 of 3"),
        "{prompts:?}"
    );
    assert!(prompts[4].contains("projector"), "{prompts:?}");
    assert_eq!(prompts[5], "move the object to p1");
    let manifest = CalibManifest::read(&target).unwrap();
    assert_eq!(manifest.board, board_target().board);
    assert_eq!(manifest.positions.len(), 2);
    let p0 = &manifest.positions[0];
    let placements: Vec<&BoardPlacement> = p0.shots.iter().map(|s| &s.placement).collect();
    assert_eq!(
        placements,
        [
            &BoardPlacement::Reference,
            &BoardPlacement::Seat(SEAT.into()),
            &BoardPlacement::Held,
            &BoardPlacement::Held,
            &BoardPlacement::Held
        ]
    );
    let folder = target.join(p0.shots[4].graycode.as_ref().unwrap());
    assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 41);
    assert!(folder.join("columns-09-inv.exr").is_file());
    assert_eq!(
        manifest.projector.map(|p| (p.width, p.height)),
        Some((1024, 768))
    );
}

/// `plan`'s calibration capture into `target`, with no prompts, progress
/// or stop.
fn capture_quietly(
    rig: &mut RigDevices,
    plan: CalibrationPlan,
    target: &std::path::Path,
) -> Result<CalibrationOutcome, CaptureError> {
    rig.capture_calibration(
        plan,
        target,
        &settings(),
        &|| false,
        &mut |_| {},
        &mut |_| {},
    )
}

#[test]
fn a_boards_photo_averages_the_frames_the_plan_asks_for_resting_and_held() {
    // A camera that dies after four frames, 2 positions x (the reference
    // and one held pose): one frame each passes; two frames for either
    // placement need a fifth frame and fail, leaving nothing behind.
    let run = |resting: usize, held: usize| {
        let dir = tempfile::tempdir().unwrap();
        let (mut rig, _turntable, button) =
            hand_turned_rig_with(matscan_drivers::sim_rig::SimFaults {
                camera_lost_after: Some(4),
                ..Default::default()
            });
        rig.calibration_target = Some(board_target());
        let target = dir.path().join("calib-0001");
        let frames = BoardFrames { resting, held };
        let plan = CalibrationPlan::Board(BoardPlan::new(2, 0, false, frames).unwrap());
        let out = with_ready_operator(button, || capture_quietly(&mut rig, plan, &target));
        let left = std::fs::read_dir(dir.path()).unwrap().count();
        (out.map(|o| o.photos), left)
    };
    let (one, left) = run(1, 1);
    assert_eq!((one.unwrap(), left), (4, 1));
    for (resting, held) in [(2, 1), (1, 2)] {
        let (out, left) = run(resting, held);
        let err = out.unwrap_err();
        assert!(err.to_string().contains("unplugged"), "{err}");
        assert_eq!(left, 0);
    }
    let zero = |resting, held| BoardPlan::new(1, 0, false, BoardFrames { resting, held });
    assert!(zero(0, 1).unwrap_err().contains("resting_frames = 0"));
    assert!(zero(1, 0).unwrap_err().contains("held_frames = 0"));
}

#[test]
fn a_calibration_without_a_board_or_a_projector_says_what_is_missing_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (mut rig, _turntable, _button) = hand_turned_rig();
    let target = dir.path().join("calib-0001");
    let run = |rig: &mut RigDevices, plan| capture_quietly(rig, plan, &target);
    let one = BoardFrames {
        resting: 1,
        held: 1,
    };
    let plan = |projector_shots| {
        CalibrationPlan::Board(BoardPlan::new(3, projector_shots, true, one).unwrap())
    };
    let err = run(&mut rig, plan(0)).unwrap_err();
    assert!(matches!(err, CaptureError::NoCalibrationTarget), "{err}");
    assert!(err.to_string().contains("[calibration] board"), "{err}");
    rig.calibration_target = Some(board_target());
    rig.projector = None;
    let err = run(&mut rig, plan(2)).unwrap_err();
    assert!(err.to_string().contains("no projector"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn a_sphere_capture_without_a_sphere_radius_says_so_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (mut rig, _turntable, _button) = hand_turned_rig();
    let err = capture_quietly(
        &mut rig,
        CalibrationPlan::Sphere(SpherePlan::new(3).unwrap()),
        &dir.path().join("calib-0001"),
    )
    .unwrap_err();
    assert!(matches!(err, CaptureError::NoSphere), "{err}");
    assert!(err.to_string().contains("sphere_radius"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    assert!(SpherePlan::new(1).is_err(), "one place fixes no flash");
}
