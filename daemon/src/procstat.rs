//! This process's resource use from Linux's `/proc/self`: open file
//! descriptors, threads and resident memory. The soak harness
//! (`examples/soak.rs`) and its test read these to show that hundreds of
//! captures leak nothing.
//!
//! Boundaries: reads `/proc`; `None` where it is missing (not Linux).

/// A snapshot of this process's resources.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Usage {
    /// Open file descriptors.
    pub fds: usize,
    /// Threads.
    pub threads: usize,
    /// Resident set size, KiB.
    pub rss_kib: u64,
}

/// This process's resources now.
pub fn usage() -> Option<Usage> {
    let fds = std::fs::read_dir("/proc/self/fd").ok()?.count();
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let field = |name: &str| -> Option<u64> {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))?
            .split_whitespace()
            .next()?
            .parse()
            .ok()
    };
    Some(Usage {
        fds,
        threads: usize::try_from(field("Threads:")?).ok()?,
        rss_kib: field("VmRSS:")?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_opened_file_and_a_started_thread_show_up() {
        let before = usage().expect("Linux /proc");
        let file = std::fs::File::open("/proc/self/status").unwrap();
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let t = std::thread::spawn(move || rx.recv());
        let during = usage().unwrap();
        assert!(during.fds > before.fds, "{before:?} {during:?}");
        assert!(during.threads > before.threads, "{before:?} {during:?}");
        assert!(during.rss_kib > 0);
        drop(file);
        tx.send(()).unwrap();
        let _ = t.join();
    }
}
