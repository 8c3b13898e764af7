//! A daemon process killed with `kill -9` during a capture, then
//! restarted, leaves the scans folder consistent: the earlier scan is
//! untouched, the interrupted capture's hidden temporary folder is removed
//! at start, and the next capture works. And SIGTERM during a capture
//! stops the daemon gracefully (systemd sees READY and STOPPING, the
//! capture is cancelled without a trace, the socket file is removed).
//!
//! Runs without libtest's harness: `main` re-executes this binary with
//! `--child-daemon CONFIG` to get a daemon in its own process.

mod daemon_support;

use daemon_support::{config_text, list, TestDaemon};
use matscan_daemon::client::{request_capture, CaptureNow, Connection};
use matscan_daemon::service::config::Config;
use matscan_daemon::service::notify::Notifier;
use matscan_daemon::service::server::{install_signal_handlers, Server};
use matscan_scan::Bundle;
use serde_json::json;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--child-daemon") {
        let config = Config::load(Path::new(&args[i + 1])).unwrap();
        install_signal_handlers().unwrap();
        let server = Server::bind(config, Notifier::from_env()).unwrap();
        server.run(&AtomicBool::new(false)).unwrap();
        return;
    }
    kill_9_during_a_capture_then_restart_leaves_the_scans_folder_consistent();
    println!("test kill_9_during_a_capture_then_restart_leaves_the_scans_folder_consistent ... ok");
    sigterm_during_a_capture_stops_gracefully_and_tells_systemd();
    println!("test sigterm_during_a_capture_stops_gracefully_and_tells_systemd ... ok");
}

/// Slow enough photos that a capture is surely under way when killed.
const SLOW: &str = "size = 96\nsamples = 8\npositions = 3";

fn spawn_child(config: &Path, notify: Option<&Path>) -> Child {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.arg("--child-daemon").arg(config);
    cmd.env_remove("NOTIFY_SOCKET");
    if let Some(n) = notify {
        cmd.env("NOTIFY_SOCKET", n);
    }
    cmd.spawn().unwrap()
}

fn wait_for_socket(socket: &Path) {
    let deadline = Instant::now() + Duration::from_secs(60);
    while Connection::open(socket).is_err() {
        assert!(Instant::now() < deadline, "the child daemon never listened");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Starts a capture and returns once its first photo is taken.
fn capture_under_way(socket: &Path) {
    let queued = request_capture(socket, None, false, &mut |_| {}).unwrap();
    let CaptureNow::Queued { job } = queued else {
        panic!("{queued:?}")
    };
    let mut conn = Connection::open(socket).unwrap();
    conn.send(&json!({"cmd": "watch", "job": job})).unwrap();
    loop {
        let e = conn.receive().unwrap();
        assert_ne!(e["event"], "done", "the capture finished too soon");
        if e["event"] == "progress" {
            return;
        }
    }
}

fn files_below(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(files_below(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn kill_9_during_a_capture_then_restart_leaves_the_scans_folder_consistent() {
    let dir = tempfile::tempdir().unwrap();
    let (socket, scans) = (dir.path().join("d.sock"), dir.path().join("scans"));
    let fast = config_text(&socket, &scans, "", "");

    // An earlier, complete scan.
    let d = TestDaemon::start_with(&fast);
    let earlier = match request_capture(&socket, None, true, &mut |_| {}).unwrap() {
        CaptureNow::Captured { scan, .. } => scan,
        other => panic!("{other:?}"),
    };
    d.stop();
    let earlier_files = files_below(&earlier);

    // A daemon process, killed mid-capture.
    let slow_config = dir.path().join("slow.toml");
    std::fs::write(&slow_config, config_text(&socket, &scans, "", SLOW)).unwrap();
    let mut child = spawn_child(&slow_config, None);
    wait_for_socket(&socket);
    capture_under_way(&socket);
    child.kill().unwrap();
    child.wait().unwrap();
    let hidden = list(&scans, |n| n.starts_with('.'));
    assert_eq!(
        hidden.len(),
        1,
        "the interrupted capture's temporary: {hidden:?}"
    );
    assert!(hidden[0]
        .file_name()
        .unwrap()
        .to_string_lossy()
        .starts_with(".scan-0002.tmp-"));
    assert_eq!(list(&scans, |n| !n.starts_with('.')), vec![earlier.clone()]);
    assert!(socket.exists(), "kill -9 leaves the socket file behind");

    // The restart cleans up, replaces the stale socket and captures again.
    let d = TestDaemon::start_with(&fast);
    assert!(d.hidden().is_empty(), "{:?}", d.hidden());
    assert_eq!(files_below(&earlier), earlier_files);
    Bundle::open(&earlier).unwrap().verify_images().unwrap();
    let next = match request_capture(&socket, None, true, &mut |_| {}).unwrap() {
        CaptureNow::Captured { scan, .. } => scan,
        other => panic!("{other:?}"),
    };
    assert_eq!(next, scans.join("scan-0002"));
    Bundle::open(&next).unwrap();
    assert_eq!(d.scans(), vec![earlier, next]);
    d.stop();
}

fn sigterm_during_a_capture_stops_gracefully_and_tells_systemd() {
    let dir = tempfile::tempdir().unwrap();
    let (socket, scans) = (dir.path().join("d.sock"), dir.path().join("scans"));
    let config = dir.path().join("slow.toml");
    std::fs::write(&config, config_text(&socket, &scans, "", SLOW)).unwrap();
    let notify_path = dir.path().join("notify");
    let notify = UnixDatagram::bind(&notify_path).unwrap();
    notify
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    let mut child = spawn_child(&config, Some(&notify_path));
    wait_for_socket(&socket);
    let mut buf = [0u8; 1024];
    let n = notify.recv(&mut buf).unwrap();
    let first = String::from_utf8_lossy(&buf[..n]).into_owned();
    assert!(first.starts_with("READY=1\nSTATUS=idle"), "{first}");
    capture_under_way(&socket);
    // SAFETY: sending a signal to our own child process.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) },
        0
    );
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "the daemon did not stop on SIGTERM"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status}");
    let mut messages = Vec::new();
    notify.set_nonblocking(true).unwrap();
    while let Ok(n) = notify.recv(&mut buf) {
        messages.push(String::from_utf8_lossy(&buf[..n]).into_owned());
    }
    assert!(
        messages
            .iter()
            .any(|m| m.starts_with("STATUS=capturing job 1")),
        "{messages:?}"
    );
    assert!(
        messages.iter().any(|m| m.starts_with("STOPPING=1")),
        "{messages:?}"
    );
    assert!(
        !socket.exists(),
        "the socket file is removed on a graceful stop"
    );
    assert!(
        list(&scans, |_| true).is_empty(),
        "the cancelled capture left nothing"
    );
}
