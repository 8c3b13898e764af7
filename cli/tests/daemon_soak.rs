//! A short soak (its own test binary, so that no other test's threads or
//! files are counted): 30 captures, each estimated, through the socket of a
//! daemon in this process, leave no file descriptor, thread or steadily
//! growing memory behind. The 200-capture soak is `examples/soak.rs`.

use crate::daemon_support;

use daemon_support::{test_weights, TestDaemon};
use matscan_daemon::soak::soak;

#[test]
fn thirty_estimated_captures_leak_no_descriptor_thread_or_memory() {
    let dir = tempfile::tempdir().unwrap();
    let weights = test_weights(dir.path());
    let d = TestDaemon::start(dir.path(), &weights, "size = 16");
    let report = soak(&d.socket, 30, 10, 10).unwrap();
    let (b, e) = (report.baseline, report.end);
    assert!(e.fds <= b.fds, "descriptors {b:?} -> {e:?}");
    assert!(e.threads <= b.threads, "threads {b:?} -> {e:?}");
    // Allocator noise is a few MiB; a leak of one scan's photos, maps or
    // network state per capture would pass 20 MiB well before 20 captures.
    let growth_mib = (e.rss_kib as f64 - b.rss_kib as f64) / 1024.0;
    assert!(
        growth_mib < 20.0,
        "memory grew {growth_mib:.1} MiB: {b:?} -> {e:?}"
    );
    assert_eq!(d.scans().len(), 30);
    assert!(d.hidden().is_empty());
    d.stop();
}
