//! The footswitch starts captures: a daemon with the simulated rig whose
//! pedal is a named pipe (`[simulated] footswitch`), pressed by writing a
//! line to it, as an operator's foot would press the real one. No socket
//! request asks for these captures; `status` only watches.

use crate::daemon_support;

use daemon_support::TestDaemon;
use matscan_daemon::client::fetch_status;
use serde_json::Value;
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};

fn press(pedal: &Path) {
    let mut w = std::fs::OpenOptions::new()
        .write(true)
        .open(pedal)
        .expect("the daemon's pedal pipe");
    w.write_all(b"\n").unwrap();
}

/// Polls `status` until `done` holds (or a minute passes) and returns it.
fn status_until(d: &TestDaemon, done: impl Fn(&Value) -> bool) -> Value {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let s = fetch_status(&d.socket).unwrap();
        if done(&s) || Instant::now() > deadline {
            return s;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_press_starts_a_capture_and_a_press_at_each_position_moves_on() {
    let dir = tempfile::tempdir().unwrap();
    let pedal = dir.path().join("pedal");
    // No turntable: between positions the operator turns the object and
    // presses again. Refuse, so the extra presses below queue nothing.
    let d = TestDaemon::start(
        dir.path(),
        "busy = \"refuse\"\n[capture]\noperator_timeout_s = 30",
        &format!("positions = 2\nturntable = false\nfootswitch = {pedal:?}"),
    );
    let idle = status_until(&d, |s| s["footswitch"] == "listening");
    assert_eq!(idle["footswitch"], "listening", "{idle}");
    assert_eq!(idle["state"], "idle");
    assert!(d.scans().is_empty());

    press(&pedal);
    let capturing = status_until(&d, |s| {
        s["state"] == "capturing" || !s["last_scans"][0].is_null()
    });
    assert!(
        capturing["last_scans"][0].is_null()
            || capturing["last_scans"][0]["source"] == "footswitch"
    );
    // The operator presses until the sequencer, waiting at p1, moves on
    // (presses during the photos do not count as "the object is in place").
    let deadline = Instant::now() + Duration::from_secs(60);
    while d.scans().is_empty() && Instant::now() < deadline {
        press(&pedal);
        std::thread::sleep(Duration::from_millis(100));
    }
    let done = status_until(&d, |s| {
        s["state"] == "idle" && !s["last_scans"][0].is_null()
    });
    assert_eq!(d.scans(), vec![d.scans.join("scan-0001")], "{done}");
    let scan = &done["last_scans"][0];
    assert_eq!(scan["job"], 1);
    assert_eq!(scan["source"], "footswitch");
    assert_eq!(scan["summary"]["positions"], 2);
    assert_eq!(scan["summary"]["photos"], 14);
    let bundle = matscan_scan::Bundle::open(d.scans.join("scan-0001")).unwrap();
    bundle.verify_images().unwrap();
    assert!(d.hidden().is_empty());
    d.stop();
}

/// Starts a daemon whose captures take a few seconds, presses once, and
/// presses again (after the debounce) while the capture runs; returns the
/// daemon and its status once everything has settled.
fn press_during_a_capture(dir: &Path, busy: &str) -> (TestDaemon, Value) {
    let pedal = dir.join("pedal");
    let d = TestDaemon::start(
        dir,
        busy,
        &format!("positions = 3\nsize = 96\nsamples = 16\nfootswitch = {pedal:?}"),
    );
    status_until(&d, |s| s["footswitch"] == "listening");
    press(&pedal);
    let running = status_until(&d, |s| s["state"] == "capturing");
    assert_eq!(running["current"]["source"], "footswitch", "{running}");
    std::thread::sleep(matscan_daemon::service::server::DEBOUNCE + Duration::from_millis(50));
    let still = fetch_status(&d.socket).unwrap();
    assert_eq!(
        still["current"]["job"], 1,
        "the capture must still run for this test to mean anything: {still}"
    );
    press(&pedal);
    let settled = status_until(&d, |s| {
        s["state"] == "idle"
            && s["queue"].as_array().is_some_and(Vec::is_empty)
            && !s["last_scans"][0].is_null()
    });
    // A queued second capture starts right after the first: wait for it too.
    let settled = if settled["last_scans"].as_array().map_or(0, Vec::len) < 2 {
        std::thread::sleep(Duration::from_millis(500));
        status_until(&d, |s| {
            s["state"] == "idle" && s["queue"].as_array().is_some_and(Vec::is_empty)
        })
    } else {
        settled
    };
    (d, settled)
}

#[test]
fn with_busy_queue_a_press_during_a_capture_queues_one_more() {
    let dir = tempfile::tempdir().unwrap();
    let (d, s) = press_during_a_capture(dir.path(), "busy = \"queue\"");
    let scans = s["last_scans"].as_array().unwrap();
    assert_eq!(scans.len(), 2, "{s}");
    assert!(scans.iter().all(|j| j["source"] == "footswitch"), "{s}");
    assert_eq!(
        d.scans(),
        vec![d.scans.join("scan-0001"), d.scans.join("scan-0002")]
    );
    d.stop();
}

#[test]
fn with_busy_refuse_a_press_during_a_capture_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (d, s) = press_during_a_capture(dir.path(), "busy = \"refuse\"");
    std::thread::sleep(Duration::from_millis(500));
    assert_eq!(s["last_scans"].as_array().unwrap().len(), 1, "{s}");
    assert_eq!(d.scans(), vec![d.scans.join("scan-0001")]);
    assert!(fetch_status(&d.socket).unwrap()["queue"]
        .as_array()
        .unwrap()
        .is_empty());
    d.stop();
}
