//! The soak harness: many captures in a row through the control socket,
//! with this process's file descriptors, threads and memory sampled as they
//! go (the daemon must run in this process, as `examples/soak.rs` and
//! `tests/daemon_soak.rs` start it, for the figures to be the daemon's).
//!
//! Boundaries: a client of the socket plus `/proc` readings; judging the
//! figures is the caller's.

use crate::client::{request_capture, CaptureNow};
use crate::procstat::{usage, Usage};
use std::path::Path;
use std::time::{Duration, Instant};

/// What a soak measured.
#[derive(Clone, Debug)]
pub struct SoakReport {
    /// Resources after the warm-up captures (caches filled, pools started).
    pub baseline: Usage,
    /// Resources after the last capture, once the connection threads of
    /// the finished requests have ended.
    pub end: Usage,
    /// `(captures done, usage)` every `every` captures.
    pub samples: Vec<(usize, Usage)>,
    /// Wall seconds of each capture, estimate included.
    pub seconds: Vec<f64>,
}

impl SoakReport {
    /// Median seconds per capture.
    pub fn median_seconds(&self) -> f64 {
        let mut s = self.seconds.clone();
        s.sort_by(f64::total_cmp);
        s.get(s.len() / 2).copied().unwrap_or(0.0)
    }
}

/// Waits up to two seconds for the threads of finished connections to end,
/// then samples.
fn settled(limit_threads: usize) -> Option<Usage> {
    let deadline = Instant::now() + Duration::from_secs(2);
    loop {
        let u = usage()?;
        if u.threads <= limit_threads || Instant::now() > deadline {
            return Some(u);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Runs `captures` captures one after another on the daemon at `socket`,
/// each waited for to the end of its estimate; the baseline is taken after
/// `warmup` of them. Fails on the first capture or estimate that fails.
pub fn soak(
    socket: &Path,
    captures: usize,
    warmup: usize,
    every: usize,
) -> Result<SoakReport, String> {
    let no_proc = || "no /proc/self to measure (not Linux?)".to_string();
    let mut baseline = usage().ok_or_else(no_proc)?;
    let mut samples = Vec::new();
    let mut seconds = Vec::with_capacity(captures);
    for i in 1..=captures {
        let t = Instant::now();
        match request_capture(socket, None, true, &mut |_| {}) {
            Ok(CaptureNow::Captured { estimate, .. }) => {
                if estimate["outcome"] == "failed" {
                    return Err(format!("capture {i}: estimate failed: {estimate}"));
                }
            }
            Ok(other) => return Err(format!("capture {i}: {other:?}")),
            Err(e) => return Err(format!("capture {i}: {e}")),
        }
        seconds.push(t.elapsed().as_secs_f64());
        if i == warmup {
            baseline = settled(0).ok_or_else(no_proc)?;
        }
        if every > 0 && i % every == 0 {
            samples.push((i, settled(baseline.threads).ok_or_else(no_proc)?));
        }
    }
    let end = settled(baseline.threads).ok_or_else(no_proc)?;
    Ok(SoakReport {
        baseline,
        end,
        samples,
        seconds,
    })
}
