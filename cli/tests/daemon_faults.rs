//! Injected faults of the simulated rig: each ends in a clear error in
//! `status` and in the log, the daemon keeps serving, and no partial scan
//! appears in the scans folder.

mod daemon_support;

use daemon_support::TestDaemon;
use matscan_daemon::client::{fetch_status, request_capture, ClientError};
use std::io::Write;
use std::sync::{Arc, Mutex, OnceLock};

/// Everything the daemon logs in this test process.
fn log() -> Arc<Mutex<Vec<u8>>> {
    static LOG: OnceLock<Arc<Mutex<Vec<u8>>>> = OnceLock::new();
    LOG.get_or_init(|| {
        let buf = Arc::new(Mutex::new(Vec::new()));
        let sink = buf.clone();
        let subscriber = tracing_subscriber::fmt()
            .with_ansi(false)
            .with_max_level(tracing::Level::INFO)
            .with_writer(move || LogWriter(sink.clone()))
            .finish();
        tracing::subscriber::set_global_default(subscriber).unwrap();
        buf
    })
    .clone()
}

struct LogWriter(Arc<Mutex<Vec<u8>>>);

impl Write for LogWriter {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Starts a daemon with `faults` (keys of `[simulated.faults]`), asks for
/// a capture, and checks the failure everywhere it must show; returns the
/// error text.
fn fault_is_reported(faults: &str, expected: &str) -> String {
    let log = log();
    let dir = tempfile::tempdir().unwrap();
    let d = TestDaemon::start(dir.path(), "", &format!("[simulated.faults]\n{faults}"));
    let err = request_capture(&d.socket, None, true, &mut |_| {}).unwrap_err();
    let ClientError::CaptureFailed(message) = &err else {
        panic!("expected a failed capture, got {err}");
    };
    assert_eq!(err.exit_code(), 5);
    assert!(message.contains(expected), "{faults}: {message}");

    let status = fetch_status(&d.socket).unwrap();
    let last = status["last_error"].as_str().unwrap();
    assert!(last.contains(expected), "status: {status}");
    assert_eq!(status["failed"][0]["error"].as_str().unwrap(), message);
    assert_eq!(status["state"], "idle");

    let text = String::from_utf8_lossy(&log.lock().unwrap()).into_owned();
    assert!(
        text.lines()
            .any(|l| l.contains("ERROR") && l.contains(message.as_str())),
        "log lacks the error `{message}`"
    );
    // No partial scan, no temporary left behind.
    assert!(d.scans().is_empty(), "{:?}", d.scans());
    assert!(d.hidden().is_empty(), "{:?}", d.hidden());
    // Still serving: another request is accepted and answered.
    let again = request_capture(&d.socket, None, true, &mut |_| {}).unwrap_err();
    assert!(again.to_string().contains(expected), "{again}");
    assert!(d.scans().is_empty());
    d.stop();
    message.clone()
}

#[test]
fn a_lost_camera_fails_the_capture_naming_the_camera() {
    let m = fault_is_reported("camera_lost_after = 3", "the camera is gone");
    assert!(m.starts_with("sim:camera:"), "{m}");
}

#[test]
fn a_silent_light_controller_fails_the_capture_with_a_timeout_naming_its_port() {
    let m = fault_is_reported("lights_silent_after = 6", "no reply to");
    assert!(m.starts_with("sim:lights:"), "{m}");
}

#[test]
fn a_flash_that_does_not_fire_is_retried_then_named() {
    let m = fault_is_reported("dead_lights = [\"flash0\"]", "light `flash0` did not fire");
    assert!(m.contains("2 attempts"), "{m}");
}

#[test]
fn a_full_disk_fails_the_capture_and_removes_the_temporary_folder() {
    fault_is_reported("disk_capacity = 3000", "no space left on the device");
}

#[test]
fn a_mesh_that_does_not_match_the_photos_gets_the_estimate_refused_and_keeps_the_photos() {
    use matscan_daemon::service::worker::{EstimateOutcome, Job, Verdict, Worker};
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("scan-0001");
    let scan_arg = scan.display().to_string();
    daemon_support::simulate_sphere(32, 1, 1, &["--out", &scan_arg]);
    // The scanner software left the previous object's mesh: the same
    // sphere, somewhere else.
    let bundle = matscan_scan::Bundle::open(&scan).unwrap();
    let mut mesh = bundle.read_mesh().unwrap();
    for v in &mut mesh.positions {
        v.x += 0.6;
    }
    matscan_scan::mesh_io::write_mesh(&bundle.mesh_path(), &mesh).unwrap();
    let photos_before = std::fs::read_dir(scan.join("views").join("p0"))
        .map(|d| d.count())
        .unwrap_or(0);

    let (tx, rx) = std::sync::mpsc::channel();
    let weights = daemon_support::weights_dir(dir.path(), 3);
    let settings = matscan_daemon::service::config::EstimateSettings {
        enabled: true,
        weights: Some(weights),
    };
    let worker = Worker::spawn(settings, move |job, p| tx.send((job.id, p)).unwrap()).unwrap();
    assert!(worker.submit(Job {
        id: 1,
        scan: scan.clone(),
        given: vec![],
    }));
    let (_, processed) = rx.recv().unwrap();
    worker.finish();
    let Verdict::Problems { problems, geometry } = &processed.check else {
        panic!("expected problems, got {:?}", processed.check);
    };
    assert!(geometry, "{problems:?}");
    assert!(
        problems.iter().any(|p| p.contains("silhouette")),
        "{problems:?}"
    );
    let Some(EstimateOutcome::Failed { error }) = &processed.estimate else {
        panic!("expected a refused estimate, got {:?}", processed.estimate);
    };
    assert!(
        error.contains("estimate refused") && error.contains(&scan_arg) && error.contains("stale"),
        "{error}"
    );
    assert!(!scan.join("estimate").exists(), "nothing estimated");
    let photos_after = std::fs::read_dir(scan.join("views").join("p0"))
        .map(|d| d.count())
        .unwrap_or(0);
    assert_eq!(photos_before, photos_after, "the photos are kept");
    assert!(matscan_scan::Bundle::open(&scan).is_ok());
}
