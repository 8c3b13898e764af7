//! This process's resource use from Linux's `/proc/self`: open file
//! descriptors, threads and resident memory. The soak harness
//! (`examples/soak.rs`) and its test read these to show that hundreds of
//! captures leak nothing.
//!
//! Boundaries: reads `/proc`; `None` where it is missing (not Linux).
//! Its test is `tests/procstat.rs`, a binary of its own: in the library's
//! test binary other tests start and end threads and files between two
//! readings, which made a unit test here flaky (CI saw 3 threads -> 3).

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
