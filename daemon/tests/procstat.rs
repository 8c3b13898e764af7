//! `procstat::usage` sees a file opened and a thread started. One test in a
//! binary of its own: with other tests running beside it, their threads and
//! files come and go between the two readings (a unit test in the library
//! once read 3 threads before and 3 after starting one).

use matscan_daemon::procstat::usage;

#[test]
fn an_opened_file_and_a_started_thread_show_up() {
    let before = usage().expect("Linux /proc");
    let file = std::fs::File::open("/proc/self/status").unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    let t = std::thread::spawn(move || rx.recv());
    let during = usage().unwrap();
    assert_eq!(during.fds, before.fds + 1, "{before:?} {during:?}");
    assert_eq!(during.threads, before.threads + 1, "{before:?} {during:?}");
    assert!(during.rss_kib > 0);
    drop(file);
    tx.send(()).unwrap();
    t.join().unwrap().unwrap();
    // The kernel drops a thread from the count a moment after `join`
    // returns (the tid is cleared before the task is released).
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(2);
    let after = loop {
        let u = usage().unwrap();
        if u.threads == before.threads || std::time::Instant::now() > deadline {
            break u;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    assert_eq!(after.fds, before.fds, "{before:?} {after:?}");
    assert_eq!(after.threads, before.threads, "{before:?} {after:?}");
}
