//! The rig calibrated from its own photos, end to end: `matscan calib
//! capture` asks the daemon (the simulated rig, whose operator holds the
//! printed board) for the board photos, `matscan calib rig` turns them into
//! a rig file, and `matscan calib compare` judges it against the rig the
//! simulator really has.

use crate::daemon_support;

use daemon_support::{matscan, stdout, TestDaemon};
use matscan_scan::Manifest;
use serde_json::Value;

/// `matscan calib capture --target ARGS --socket SOCKET --json`, which
/// must exit 0; its JSON line.
fn capture_json(socket: &str, args: &[&str]) -> Value {
    let mut all = vec!["calib", "capture", "--target"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--socket", socket, "--json"]);
    let o = matscan(&all);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_str(stdout(&o).lines().last().unwrap_or("")).unwrap()
}

#[test]
fn calib_capture_through_the_daemon_calibrates_the_simulated_rig_and_names_a_missing_shot() {
    let dir = tempfile::tempdir().unwrap();
    // Fewer frames per photo than a real rig's defaults (16 and 16) keep
    // the test's renders few; its limits hold with them.
    let d = TestDaemon::start(
        dir.path(),
        "[calibration]\nresting_frames = 4\nheld_frames = 1",
        "seed = 1\nsize = 448\npositions = 2\nsamples = 4\nturntable = true",
    );
    let socket = d.socket.display().to_string();
    let v = capture_json(
        &socket,
        &["board", "--shots", "6", "--projector-shots", "3"],
    );
    let bundle = d.scans.join("calib-0001");
    assert_eq!(v["bundle"], bundle.display().to_string());
    // 2 x (6 board shots and the second seat), 3 Gray-code poses of a
    // flash photo and 2 x 20 stripe images each (a 1024 x 768 projector:
    // 10 bits per axis).
    assert_eq!(v["summary"]["shots"], 17, "{v}");
    assert_eq!(v["summary"]["graycode_shots"], 3);
    assert_eq!(v["summary"]["photos"], 14 + 3 * 41);
    let status: Value = serde_json::from_str(&stdout(&matscan(&[
        "status", "--socket", &socket, "--json",
    ])))
    .unwrap();
    assert_eq!(status["last_calibrations"][0]["bundle"], v["bundle"]);
    assert_eq!(status["last_scans"], Value::Array(vec![]));
    // The glossy sphere at four places before the first camera: ambient,
    // backlight, both flashes and the projector's white at each.
    let v = capture_json(&socket, &["sphere", "--placements", "4"]);
    let spheres = d.scans.join("calib-0002");
    assert_eq!(v["bundle"], spheres.display().to_string());
    assert_eq!(v["summary"]["photos"], 4 * 5, "{v}");
    // The backlight panel with the mount empty (and its ambient), the
    // white card on the board's mount (ambient, both flashes, the
    // projector), then flash0 and its ambient at half the exposure.
    let v = capture_json(&socket, &["white", "--exposures", "2"]);
    let white = d.scans.join("calib-0003");
    assert_eq!(v["summary"]["photos"], 2 + 4 + 2, "{v}");
    d.stop();

    let b = bundle.to_str().unwrap();
    let o = matscan(&["calib", "rig", b]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = stdout(&o);
    assert!(
        out.contains("17 shots")
            && out.contains("3 Gray-code shots")
            && out.contains("seat-2 holds the board turned"),
        "{out}"
    );
    for f in ["rig.toml", "calib-report.toml", "contact-sheet.png"] {
        assert!(bundle.join("result").join(f).exists(), "missing {f}");
    }
    let measured = bundle.join("result/rig.toml");
    let truth = bundle.join("truth-rig.toml");
    let (m, _) = Manifest::read_rig(&measured).unwrap();
    let (t, _) = Manifest::read_rig(&truth).unwrap();
    let focal = (m.camera.fx / t.camera.fx - 1.0).abs();
    assert!(focal < 0.005, "focal length off by {:.3} %", focal * 100.0);
    for (mp, tp) in m.positions.iter().zip(&t.positions) {
        let shift = (mp.camera_to_world.w_axis - tp.camera_to_world.w_axis)
            .truncate()
            .length();
        assert!(
            shift < 0.005,
            "{}: camera {:.2} mm off",
            mp.name,
            shift * 1e3
        );
    }
    let o = matscan(&[
        "calib",
        "compare",
        measured.to_str().unwrap(),
        truth.to_str().unwrap(),
    ]);
    assert!(o.status.success() && stdout(&o).contains("projector: focal length"));

    // The flashes from the sphere's highlights, with the camera and the
    // projector just calibrated: within a few millimetres at 448 px.
    let o = matscan(&[
        "calib",
        "lights",
        spheres.to_str().unwrap(),
        "--rig",
        measured.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (lit, _) = Manifest::read_rig(&spheres.join("result/rig.toml")).unwrap();
    let d = matscan_rigcal::compare::compare(&lit, &t);
    assert_eq!(d.flashes.len(), 2, "{d:?}");
    for (name, off) in &d.flashes {
        assert!(*off < 0.015, "{name} {:.1} mm off", off * 1e3);
    }
    assert!(spheres.join("result/lights-report.toml").is_file());
    // The same in one go: `calib rig --spheres --white` writes the whole
    // rig file, the lights' intensities from the white card included.
    let whole = dir.path().join("whole");
    let o = matscan(&[
        "calib",
        "rig",
        b,
        "--spheres",
        spheres.to_str().unwrap(),
        "--white",
        white.to_str().unwrap(),
        "--out",
        whole.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout(&o).contains("linearity of flash0"), "{}", stdout(&o));
    let (all, _) = Manifest::read_rig(&whole.join("rig.toml")).unwrap();
    let d = matscan_rigcal::compare::compare(&all, &lit);
    assert_eq!(d.flashes.len(), 2);
    assert!(d.flashes.iter().all(|(_, d)| *d < 1e-9));
    let d = matscan_rigcal::compare::compare(&all, &t);
    assert_eq!(d.intensities.len(), 4, "{d:?}");
    for (name, off) in &d.intensities {
        assert!(
            off.abs() < 0.02,
            "{name}: intensity {:+.2} % off",
            off * 100.0
        );
    }
    assert!(whole.join("white-report.toml").is_file());

    // A shot the bundle lists but the folder lacks: named, nothing written.
    std::fs::remove_dir_all(bundle.join("result")).unwrap();
    std::fs::remove_file(bundle.join("p1/board-03.exr")).unwrap();
    let o = matscan(&["calib", "rig", b]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("p1/board-03.exr"), "{err}");
    assert!(!bundle.join("result").exists());
}
