//! End to end: a daemon on a temporary socket with the simulated rig,
//! `capture-now --wait` through the client, a valid bundle in the scans
//! folder, `status` showing it, and the busy policies.

use crate::daemon_support;

use daemon_support::TestDaemon;
use matscan_daemon::client::{fetch_status, request_capture, CaptureNow, ClientError};
use matscan_scan::Bundle;
use std::os::unix::fs::PermissionsExt;
use std::time::{Duration, Instant};

#[test]
fn capture_now_wait_publishes_a_valid_bundle_that_status_lists_and_the_worker_checks() {
    let dir = tempfile::tempdir().unwrap();
    let weights = daemon_support::test_weights(dir.path());
    let d = TestDaemon::start(dir.path(), &weights, "positions = 2");
    let mode = std::fs::metadata(&d.socket).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o660, "control socket mode");
    let mut events = Vec::new();
    let done = request_capture(&d.socket, None, true, &mut |e| events.push(e.clone())).unwrap();
    let CaptureNow::Captured {
        job,
        scan,
        summary,
        check,
        estimate,
    } = done
    else {
        panic!("expected a finished capture, got {done:?}");
    };
    let verdict = check["verdict"].as_str().unwrap();
    assert!(verdict == "passed" || verdict == "problems", "{check}");
    // The estimate is in the scan folder, with every parameter accounted
    // for and finite errors against the simulated truth.
    assert_eq!(estimate["outcome"], "estimated", "{estimate}");
    let result_file = scan.join("estimate/result.toml");
    let result =
        matscan_estimate::ResultFile::parse(&std::fs::read_to_string(&result_file).unwrap())
            .unwrap();
    for kind in matscan_estimate::PIPELINE_ORDER {
        let p = &estimate["summary"]["params"][kind.name()];
        assert!(p["status"].is_string(), "{kind}: {estimate}");
        assert!(result.param(kind).is_some(), "{kind} in {result_file:?}");
        if p["status"] == "estimated" {
            let mad = p["mad"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&mad), "{kind}: {p}");
        }
    }
    assert_eq!(
        estimate["summary"]["params"]["metallic"]["status"],
        "estimated"
    );
    assert!(events.iter().any(|e| e["event"] == "estimated"));
    assert_eq!(job, 1);
    assert_eq!(scan, d.scans.join("scan-0001"));
    assert_eq!(summary["positions"], 2);
    assert_eq!(summary["photos"], 14);
    assert_eq!(summary["profile"], "full");
    let progress: Vec<_> = events.iter().filter(|e| e["event"] == "progress").collect();
    assert_eq!(progress.len(), 14);
    let last = progress.last().unwrap()["what"].as_str().unwrap();
    assert!(last.starts_with("p1/checker_"), "{last}");
    let bundle = Bundle::open(&scan).unwrap();
    bundle.verify_images().unwrap();
    assert_eq!(bundle.manifest.positions.len(), 2);
    assert_eq!(d.scans(), vec![scan.clone()]);
    assert!(d.hidden().is_empty());

    // The worker's verdict arrives in `status`.
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        let s = fetch_status(&d.socket).unwrap();
        if !s["last_scans"][0]["estimate"].is_null() || Instant::now() > deadline {
            break s;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(status["last_scans"][0]["estimate"]["outcome"], "estimated");
    assert_eq!(status["state"], "idle");
    assert_eq!(status["last_scans"][0]["scan"], scan.to_str().unwrap());
    let verdict = status["last_scans"][0]["check"]["verdict"]
        .as_str()
        .unwrap();
    assert!(verdict == "passed" || verdict == "problems", "{status}");
    assert!(status["last_error"].is_null());
    let text = matscan_daemon::client::format_status(&status);
    assert!(text.contains("scan-0001"), "{text}");
    assert!(status["rig"].as_str().unwrap().starts_with("simulated"));
    d.stop();
}

#[test]
fn a_given_parameter_profile_leaves_captures_out_and_unknown_profiles_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = TestDaemon::start(
        dir.path(),
        "[profiles.opaque]\ngiven = [\"transmission\", \"subsurface\"]",
        "",
    );
    let err = request_capture(&d.socket, Some("glass"), true, &mut |_| {}).unwrap_err();
    assert!(matches!(err, ClientError::Refused(_)), "{err}");
    assert_eq!(err.exit_code(), 4);
    assert!(err.to_string().contains("no profile `glass`"), "{err}");
    let done = request_capture(&d.socket, Some("opaque"), true, &mut |_| {}).unwrap();
    let CaptureNow::Captured { scan, summary, .. } = done else {
        panic!("{done:?}")
    };
    assert_eq!(summary["photos"], 4);
    let bundle = Bundle::open(&scan).unwrap();
    assert!(bundle.manifest.positions[0].backlit().is_none());
    let info = std::fs::read_to_string(scan.join("capture.toml")).unwrap();
    assert!(
        info.contains("given = [\"transmission\", \"subsurface\"]"),
        "{info}"
    );
}

#[test]
fn with_busy_refuse_a_press_during_a_capture_is_refused_never_interleaved() {
    let dir = tempfile::tempdir().unwrap();
    // Slower photos so the second press surely lands during the first.
    let d = TestDaemon::start(
        dir.path(),
        "busy = \"refuse\"",
        "positions = 2\nsize = 48\nsamples = 4",
    );
    let first = request_capture(&d.socket, None, false, &mut |_| {}).unwrap();
    assert_eq!(first, CaptureNow::Queued { job: 1 });
    let err = request_capture(&d.socket, None, false, &mut |_| {}).unwrap_err();
    assert!(
        err.to_string().contains("a capture is running (job 1)"),
        "{err}"
    );
    let deadline = Instant::now() + Duration::from_secs(120);
    while d.scans().is_empty() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(d.scans(), vec![d.scans.join("scan-0001")]);
}

#[test]
fn with_busy_queue_presses_wait_their_turn_and_each_gets_its_own_scan() {
    let dir = tempfile::tempdir().unwrap();
    let d = TestDaemon::start(dir.path(), "busy = \"queue\"\nqueue_limit = 2", "");
    let a = request_capture(&d.socket, None, false, &mut |_| {}).unwrap();
    let b = request_capture(&d.socket, None, false, &mut |_| {}).unwrap();
    assert_eq!(
        (a, b),
        (CaptureNow::Queued { job: 1 }, CaptureNow::Queued { job: 2 })
    );
    // Job 2 waits behind job 1 (the limit of 2 accepts both whether or not
    // job 1 has started); a watcher of job 2 sees it through to its scan.
    let mut conn = matscan_daemon::client::Connection::open(&d.socket).unwrap();
    conn.send(&serde_json::json!({"cmd": "watch", "job": 2}))
        .unwrap();
    let mut events = Vec::new();
    loop {
        let e = conn.receive().unwrap();
        let end = e["event"] == "done" || e["event"] == "failed";
        events.push(e);
        if end {
            break;
        }
    }
    assert_eq!(events.last().unwrap()["event"], "done", "{events:?}");
    assert_eq!(
        d.scans(),
        vec![d.scans.join("scan-0001"), d.scans.join("scan-0002")]
    );
    for s in d.scans() {
        Bundle::open(&s).unwrap();
    }
}

#[test]
fn the_socket_goes_to_socket_group_and_an_unknown_group_is_refused_naming_it() {
    use std::os::unix::fs::MetadataExt;
    let group = daemon_support::own_group_name().expect("this process's group");
    let gid = matscan_daemon::service::server::group_id(&group)
        .unwrap()
        .expect("the group exists");
    let dir = tempfile::tempdir().unwrap();
    let d = TestDaemon::start(dir.path(), &format!("socket_group = {group:?}"), "");
    let meta = std::fs::metadata(&d.socket).unwrap();
    assert_eq!(meta.gid(), gid);
    assert_eq!(meta.permissions().mode() & 0o777, 0o660);
    d.stop();

    let other = tempfile::tempdir().unwrap();
    let text = daemon_support::config_text(
        &other.path().join("s.sock"),
        &other.path().join("scans"),
        "socket_group = \"no-such-group-matscan\"",
        "",
    );
    let config =
        matscan_daemon::service::config::Config::parse(&text, std::path::Path::new("t.toml"))
            .unwrap();
    let err = matscan_daemon::service::server::Server::bind(
        config,
        matscan_daemon::service::notify::Notifier::new(None, None),
    )
    .err()
    .expect("an unknown group is refused")
    .to_string();
    assert!(
        err.contains("socket_group `no-such-group-matscan`"),
        "{err}"
    );
}

#[test]
fn a_scan_published_but_never_estimated_is_estimated_after_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let scans = dir.path().join("scans");
    std::fs::create_dir_all(&scans).unwrap();
    // scan-0001 has its estimate; scan-0002 and scan-0003 were published
    // just before the daemon died, their estimates never written.
    for n in 1..=3 {
        let out = scans.join(format!("scan-{n:04}"));
        daemon_support::simulate_sphere(24, 1, 1, &["--out", &out.display().to_string()]);
    }
    std::fs::create_dir_all(scans.join("scan-0001/estimate")).unwrap();
    std::fs::write(scans.join("scan-0001/estimate/result.toml"), "").unwrap();
    let weights = daemon_support::test_weights(dir.path());
    let d = TestDaemon::start(dir.path(), &weights, "");
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        let s = fetch_status(&d.socket).unwrap();
        let done = s["last_scans"]
            .as_array()
            .is_some_and(|l| l.len() == 2 && l.iter().all(|j| !j["estimate"].is_null()));
        if done || Instant::now() > deadline {
            break s;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let recovered: Vec<&str> = status["last_scans"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            assert_eq!(j["source"], "restart", "{j}");
            assert_eq!(j["estimate"]["outcome"], "estimated", "{j}");
            j["scan"].as_str().unwrap()
        })
        .collect();
    let expected: Vec<String> = ["scan-0003", "scan-0002"]
        .iter()
        .map(|n| scans.join(n).display().to_string())
        .collect();
    assert_eq!(recovered, expected, "{status}");
    for n in ["scan-0002", "scan-0003"] {
        assert!(scans.join(n).join("estimate/result.toml").is_file(), "{n}");
    }
    // The one already estimated was left alone.
    assert_eq!(
        std::fs::read_to_string(scans.join("scan-0001/estimate/result.toml")).unwrap(),
        ""
    );
    d.stop();
}
