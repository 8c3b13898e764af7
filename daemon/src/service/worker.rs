//! The estimation worker: a thread fed through a `crossbeam-channel`, so
//! that the next capture can start while the last scan is processed.
//!
//! Per scan it first checks the calibration against the photos
//! (`matscan_calib::check`, as `matscan calib check` does). Where the
//! mesh's silhouette does not match the photographed object (a stale mesh
//! export, a wrong pose in the rig calibration), the estimate is refused
//! with that reason: its maps would be the wrong pixels' materials. The
//! photos stay; `matscan estimate SCAN` runs once the mesh is fixed. A
//! light check that fails only warns: its correlation is low on strongly
//! textured objects (see `matscan_calib::check`). Then, unless the
//! configuration turns it off, the worker estimates the BSDF maps into
//! `<scan>/estimate` (`matscan_estimate::estimate`, as `matscan estimate`
//! does). Parameters the capture profile gives are passed as the
//! documented defaults (`matscan_scan::Param::default_value`: 0 for
//! metallic, transmission and subsurface), so an "opaque" profile means
//! what it says; parameters the captures cannot support are skipped by the
//! estimator with the reason in `result.toml`.
//!
//! Boundaries: writes only the scan's `estimate/` folder (atomically, via
//! the estimator); never touches the photos.

use super::config::EstimateSettings;
use crossbeam_channel::{unbounded, Sender};
use matscan_calib::check::{check, CheckOptions};
use matscan_estimate::pipeline::run::{estimate_prepared, PreparedScan};
use matscan_estimate::{cpu_device, EstimateOptions, Given, ModelSource};
use matscan_scan::Param;
use serde::Serialize;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::thread::JoinHandle;

/// A published scan to process.
#[derive(Debug, Clone)]
pub struct Job {
    pub id: u64,
    pub scan: PathBuf,
    /// Parameters the capture profile gives.
    pub given: Vec<Param>,
}

/// What the worker made of a scan: the calibration verdict, then the
/// estimate (`None` when estimation is turned off).
#[derive(Debug, Clone, PartialEq)]
pub struct Processed {
    pub check: Verdict,
    pub estimate: Option<EstimateOutcome>,
}

/// How the estimate of a scan ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum EstimateOutcome {
    /// `summary`: the folder, each parameter's status (with metrics where
    /// the scan has truth) and the timings.
    Estimated {
        summary: Value,
    },
    Failed {
        error: String,
    },
}

/// What the worker concluded about a scan.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "verdict", rename_all = "snake_case")]
pub enum Verdict {
    /// Every calibration check passed.
    Passed,
    /// The scan is complete but a check failed (a wrong pose, a misplaced
    /// light). `geometry`: the mesh's silhouette does not match the photos,
    /// so the estimate is refused.
    Problems {
        problems: Vec<String>,
        geometry: bool,
    },
    /// The scan could not be checked at all.
    Failed { error: String },
}

/// The running worker; dropping the handle's sender ends it.
pub struct Worker {
    tx: Option<Sender<Job>>,
    handle: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the thread; `done` hears what became of each job.
    pub fn spawn(
        settings: EstimateSettings,
        done: impl Fn(&Job, Processed) + Send + 'static,
    ) -> std::io::Result<Worker> {
        let (tx, rx) = unbounded::<Job>();
        let handle = std::thread::Builder::new()
            .name("matscan-estimate".into())
            .spawn(move || {
                for job in rx {
                    tracing::info!("job {}: checking {}", job.id, job.scan.display());
                    let (verdict, prepared) = check_scan(&job.scan);
                    match &verdict {
                        Verdict::Passed => {
                            tracing::info!("job {}: calibration check passed", job.id)
                        }
                        Verdict::Problems { problems, .. } => tracing::warn!(
                            "job {}: calibration check found problems: {}",
                            job.id,
                            problems.join("; ")
                        ),
                        Verdict::Failed { error } => {
                            tracing::error!("job {}: cannot check the scan: {error}", job.id)
                        }
                    }
                    let estimate = settings.enabled.then(|| {
                        let outcome = match &verdict {
                            Verdict::Problems {
                                problems,
                                geometry: true,
                            } => EstimateOutcome::Failed {
                                error: refusal(&job.scan, problems),
                            },
                            _ => {
                                tracing::info!("job {}: estimating {}", job.id, job.scan.display());
                                estimate_scan(&job, &prepared, &settings)
                            }
                        };
                        match &outcome {
                            EstimateOutcome::Estimated { summary } => {
                                tracing::info!("job {}: estimated: {summary}", job.id)
                            }
                            EstimateOutcome::Failed { error } => {
                                tracing::error!("job {}: estimate failed: {error}", job.id)
                            }
                        }
                        outcome
                    });
                    done(
                        &job,
                        Processed {
                            check: verdict,
                            estimate,
                        },
                    );
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

/// Why the estimate of `scan` is refused.
fn refusal(scan: &Path, problems: &[String]) -> String {
    format!(
        "{}: estimate refused: the mesh does not match the photos ({}); is the scanner's \
         mesh export stale, or the rig calibration wrong? The photos are kept: fix the mesh \
         or the calibration, then run `matscan estimate {}`",
        scan.display(),
        problems.join("; "),
        scan.display()
    )
}

/// Opens, calibrates and checks the scan at `scan`; the opened and
/// calibrated scan (or why it could not be) comes back for the estimate,
/// so it is opened and calibrated once.
pub fn check_scan(scan: &Path) -> (Verdict, Result<PreparedScan, String>) {
    let prepared = match PreparedScan::open(scan, &EstimateOptions::default().calib) {
        Ok(p) => p,
        Err(e) => {
            let error = e.to_string();
            return (
                Verdict::Failed {
                    error: error.clone(),
                },
                Err(error),
            );
        }
    };
    let report = check(
        &prepared.bundle.manifest,
        &prepared.calibration,
        &prepared.bundle,
        &CheckOptions::default(),
    );
    let verdict = match report {
        Ok(r) if r.problems.is_empty() => Verdict::Passed,
        Ok(r) => Verdict::Problems {
            problems: r.problems,
            geometry: r.geometry_mismatch,
        },
        Err(e) => Verdict::Failed {
            error: e.to_string(),
        },
    };
    (verdict, Ok(prepared))
}

/// Estimates `job`'s scan into `<scan>/estimate` from the scan the check
/// opened and calibrated; a scan that could not be opened fails with that
/// reason.
pub fn estimate_scan(
    job: &Job,
    prepared: &Result<PreparedScan, String>,
    settings: &EstimateSettings,
) -> EstimateOutcome {
    let models = match &settings.weights {
        Some(dir) => ModelSource::Dir(dir.clone()),
        None => ModelSource::Embedded,
    };
    let given = job
        .given
        .iter()
        .copied()
        .map(|k| (k, Given::Constant(k.default_value())))
        .collect();
    let options = EstimateOptions {
        given,
        ..EstimateOptions::default()
    };
    let prepared = match prepared {
        Ok(p) => p,
        Err(error) => {
            return EstimateOutcome::Failed {
                error: format!("{}: {error}", job.scan.display()),
            }
        }
    };
    match estimate_prepared(prepared, models, &options, &cpu_device()) {
        Ok(report) => EstimateOutcome::Estimated {
            summary: summary(&report.out, &report.result),
        },
        Err(e) => EstimateOutcome::Failed {
            error: format!("{}: {e}", job.scan.display()),
        },
    }
}

/// The JSON summary of an estimate: what `capture-now --wait` prints.
pub fn summary(out: &Path, result: &matscan_estimate::ResultFile) -> Value {
    let params: serde_json::Map<String, Value> = matscan_estimate::PIPELINE_ORDER
        .iter()
        .filter_map(|k| result.param(*k).map(|p| (*k, p)))
        .map(|(k, p)| {
            let mut v = json!({"status": p.status, "method": p.answered_by()});
            if let Some(r) = &p.reason {
                v["reason"] = json!(r);
            }
            if let Some(share) = p.constrained {
                v["constrained"] = json!(share);
            }
            if let Some(seconds) = p.seconds {
                v["seconds"] = json!(seconds);
            }
            if let Some(m) = result.metrics.get(k.name()) {
                v["mad"] = json!(m.mad);
                v["mse"] = json!(m.mse);
                v["psnr"] = json!(m.psnr);
            }
            (k.name().to_string(), v)
        })
        .collect();
    json!({
        "out": out,
        "views": result.views.len(),
        "params": params,
        "seconds": result.timings.total_s,
        "networks": result.timings.networks,
        "stages": {
            "load": result.timings.load_s,
            "calibration": result.timings.calibration_s,
            "inputs": result.timings.inputs_s,
            "weights": result.timings.weights_s,
            "networks": result.timings.networks.values().sum::<f64>(),
            "fit": result.timings.fit_s,
            "refine": result.timings.refine_s,
            "metrics": result.timings.metrics_s,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::channel;

    #[test]
    fn a_missing_scan_is_reported_as_failed_with_its_path() {
        let (tx, rx) = channel();
        let worker = Worker::spawn(EstimateSettings::default(), move |job, v| {
            tx.send((job.id, v)).unwrap()
        })
        .unwrap();
        assert!(worker.submit(Job {
            id: 7,
            scan: PathBuf::from("/nonexistent/scan-0001"),
            given: vec![],
        }));
        let (id, processed) = rx.recv().unwrap();
        assert_eq!(id, 7);
        match processed.check {
            Verdict::Failed { error } => {
                assert!(error.contains("/nonexistent/scan-0001"), "{error}")
            }
            other => panic!("expected a failure, got {other:?}"),
        }
        match processed.estimate {
            Some(EstimateOutcome::Failed { error }) => {
                assert!(error.contains("/nonexistent/scan-0001"), "{error}")
            }
            other => panic!("expected a failed estimate, got {other:?}"),
        }
        worker.finish();
    }
}
