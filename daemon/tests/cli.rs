//! The `matscan` binary end to end: the commands a user types, on small
//! simulated scans.

use std::path::Path;
use std::process::Command;

fn matscan(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_matscan"))
        .args(args)
        .output()
        .expect("run matscan")
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn simulate(out: &Path) {
    let o = matscan(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--size",
        "48",
        "--positions",
        "2",
        "--samples",
        "2",
        "--geometry",
        "sphere",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn demo_simulates_a_numbered_scan_and_draws_its_sheet() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("demo");
    let args = [
        "demo",
        "--out",
        root.to_str().unwrap(),
        "--size",
        "48",
        "--samples",
        "2",
    ];
    let first = matscan(&args);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    assert!(stdout(&first).contains("capture (render)"));
    assert!(root.join("scan-0001/scan.toml").exists());
    assert!(root.join("scan-0001/sheet.png").exists());
    // A second run never overwrites the first scan.
    let second = matscan(&args);
    assert!(second.status.success());
    assert!(root.join("scan-0002/scan.toml").exists());
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
