//! The estimation worker: a thread fed through a `crossbeam-channel`, so
//! that the next capture can start while the last scan is processed.
//!
//! For now the worker checks each new scan's calibration against its
//! photos (`matscan_calib::check`, as `matscan calib check` does) and
//! reports the verdict; the estimator is hooked in here later, after the
//! check.
//!
//! Boundaries: reads published scans only; never writes into them.

use crossbeam_channel::{unbounded, Sender};
use matscan_calib::check::{check, CheckOptions};
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_scan::Bundle;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

/// A published scan to process.
#[derive(Debug, Clone)]
pub struct Job {
    pub id: u64,
    pub scan: PathBuf,
}

/// What the worker concluded about a scan.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum Verdict {
    /// Every calibration check passed.
    Passed,
    /// The scan is complete but a check failed (a wrong pose, a misplaced
    /// light).
    Problems { problems: Vec<String> },
    /// The scan could not be checked at all.
    Failed { error: String },
}

/// The running worker; dropping the handle's sender ends it.
pub struct Worker {
    tx: Option<Sender<Job>>,
    handle: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the thread; `done` hears each job's verdict.
    pub fn spawn(done: impl Fn(&Job, Verdict) + Send + 'static) -> std::io::Result<Worker> {
        let (tx, rx) = unbounded::<Job>();
        let handle = std::thread::Builder::new()
            .name("matscan-estimate".into())
            .spawn(move || {
                for job in rx {
                    tracing::info!("job {}: checking {}", job.id, job.scan.display());
                    let verdict = check_scan(&job.scan);
                    match &verdict {
                        Verdict::Passed => {
                            tracing::info!("job {}: calibration check passed", job.id)
                        }
                        Verdict::Problems { problems } => tracing::warn!(
                            "job {}: calibration check found problems: {}",
                            job.id,
                            problems.join("; ")
                        ),
                        Verdict::Failed { error } => {
                            tracing::error!("job {}: cannot check the scan: {error}", job.id)
                        }
                    }
                    done(&job, verdict);
                }
            })?;
        Ok(Worker {
            tx: Some(tx),
            handle: Some(handle),
        })
    }

    /// Queues `job`; `false` if the worker is gone.
    pub fn submit(&self, job: Job) -> bool {
        self.tx.as_ref().is_some_and(|tx| tx.send(job).is_ok())
    }

    /// Lets the worker finish what it was given, then joins it.
    pub fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        self.tx = None;
        if let Some(h) = self.handle.take() {
            if h.join().is_err() {
                tracing::error!("the estimation worker panicked");
            }
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Opens, calibrates and checks the scan at `scan`.
pub fn check_scan(scan: &Path) -> Verdict {
    let run = || -> Result<Vec<String>, String> {
        let bundle = Bundle::open(scan).map_err(|e| e.to_string())?;
        let calibration =
            calibrate_bundle(&bundle, &CalibOptions::default()).map_err(|e| e.to_string())?;
        let report = check(
            &bundle.manifest,
            &calibration,
            &bundle,
            &CheckOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        Ok(report.problems)
    };
    match run() {
        Ok(problems) if problems.is_empty() => Verdict::Passed,
        Ok(problems) => Verdict::Problems { problems },
        Err(error) => Verdict::Failed { error },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::channel;

    #[test]
    fn a_missing_scan_is_reported_as_failed_with_its_path() {
        let (tx, rx) = channel();
        let worker = Worker::spawn(move |job, v| tx.send((job.id, v)).unwrap()).unwrap();
        assert!(worker.submit(Job {
            id: 7,
            scan: PathBuf::from("/nonexistent/scan-0001"),
        }));
        let (id, verdict) = rx.recv().unwrap();
        assert_eq!(id, 7);
        match verdict {
            Verdict::Failed { error } => {
                assert!(error.contains("/nonexistent/scan-0001"), "{error}")
            }
            other => panic!("expected a failure, got {other:?}"),
        }
        worker.finish();
    }
}
