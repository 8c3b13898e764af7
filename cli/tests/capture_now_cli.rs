//! The `matscan capture-now` and `matscan status` binaries against a
//! daemon (the simulated rig, in this test process): what they print with
//! `--wait --json`, and the documented exit codes 0, 4, 5 and 6
//! (docs/daemon-protocol.md; 3 is in `cli.rs`).

use crate::daemon_support;

use daemon_support::{test_weights, TestDaemon};
use serde_json::Value;
use std::process::{Command, Output};

fn client(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_matscan"))
        .args(args)
        .output()
        .expect("run matscan")
}

fn json_line(o: &Output) -> Value {
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text.lines().last().unwrap_or_default();
    serde_json::from_str(line).unwrap_or_else(|e| panic!("`{line}` is no JSON: {e}"))
}

#[test]
fn capture_now_wait_json_prints_the_scan_and_its_estimate_and_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let weights = test_weights(dir.path());
    let d = TestDaemon::start(dir.path(), &weights, "");
    let socket = d.socket.display().to_string();
    let o = client(&["capture-now", "--socket", &socket, "--wait", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{o:?}");
    let v = json_line(&o);
    assert_eq!(v["scan"], d.scans.join("scan-0001").display().to_string());
    assert_eq!(v["summary"]["positions"], 1);
    assert_eq!(v["summary"]["photos"], 7);
    assert_eq!(v["estimate"]["outcome"], "estimated", "{v}");
    assert!(d.scans.join("scan-0001/estimate/result.toml").is_file());

    let s = client(&["status", "--socket", &socket, "--json"]);
    assert_eq!(s.status.code(), Some(0));
    let s = json_line(&s);
    assert_eq!(s["state"], "idle");
    assert_eq!(s["last_scans"][0]["scan"], v["scan"]);
    assert_eq!(s["last_scans"][0]["source"], "socket");
    let text = client(&["status", "--socket", &socket]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("scan-0001"));

    // Exit 4: refused, naming what was refused.
    let o = client(&["capture-now", "--socket", &socket, "--profile", "glass"]);
    assert_eq!(o.status.code(), Some(4), "{o:?}");
    assert!(String::from_utf8_lossy(&o.stderr).contains("no profile `glass`"));
    let o = client(&[
        "capture-now",
        "--socket",
        &socket,
        "--profile",
        "glass",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(4));
    assert_eq!(json_line(&o)["exit_code"], 4);
    d.stop();
}

#[test]
fn a_failed_capture_exits_5_naming_the_device() {
    let dir = tempfile::tempdir().unwrap();
    let d = TestDaemon::start(dir.path(), "", "[simulated.faults]\ncamera_lost_after = 2");
    let socket = d.socket.display().to_string();
    let o = client(&["capture-now", "--socket", &socket, "--wait"]);
    assert_eq!(o.status.code(), Some(5), "{o:?}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("sim:camera"), "{err}");
    d.stop();
}

#[test]
fn a_failed_estimate_exits_6_after_the_scan_was_published() {
    let dir = tempfile::tempdir().unwrap();
    let weights = daemon_support::weights_dir(dir.path(), 3);
    // A weight file cut short: the estimate must fail and say which file.
    let file = weights.join("metallic.weights");
    let bytes = std::fs::read(&file).unwrap();
    std::fs::write(&file, &bytes[..bytes.len() / 2]).unwrap();
    let d = TestDaemon::start(
        dir.path(),
        &format!("[estimate]\nweights = {weights:?}"),
        "",
    );
    let socket = d.socket.display().to_string();
    let o = client(&["capture-now", "--socket", &socket, "--wait", "--json"]);
    assert_eq!(o.status.code(), Some(6), "{o:?}");
    let v = json_line(&o);
    assert_eq!(v["estimate"]["outcome"], "failed");
    let error = v["estimate"]["error"].as_str().unwrap();
    assert!(error.contains("metallic.weights"), "{error}");
    // The photos are published all the same.
    assert_eq!(d.scans(), vec![d.scans.join("scan-0001")]);
    d.stop();
}
