//! What the daemon knows, shared between the socket's connections, the
//! capture thread and the estimation worker: the queue, each job's events
//! and outcome, the last error. One mutex plus a condition variable, so
//! that `watch` connections and the capture thread wake on every change.
//!
//! Boundaries: bookkeeping only; no device, file or socket I/O.

use super::sequencer::CalibrationPlan;
use super::worker::{EstimateOutcome, Verdict};
use serde_json::{json, Value};
use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard};

/// The profile name of calibration captures, in events and `status`.
pub const CALIBRATION_PROFILE: &str = "calibration";

/// Finished jobs kept for `status` and late `watch` requests.
const KEEP_FINISHED: usize = 32;

#[derive(Debug, Clone, PartialEq)]
pub enum JobStage {
    Queued,
    Capturing,
    Captured { scan: PathBuf, summary: Value },
    Failed { error: String },
}

#[derive(Debug, Clone)]
pub struct JobRecord {
    pub id: u64,
    /// The capture profile; `calibration` for a calibration capture.
    pub profile: String,
    /// `Some` for a calibration capture (`matscan calib capture`): what to
    /// photograph. Its bundle goes to no estimator.
    pub calibration: Option<CalibrationPlan>,
    /// Who asked for it: `socket` or `footswitch`.
    pub source: String,
    pub stage: JobStage,
    /// Every event so far, in order (what `watch` replays).
    pub events: Vec<Value>,
    /// The estimation worker's verdict, once it has one.
    pub check: Option<Verdict>,
    /// The estimate, once the worker has made it (stays `None` when
    /// estimation is off).
    pub estimate: Option<EstimateOutcome>,
    /// The worker is done with this job's scan.
    pub processed: bool,
}

impl JobRecord {
    /// Nothing more will happen to this job: its capture failed, or the
    /// worker is done with its scan.
    pub fn finished(&self) -> bool {
        match self.stage {
            JobStage::Failed { .. } => true,
            JobStage::Captured { .. } => self.processed,
            _ => false,
        }
    }
}

#[derive(Debug, Default)]
pub struct State {
    next_id: u64,
    pub queue: VecDeque<u64>,
    pub current: Option<u64>,
    pub jobs: BTreeMap<u64, JobRecord>,
    pub rig: String,
    /// The last failure (of a capture or of opening the rig).
    pub last_error: Option<String>,
    /// The footswitch as the idle daemon last saw it: `None` when the rig
    /// has none or is not open yet, else "listening" or what went wrong.
    pub footswitch: Option<String>,
    pub stopping: bool,
}

impl State {
    /// Records a new job in `stage`, its first event made from its id by
    /// `first_event`; returns the id.
    fn insert_job(
        &mut self,
        profile: &str,
        source: &str,
        stage: JobStage,
        first_event: impl FnOnce(u64) -> Value,
    ) -> u64 {
        self.next_id += 1;
        let id = self.next_id;
        self.jobs.insert(
            id,
            JobRecord {
                id,
                profile: profile.to_string(),
                source: source.to_string(),
                calibration: None,
                stage,
                events: vec![first_event(id)],
                check: None,
                estimate: None,
                processed: false,
            },
        );
        id
    }

    /// Records a new queued job, asked for by `source`, and returns its id.
    pub fn enqueue(&mut self, profile: &str, source: &str) -> u64 {
        let id = self.insert_job(
            profile,
            source,
            JobStage::Queued,
            |id| json!({"event": "queued", "job": id, "profile": profile, "source": source}),
        );
        self.queue.push_back(id);
        self.prune();
        id
    }

    /// Records a new queued calibration capture of `plan`, asked for by
    /// `source`, and returns its id.
    pub fn enqueue_calibration(&mut self, plan: CalibrationPlan, source: &str) -> u64 {
        let id = self.insert_job(CALIBRATION_PROFILE, source, JobStage::Queued, |id| {
            json!({"event": "queued", "job": id, "calibration": plan.to_json(), "source": source})
        });
        if let Some(job) = self.jobs.get_mut(&id) {
            job.calibration = Some(plan);
        }
        self.queue.push_back(id);
        self.prune();
        id
    }

    /// Records a scan published before this start whose estimate never
    /// finished (the daemon stopped or crashed meanwhile), to be handed to
    /// the worker again; returns its job id.
    pub fn recovered(&mut self, scan: PathBuf, profile: &str) -> u64 {
        let summary = json!({"profile": profile, "recovered": true});
        let stage = JobStage::Captured {
            scan: scan.clone(),
            summary: summary.clone(),
        };
        self.insert_job(
            profile,
            "restart",
            stage,
            |id| json!({"event": "done", "job": id, "scan": scan, "summary": summary}),
        )
    }

    pub fn event(&mut self, id: u64, event: Value) {
        if let Some(job) = self.jobs.get_mut(&id) {
            job.events.push(event);
        }
    }

    pub fn set_stage(&mut self, id: u64, stage: JobStage) {
        if let Some(job) = self.jobs.get_mut(&id) {
            job.stage = stage;
        }
    }

    /// Forgets the oldest finished jobs beyond [`KEEP_FINISHED`].
    fn prune(&mut self) {
        let finished: Vec<u64> = self
            .jobs
            .values()
            .filter(|j| j.finished())
            .map(|j| j.id)
            .collect();
        for id in finished
            .iter()
            .take(finished.len().saturating_sub(KEEP_FINISHED))
        {
            self.jobs.remove(id);
        }
    }

    /// The `status` reply.
    pub fn status_json(&self) -> Value {
        let current = self.current.and_then(|id| self.jobs.get(&id)).map(|j| {
            let progress = j
                .events
                .iter()
                .rev()
                .find(|e| e["event"] == "progress")
                .cloned();
            json!({"job": j.id, "profile": j.profile, "source": j.source, "progress": progress})
        });
        let queue: Vec<Value> = self
            .queue
            .iter()
            .filter_map(|id| self.jobs.get(id))
            .map(|j| json!({"job": j.id, "profile": j.profile, "source": j.source}))
            .collect();
        let last_calibrations: Vec<Value> = self
            .jobs
            .values()
            .rev()
            .filter(|j| j.calibration.is_some())
            .filter_map(|j| match &j.stage {
                JobStage::Captured { scan, summary } => Some(json!({
                    "job": j.id,
                    "bundle": scan,
                    "summary": summary,
                })),
                _ => None,
            })
            .take(10)
            .collect();
        let last_scans: Vec<Value> = self
            .jobs
            .values()
            .rev()
            .filter(|j| j.calibration.is_none())
            .filter_map(|j| match &j.stage {
                JobStage::Captured { scan, summary } => Some(json!({
                    "job": j.id,
                    "source": j.source,
                    "scan": scan,
                    "summary": summary,
                    "check": j.check,
                    "estimate": j.estimate,
                })),
                _ => None,
            })
            .take(10)
            .collect();
        let failed: Vec<Value> = self
            .jobs
            .values()
            .rev()
            .filter_map(|j| match &j.stage {
                JobStage::Failed { error } => Some(json!({"job": j.id, "error": error})),
                _ => None,
            })
            .take(10)
            .collect();
        json!({
            "ok": true,
            "rig": self.rig,
            "footswitch": self.footswitch,
            "state": if self.stopping { "stopping" } else if self.current.is_some() { "capturing" } else { "idle" },
            "current": current,
            "queue": queue,
            "last_scans": last_scans,
            "last_calibrations": last_calibrations,
            "failed": failed,
            "last_error": self.last_error,
        })
    }

    /// One line for systemd's `STATUS=`.
    pub fn status_line(&self) -> String {
        let done = self
            .jobs
            .values()
            .filter(|j| j.calibration.is_none() && matches!(j.stage, JobStage::Captured { .. }))
            .count();
        let now = match self.current.and_then(|id| self.jobs.get(&id)) {
            Some(j) => match j.events.iter().rev().find(|e| e["event"] == "progress") {
                Some(p) => format!(
                    "capturing job {} ({} {}/{})",
                    j.id, p["what"], p["done"], p["total"]
                ),
                None => format!("capturing job {}", j.id),
            },
            None => "idle".to_string(),
        };
        let error = self
            .last_error
            .as_deref()
            .map_or(String::new(), |e| format!("; last error: {e}"));
        format!(
            "{now}; {} queued; {done} scans this run{error}",
            self.queue.len()
        )
    }
}

/// The state with its wake-up signal and the cancellation flag of the
/// running capture.
#[derive(Debug, Default)]
pub struct Shared {
    state: Mutex<State>,
    pub changed: Condvar,
    pub cancel: AtomicBool,
    /// When the capture thread last showed it is alive (monotonic ms).
    heartbeat: AtomicU64,
}

impl Shared {
    pub fn lock(&self) -> MutexGuard<'_, State> {
        // Every update under this lock leaves the state consistent (single
        // pushes and assignments), so a panicked holder left nothing
        // half-done.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The capture thread is alive and not stuck in a driver.
    pub fn beat(&self) {
        self.heartbeat.store(now_ms(), Ordering::SeqCst);
    }

    /// Time since the last [`Shared::beat`].
    pub fn since_beat(&self) -> std::time::Duration {
        let ms = now_ms().saturating_sub(self.heartbeat.load(Ordering::SeqCst));
        std::time::Duration::from_millis(ms)
    }

    /// Runs `f` on the state and wakes every waiter.
    pub fn update<T>(&self, f: impl FnOnce(&mut State) -> T) -> T {
        let value = f(&mut self.lock());
        self.changed.notify_all();
        value
    }

    /// Waits for a change (or `timeout`), returning the guard.
    pub fn wait<'a>(
        &self,
        guard: MutexGuard<'a, State>,
        timeout: std::time::Duration,
    ) -> MutexGuard<'a, State> {
        match self.changed.wait_timeout(guard, timeout) {
            Ok((g, _)) => g,
            Err(p) => p.into_inner().0,
        }
    }
}

fn now_ms() -> u64 {
    u64::try_from(matscan_drivers::monotonic_now().as_millis()).unwrap_or(u64::MAX)
}
