//! The `matscan` binary end to end: the commands a user types, on small
//! simulated scans.

use crate::daemon_support;

use daemon_support::{matscan, simulate_sphere, stdout, weights_dir};
use matscan_estimate::Backend;
use std::path::Path;

/// A 48 px sphere scan with two positions.
fn simulate(out: &Path) {
    simulate_sphere(48, 2, 2, &["--out", out.to_str().unwrap()]);
}

/// Simulates `tmp/scan` and runs `matscan estimate` on it with small
/// random networks and `extra` flags; returns the scan and the run.
fn estimate_fresh_scan(tmp: &Path, extra: &[&str]) -> (std::path::PathBuf, std::process::Output) {
    let scan = tmp.join("scan");
    simulate(&scan);
    let weights = weights_dir(tmp, 5);
    let mut args = vec![
        "estimate",
        scan.to_str().unwrap(),
        "--weights",
        weights.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let o = matscan(&args);
    (scan, o)
}

/// The words of the estimate table's line that starts with `first`.
fn table_row<'a>(out: &'a str, first: &str) -> Vec<&'a str> {
    out.lines()
        .find(|l| l.starts_with(first))
        .unwrap_or_else(|| panic!("no {first} row in {out}"))
        .split_whitespace()
        .collect()
}

#[test]
fn demo_captures_through_the_daemon_estimates_and_prints_errors_and_timings() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("demo");
    let weights = weights_dir(tmp.path(), 5);
    let args = [
        "demo",
        "--out",
        root.to_str().unwrap(),
        "--size",
        "32",
        "--positions",
        "2",
        "--samples",
        "2",
        "--weights",
        weights.to_str().unwrap(),
    ];
    let first = matscan(&args);
    let out = stdout(&first);
    assert!(
        first.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&first.stderr)
    );
    assert!(out.contains("capture "), "{out}");
    // A row per parameter under a header that names who answered;
    // metallic is always estimable, with its error.
    let header = table_row(&out, "parameter");
    assert_eq!(
        header,
        [
            "parameter",
            "status",
            "method",
            "MAD",
            "PSNR",
            "dB",
            "seconds"
        ]
    );
    let metallic = table_row(&out, "metallic");
    assert_eq!(metallic[1], "estimated", "{metallic:?}");
    // The simulated rig calibrates its lights, so the fit runs and answers
    // metallic where the photos pin it, the networks elsewhere.
    assert!(
        ["hybrid", "networks"].contains(&metallic[2]),
        "{metallic:?}"
    );
    let mad: f64 = metallic[3].parse().unwrap();
    assert!((0.0..=1.0).contains(&mad), "{metallic:?}");
    let seconds: f64 = metallic[5].parse().unwrap();
    assert!(seconds > 0.0, "{metallic:?}");
    for p in ["basecolor", "roughness", "transmission", "subsurface"] {
        assert!(out.lines().any(|l| l.starts_with(p)), "{p} in {out}");
    }
    assert!(out.contains("stages, s: "), "{out}");
    assert!(out.contains("estimate total"), "{out}");
    let scan = root.join("scans/scan-0001");
    assert!(scan.join("scan.toml").exists());
    assert!(scan.join("estimate/result.toml").exists());
    assert!(scan.join("sheet.png").exists());
    // The daemon stopped: its socket is gone, and a second run never
    // overwrites the first scan.
    assert!(!root.join("matscan.sock").exists());
    let second = matscan(&args);
    assert!(second.status.success());
    assert!(root.join("scans/scan-0002/scan.toml").exists());
}

#[test]
fn estimate_writes_the_contract_folder_and_reports_each_parameter() {
    let tmp = tempfile::tempdir().unwrap();
    let (scan, o) = estimate_fresh_scan(tmp.path(), &["--given", "subsurface=0"]);
    let out = stdout(&o);
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        table_row(&out, "subsurface")[1..3],
        ["given", "given"],
        "{out}"
    );
    assert_eq!(table_row(&out, "metallic")[1], "estimated", "{out}");
    assert!(out.contains("MAD"), "{out}");
    assert!(scan.join("estimate/result.toml").exists());
    // A missing weights folder is named.
    let o = matscan(&[
        "estimate",
        scan.to_str().unwrap(),
        "--weights",
        "/nonexistent/weights",
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/weights"));
}

#[test]
fn status_and_capture_now_without_a_daemon_exit_3_and_name_the_socket() {
    let tmp = tempfile::tempdir().unwrap();
    let socket = tmp.path().join("none.sock");
    for cmd in ["status", "capture-now"] {
        let o = matscan(&[cmd, "--socket", socket.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(3), "{cmd}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("none.sock"), "{cmd}: {err}");
    }
}

#[test]
fn simulate_refuses_to_overwrite_an_existing_scan() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("scan");
    simulate(&out);
    let before = std::fs::read(out.join("scan.toml")).unwrap();
    let o = matscan(&["simulate", "--out", out.to_str().unwrap(), "--size", "16"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("exists"), "{err}");
    assert_eq!(std::fs::read(out.join("scan.toml")).unwrap(), before);
}

#[test]
fn simulate_dataset_is_resumable_and_skips_finished_scenes() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    let run = |count: &str| {
        matscan(&[
            "simulate",
            "--dataset",
            ds.to_str().unwrap(),
            "--count",
            count,
            "--size",
            "16",
            "--positions",
            "1",
            "--samples",
            "1",
        ])
    };
    let o = run("2");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run("3");
    assert!(o.status.success());
    assert!(
        stdout(&o).contains("1 scenes rendered, 2 already present"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn calib_writes_the_documented_maps_and_check_reports_json() {
    let tmp = tempfile::tempdir().unwrap();
    let scan = tmp.path().join("scan");
    simulate(&scan);
    let out = tmp.path().join("maps");
    let o = matscan(&[
        "calib",
        scan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "mask.exr",
        "position.exr",
        "normal.exr",
        "depth.exr",
        "view.exr",
        "cos_nv.exr",
        "light_flash0.exr",
        "cos_nl_flash0.exr",
        "cos_vl_flash0.exr",
        "shadow_flash0.exr",
    ] {
        assert!(out.join("p0").join(f).exists(), "missing p0/{f}");
    }
    let o = matscan(&["calib", "check", scan.to_str().unwrap(), "--json"]);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let iou = json["positions"][0]["silhouette"]["iou"].as_f64().unwrap();
    assert!(iou >= 0.98, "IoU {iou}");
    // Against a rig file whose camera turned 3 degrees since: the photos
    // no longer fit it, the check fails and says how far it moved.
    let (mut rig, _) = matscan_scan::Manifest::read(&scan.join("scan.toml")).unwrap();
    for p in &mut rig.positions {
        p.camera_to_world *= glam::DMat4::from_rotation_y(3f64.to_radians());
    }
    let rig_file = tmp.path().join("rig.toml");
    std::fs::write(&rig_file, rig.to_toml()).unwrap();
    let check = |rig: &std::path::Path| {
        matscan(&[
            "calib",
            "check",
            scan.to_str().unwrap(),
            "--rig",
            rig.to_str().unwrap(),
        ])
    };
    let o = check(&rig_file);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stdout(&o).contains("orientation 3.000 deg"),
        "{}",
        stdout(&o)
    );
    let o = check(&scan.join("scan.toml"));
    assert!(o.status.success(), "{}", stdout(&o));
}

#[test]
fn a_malformed_manifest_is_reported_with_file_and_key() {
    let tmp = tempfile::tempdir().unwrap();
    let scan = tmp.path().join("scan");
    simulate(&scan);
    let manifest = scan.join("scan.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(&manifest, text.replacen("fx = ", "fx = -", 1)).unwrap();
    let o = matscan(&["sheet", scan.to_str().unwrap()]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("scan.toml") && err.contains("fx"), "{err}");
}

#[cfg(feature = "train")]
#[test]
fn train_writes_weights_a_loss_history_and_a_plot() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    simulate_sphere(
        24,
        1,
        1,
        &["--dataset", data.to_str().unwrap(), "--count", "1"],
    );
    let out = tmp.path().join("run");
    let o = matscan(&[
        "train",
        "--param",
        "metallic",
        "--data",
        data.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--steps",
        "3",
        "--width",
        "8",
        "--crop",
        "16",
        "--log-every",
        "1",
    ]);
    assert!(
        o.status.success(),
        "{}{}",
        stdout(&o),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(out.join("metallic.weights").is_file());
    let csv = std::fs::read_to_string(out.join("loss.csv")).unwrap();
    assert!(csv.lines().count() >= 3, "{csv}");
    assert!(out.join("loss.png").is_file());
    // An unknown network is named.
    let o = matscan(&["train", "--param", "sheen", "--data", "x", "--out", "y"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--param sheen"));
}

#[cfg(not(feature = "train"))]
#[test]
fn train_in_a_build_without_training_says_how_to_build_it() {
    let o = matscan(&["train", "--param", "metallic", "--data", "x", "--out", "y"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--features train"), "{err}");
}

#[test]
fn estimate_on_a_gpu_it_cannot_use_says_what_is_missing() {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_matscan"));
    // A loader that finds no driver: the adapter check must turn that
    // into an error, not a panic in burn's worker thread.
    cmd.env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .args(["estimate", "/nonexistent-scan", "--backend", "gpu"]);
    let out = cmd.output().expect("run matscan");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    if cfg!(feature = "vulkan") {
        assert!(
            err.contains("no Vulkan adapter") || err.contains("no Vulkan loader"),
            "{err}"
        );
        assert!(
            err.contains("VK_DRIVER_FILES") || err.contains("libvulkan1"),
            "{err}"
        );
    } else {
        assert!(err.contains("--features vulkan"), "{err}");
    }
    let out = matscan(&["estimate", "/nonexistent-scan", "--backend", "tpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--backend") && err.contains("`tpu`") && err.contains(Backend::NAMES),
        "{err}"
    );
}

#[test]
fn logs_to_a_pipe_carry_no_colour_codes() {
    // A tiny scan that calibration warns about (too few white-reference
    // pixels at 8 px): a warning reaches stderr, which is a pipe here, as
    // it is under a service manager or in a log file.
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("s");
    let scan_arg = scan.display().to_string();
    simulate_sphere(8, 1, 1, &["--out", &scan_arg]);
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_matscan"))
        .args(["calib", "check", &scan_arg])
        .env("RUST_LOG", "info")
        .env_remove("JOURNAL_STREAM")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("WARN"), "{stderr}");
    assert!(!stderr.contains('\u{1b}'), "ANSI escapes in {stderr:?}");
}

#[test]
fn estimate_with_refine_writes_confidence_maps_and_records_the_fit() {
    let tmp = tempfile::tempdir().unwrap();
    let (scan, o) = estimate_fresh_scan(tmp.path(), &["--refine", "3"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(scan.join("estimate/result.toml")).unwrap();
    let result = matscan_estimate::ResultFile::parse(&text).unwrap();
    let refine = result.refine.expect("result.toml records the refinement");
    assert_eq!(refine.iterations, 3);
    assert_eq!(refine.fitted, ["basecolor", "roughness", "metallic"]);
    assert!(refine.kept.contains_key("transmission") && refine.kept.contains_key("subsurface"));
    assert!(refine.stops.values().sum::<u64>() > 0, "{:?}", refine.stops);
    let position = &result.reference_position;
    for param in ["basecolor", "roughness", "metallic"] {
        let path = scan.join(format!("estimate/{position}/{param}_confidence.exr"));
        let map = matscan_scan::image_io::read_scalar_exr(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            map.data
                .iter()
                .all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
            "{param} confidence outside [0, 1]"
        );
        assert!(
            map.data.iter().any(|v| *v > 0.0),
            "{param}: no pixel pinned by the photos"
        );
    }
    assert!(!scan
        .join(format!("estimate/{position}/transmission_confidence.exr"))
        .exists());
}
