//! The daemon's life: clean the scans folder, bind the control socket,
//! run the capture thread (one capture at a time, from the queue) and the
//! estimation worker, tell systemd, and stop gracefully.
//!
//! Boundaries: owns threads, the socket file and the scans folder's
//! housekeeping; the photos are the sequencer's, the protocol the socket
//! module's.

use super::config::Config;
use super::notify::Notifier;
use super::plan::plan;
use super::request::{request_capture, Source};
use super::sequencer::{CalibrationPlan, CaptureError, Progress, RigDevices, RunSettings};
use super::state::{JobStage, Shared};
use super::worker::{EstimateOutcome, Job, Processed, Worker};
use matscan_drivers::Press;
use serde_json::json;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    #[error("{path}: {action}: {source}")]
    Io {
        path: PathBuf,
        action: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: another daemon is already listening on this socket")]
    SocketInUse { path: PathBuf },
    #[error("socket_group `{group}`: no such group on this machine")]
    NoSuchGroup { group: String },
}

fn io_err(path: &Path, action: &'static str) -> impl FnOnce(std::io::Error) -> ServerError {
    let path = path.to_path_buf();
    move |source| ServerError::Io {
        path,
        action,
        source,
    }
}

/// A bound daemon, ready to [`Server::run`].
pub struct Server {
    config: Arc<Config>,
    shared: Arc<Shared>,
    listener: UnixListener,
    notifier: Notifier,
}

impl Server {
    /// Prepares the scans folder (removing what an interrupted capture
    /// left) and binds the control socket (mode 0660).
    pub fn bind(config: Config, notifier: Notifier) -> Result<Server, ServerError> {
        std::fs::create_dir_all(&config.scans)
            .map_err(io_err(&config.scans, "creating the scans folder"))?;
        clean_scans(&config.scans)?;
        let listener = bind_socket(&config.socket, config.socket_group.as_deref())?;
        let shared = Arc::new(Shared::default());
        shared.lock().rig = config.rig.describe();
        tracing::info!(
            "listening on {}, scans in {}, rig: {}",
            config.socket.display(),
            config.scans.display(),
            config.rig.describe()
        );
        Ok(Server {
            config: Arc::new(config),
            shared,
            listener,
            notifier,
        })
    }

    pub fn socket(&self) -> &Path {
        &self.config.socket
    }

    /// Serves until `stop` is set (or SIGTERM/SIGINT arrive when
    /// [`install_signal_handlers`] was called), then stops gracefully: the
    /// running capture is cancelled (its temporary folder removed), queued
    /// ones are dropped, the worker finishes its scan, the socket file is
    /// removed.
    pub fn run(self, stop: &AtomicBool) -> Result<(), ServerError> {
        let Server {
            config,
            shared,
            listener,
            notifier,
        } = self;
        listener
            .set_nonblocking(true)
            .map_err(io_err(&config.socket, "setting the socket non-blocking"))?;
        let worker_shared = shared.clone();
        let worker = Worker::spawn(config.estimate.clone(), move |job, processed| {
            worker_shared.update(|s| {
                let Processed { check, estimate } = processed;
                s.event(
                    job.id,
                    json!({"event": "checked", "job": job.id, "check": check}),
                );
                if let Some(e) = &estimate {
                    s.event(
                        job.id,
                        json!({"event": "estimated", "job": job.id, "estimate": e}),
                    );
                    if let EstimateOutcome::Failed { error } = e {
                        s.last_error = Some(format!("job {}: estimate: {error}", job.id));
                    }
                }
                s.event(job.id, json!({"event": "finished", "job": job.id}));
                if let Some(j) = s.jobs.get_mut(&job.id) {
                    j.check = Some(check);
                    j.estimate = estimate;
                    j.processed = true;
                }
            });
        })
        .map_err(io_err(&config.socket, "starting the estimation worker"))?;
        if config.estimate.enabled {
            for (scan, info) in unestimated_tail(&config.scans) {
                let id = shared.update(|s| s.recovered(scan.clone(), &info.profile));
                tracing::warn!(
                    "job {id}: {} was published but never estimated (the daemon stopped); estimating it now",
                    scan.display()
                );
                worker.submit(Job {
                    id,
                    scan,
                    given: info.given,
                });
            }
        }
        let capture = {
            let (config, shared) = (config.clone(), shared.clone());
            let socket = config.socket.clone();
            std::thread::Builder::new()
                .name("matscan-capture".into())
                .spawn(move || capture_loop(&config, &shared, worker))
                .map_err(io_err(&socket, "starting the capture thread"))?
        };
        shared.beat();
        notifier.ready(&shared.lock().status_line());
        let mut last_ping = Instant::now();
        let mut last_status = String::new();
        while !stop.load(Ordering::SeqCst) && !SIGNALLED.load(Ordering::SeqCst) {
            match listener.accept() {
                Ok((stream, _)) => spawn_connection(stream, &shared, &config),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                Err(e) => {
                    tracing::warn!("accepting a control connection: {e}");
                    std::thread::sleep(Duration::from_millis(20))
                }
            }
            if let Some(every) = notifier.watchdog_interval() {
                // Only while the capture thread shows signs of life: a
                // driver call that hangs stops the pings, and systemd
                // restarts the daemon (whose start cleans the scans folder).
                if last_ping.elapsed() >= every && shared.since_beat() < 2 * every {
                    notifier.watchdog();
                    last_ping = Instant::now();
                }
            }
            let status = shared.lock().status_line();
            if status != last_status {
                notifier.status(&status);
                last_status = status;
            }
        }
        tracing::info!("stopping: cancelling the running capture, dropping the queue");
        notifier.stopping("stopping");
        shared.cancel.store(true, Ordering::SeqCst);
        shared.update(|s| s.stopping = true);
        if capture.join().is_err() {
            tracing::error!("the capture thread panicked");
        }
        if let Err(e) = std::fs::remove_file(&config.socket) {
            tracing::warn!("removing {}: {e}", config.socket.display());
        }
        tracing::info!("stopped");
        Ok(())
    }
}

fn spawn_connection(stream: UnixStream, shared: &Arc<Shared>, config: &Arc<Config>) {
    if let Err(e) = stream.set_nonblocking(false) {
        tracing::warn!("control connection: {e}");
        return;
    }
    let (shared, config) = (shared.clone(), config.clone());
    let spawned = std::thread::Builder::new()
        .name("matscan-conn".into())
        .spawn(move || super::socket::serve_connection(stream, &shared, &config));
    if let Err(e) = spawned {
        tracing::warn!("cannot start a thread for a control connection: {e}");
    }
}

/// How long the idle capture thread listens to the footswitch before it
/// looks at the queue again.
const IDLE_SLICE: Duration = Duration::from_millis(200);
/// How often an idle daemon retries opening a rig that would not open.
const REOPEN_EVERY: Duration = Duration::from_secs(10);
/// Presses closer than this to the last one that counted are the same
/// press (a bouncing contact, a double tap).
pub const DEBOUNCE: Duration = Duration::from_millis(300);

/// What the idle capture thread does next.
enum Next {
    Job(u64),
    Idle,
    Stop,
}

/// The rig as the capture thread holds it between jobs.
struct RigSlot {
    rig: Option<RigDevices>,
    /// When opening it last failed (retried after [`REOPEN_EVERY`]).
    failed_at: Option<Instant>,
    /// The timestamp of the last press that counted.
    last_press: Option<Duration>,
    /// The last footswitch error, reported once until it changes.
    trigger_error: Option<String>,
}

/// Whether `press` counts (is not a bounce of the one at `last`); if it
/// does, it becomes `last`.
fn debounced(last: &mut Option<Duration>, press: Press) -> bool {
    let counts = last.is_none_or(|l| press.timestamp.saturating_sub(l) >= DEBOUNCE);
    if counts {
        *last = Some(press.timestamp);
    }
    counts
}

/// Runs queued captures one at a time until the daemon stops, handing each
/// published scan to `worker`. While idle, a rig with a footswitch is kept
/// open and its presses queue captures of the default profile, by the same
/// busy policy as socket requests; presses made during a capture ask for
/// one more capture at most, which that policy queues or refuses.
fn capture_loop(config: &Config, shared: &Shared, worker: Worker) {
    let mut slot = RigSlot {
        rig: None,
        failed_at: None,
        last_press: None,
        trigger_error: None,
    };
    loop {
        let next = {
            let mut s = shared.lock();
            if s.stopping {
                Next::Stop
            } else if let Some(id) = s.queue.pop_front() {
                s.current = Some(id);
                Next::Job(id)
            } else {
                Next::Idle
            }
        };
        match next {
            Next::Stop => break,
            Next::Job(id) => {
                shared.changed.notify_all();
                let result = run_job(config, shared, &mut slot.rig, id);
                let mut during = match &result {
                    Ok((_, _, presses)) => *presses,
                    Err(_) => 0,
                };
                if let Some(t) = slot.rig.as_mut().and_then(|r| r.trigger.as_mut()) {
                    during += super::sequencer::drain_presses(t.as_mut());
                }
                finish_job(config, shared, &worker, id, result);
                if during > 0 {
                    tracing::info!("the footswitch was pressed {during} time(s) during job {id}");
                    request_capture(shared, config, None, Source::FootswitchDuringCapture);
                }
            }
            Next::Idle => idle(config, shared, &mut slot),
        }
    }
    // Dropped jobs fail visibly rather than vanish.
    shared.update(|s| {
        while let Some(id) = s.queue.pop_front() {
            let error = "the daemon stopped before the capture ran".to_string();
            s.event(id, json!({"event": "failed", "job": id, "error": error}));
            s.set_stage(id, JobStage::Failed { error });
        }
    });
    // Let the worker finish the scan it has: it is published already.
    worker.finish();
}

/// One idle slice: listens to the footswitch (opening the rig for it when
/// it has one), or waits for a request.
fn idle(config: &Config, shared: &Shared, slot: &mut RigSlot) {
    shared.beat();
    let reopen_due = slot.failed_at.is_none_or(|t| t.elapsed() >= REOPEN_EVERY);
    if slot.rig.is_none() && config.rig.has_footswitch() && reopen_due {
        match super::rig::open(&config.rig) {
            Ok(rig) => {
                tracing::info!("rig open; listening to the footswitch");
                slot.rig = Some(rig);
                slot.failed_at = None;
                shared.update(|s| s.footswitch = Some("listening".into()));
            }
            Err(e) => {
                let error = format!("opening the rig: {e}");
                if slot.failed_at.is_none() {
                    tracing::error!("{error}; retrying every {}s", REOPEN_EVERY.as_secs());
                }
                slot.failed_at = Some(Instant::now());
                shared.update(|s| {
                    s.footswitch = Some(format!("not listening: {error}"));
                    s.last_error = Some(error);
                });
            }
        }
    }
    let Some(trigger) = slot.rig.as_mut().and_then(|r| r.trigger.as_mut()) else {
        let s = shared.lock();
        if s.queue.is_empty() && !s.stopping {
            drop(shared.wait(s, Duration::from_millis(500)));
        }
        return;
    };
    match trigger.wait(IDLE_SLICE) {
        Ok(Some(press)) => {
            if debounced(&mut slot.last_press, press) {
                tracing::info!("{}: pressed", trigger.id());
                request_capture(shared, config, None, Source::Footswitch);
            }
        }
        Ok(None) => {
            if slot.trigger_error.take().is_some() {
                shared.update(|s| s.footswitch = Some("listening".into()));
            }
        }
        Err(e) => {
            let error = e.to_string();
            if slot.trigger_error.as_deref() != Some(error.as_str()) {
                tracing::warn!("footswitch: {error}");
                shared.update(|s| s.footswitch = Some(format!("not listening: {error}")));
                slot.trigger_error = Some(error);
            }
            // A trigger that fails at once must not spin.
            std::thread::sleep(IDLE_SLICE);
        }
    }
}

/// Records how job `id` ended and hands a published scan to `worker`.
fn finish_job(
    config: &Config,
    shared: &Shared,
    worker: &Worker,
    id: u64,
    result: Result<(PathBuf, serde_json::Value, usize), String>,
) {
    shared.update(|s| {
        s.current = None;
        let calibration = s.jobs.get(&id).is_some_and(|j| j.calibration.is_some());
        match result {
            Ok((bundle, summary, _)) if calibration => {
                tracing::info!(
                    "job {id}: calibration photos published at {}",
                    bundle.display()
                );
                s.event(
                    id,
                    json!({"event": "done", "job": id, "bundle": bundle, "summary": summary}),
                );
                s.event(id, json!({"event": "finished", "job": id}));
                s.set_stage(
                    id,
                    JobStage::Captured {
                        scan: bundle,
                        summary,
                    },
                );
                if let Some(j) = s.jobs.get_mut(&id) {
                    j.processed = true;
                }
            }
            Ok((scan, summary, _)) => {
                tracing::info!("job {id}: scan published at {}", scan.display());
                s.event(
                    id,
                    json!({"event": "done", "job": id, "scan": scan, "summary": summary}),
                );
                s.set_stage(
                    id,
                    JobStage::Captured {
                        scan: scan.clone(),
                        summary,
                    },
                );
                let given = s
                    .jobs
                    .get(&id)
                    .and_then(|j| config.profiles.get(&j.profile))
                    .map(|p| p.given.iter().copied().collect())
                    .unwrap_or_default();
                if !worker.submit(Job { id, scan, given }) {
                    tracing::error!("job {id}: the estimation worker is gone");
                }
            }
            Err(error) => {
                tracing::error!("job {id}: capture failed: {error}");
                s.event(id, json!({"event": "failed", "job": id, "error": error}));
                s.set_stage(
                    id,
                    JobStage::Failed {
                        error: error.clone(),
                    },
                );
                s.last_error = Some(format!("job {id}: {error}"));
            }
        }
    });
}

/// Opens the rig if needed and carries out job `id`; returns the scan, its
/// summary and the footswitch presses made during it, or the error as the
/// operator should read it.
fn run_job(
    config: &Config,
    shared: &Shared,
    rig: &mut Option<RigDevices>,
    id: u64,
) -> Result<(PathBuf, serde_json::Value, usize), String> {
    let (profile_name, calibration) = shared
        .lock()
        .jobs
        .get(&id)
        .map(|j| (j.profile.clone(), j.calibration))
        .unwrap_or_else(|| (config.default_profile.clone(), None));
    if let Some(plan) = calibration {
        return run_calibration(config, shared, rig, id, plan);
    }
    let profile = config
        .profiles
        .get(&profile_name)
        .cloned()
        .unwrap_or_default();
    let was_open = rig.is_some();
    if !was_open {
        tracing::info!("opening the rig: {}", config.rig.describe());
        *rig = Some(super::rig::open(&config.rig).map_err(|e| format!("opening the rig: {e}"))?);
    }
    let Some(r) = rig.as_mut() else {
        return Err("the rig is not open".into());
    };
    if was_open {
        // Opening just read it.
        r.reload_mesh()
            .map_err(|e| format!("reading the object's mesh: {e}"))?;
    }
    let plan = plan(&profile, r.geometry.checker_periods, r.capabilities());
    let target = next_scan_path(&config.scans).map_err(|e| e.to_string())?;
    let given: Vec<&str> = profile.given.iter().map(|p| p.name()).collect();
    let info = format!(
        "# How this scan was captured (matscan daemon).\nprofile = {}\ngiven = {}\nleft_out = {}\n",
        toml_string(&profile_name),
        toml_list(&given),
        toml_list(&plan.left_out.iter().map(String::as_str).collect::<Vec<_>>()),
    );
    shared.update(|s| s.event(id, json!({"event": "started", "job": id, "scan": target})));
    tracing::info!(
        "job {id}: capturing into {} (profile {profile_name})",
        target.display()
    );
    let settings = run_settings(config);
    let mut progress = progress_events(shared, id);
    match r.capture(
        &plan,
        &info,
        &target,
        &settings,
        &|| should_stop(shared),
        &mut progress,
    ) {
        Ok(o) => Ok((
            o.scan.clone(),
            json!({
                "profile": profile_name,
                "positions": o.positions,
                "photos": o.photos,
                "retries": o.retries,
                "left_out": o.left_out,
                "seconds": o.seconds,
            }),
            o.presses_during,
        )),
        Err(e) => {
            // A device that failed may be in any state: reopen it for the
            // next capture rather than trust it.
            if matches!(
                e,
                CaptureError::Driver(_) | CaptureError::LightDidNotFire { .. }
            ) {
                *rig = None;
            }
            Err(e.to_string())
        }
    }
}

/// Carries out calibration job `id` on a rig opened for it (a hardware rig
/// needs no calibration file yet), then closes the rig so that the next
/// scan reads the calibration this one leads to.
fn run_calibration(
    config: &Config,
    shared: &Shared,
    rig: &mut Option<RigDevices>,
    id: u64,
    plan: CalibrationPlan,
) -> Result<(PathBuf, serde_json::Value, usize), String> {
    *rig = None;
    tracing::info!(
        "opening the rig for a calibration: {}",
        config.rig.describe()
    );
    let mut r = super::rig::open_for_calibration(&config.rig, &config.calibration)
        .map_err(|e| format!("opening the rig: {e}"))?;
    if r.calibration_target.is_none() {
        r.calibration_target = config.calibration.target.clone();
    }
    if r.sphere_radius.is_none() {
        r.sphere_radius = config.calibration.sphere_radius;
    }
    let target = next_calibration_path(&config.scans).map_err(|e| e.to_string())?;
    shared.update(|s| s.event(id, json!({"event": "started", "job": id, "bundle": target})));
    tracing::info!(
        "job {id}: photographing the calibration board into {}",
        target.display()
    );
    let settings = run_settings(config);
    let mut prompt = |what: &str| {
        tracing::info!("job {id}: {what}");
        shared.update(|s| s.event(id, json!({"event": "prompt", "job": id, "what": what})))
    };
    let mut progress = progress_events(shared, id);
    let stop = || should_stop(shared);
    let outcome = r
        .capture_calibration(plan, &target, &settings, &stop, &mut prompt, &mut progress)
        .map_err(|e| e.to_string())?;
    Ok((
        outcome.bundle.clone(),
        json!({
            "target": plan.target(),
            "positions": outcome.positions,
            "shots": outcome.shots,
            "graycode_shots": outcome.graycode_shots,
            "photos": outcome.photos,
            "seconds": outcome.seconds,
        }),
        0,
    ))
}

/// The capture knobs of `config`.
fn run_settings(config: &Config) -> RunSettings {
    RunSettings {
        light_retries: config.capture.light_retries,
        min_light_difference: config.capture.min_light_difference,
        operator_timeout: config.capture.operator_timeout,
    }
}

/// Records each photo of job `id` as a `progress` event.
fn progress_events(shared: &Shared, id: u64) -> impl FnMut(Progress) + '_ {
    move |p: Progress| {
        shared.update(|s| {
            s.event(
                id,
                json!({"event": "progress", "job": id, "done": p.done, "total": p.total, "what": p.what}),
            )
        })
    }
}

/// Whether the running capture is to stop; beats the watchdog, since the
/// sequencer asks before every photo.
fn should_stop(shared: &Shared) -> bool {
    shared.beat();
    shared.cancel.load(Ordering::SeqCst)
}

fn toml_string(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

fn toml_list(items: &[&str]) -> String {
    let quoted: Vec<String> = items.iter().map(|s| toml_string(s)).collect();
    format!("[{}]", quoted.join(", "))
}

/// Whether `name` is a temporary folder an interrupted publication left
/// (`.<name>.tmp-<pid>-<n>`, see `matscan_scan::atomic`).
pub fn is_leftover_temp(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// Removes the hidden temporary folders and files that interrupted
/// captures left in `scans`; published scans are never touched.
pub fn clean_scans(scans: &Path) -> Result<Vec<PathBuf>, ServerError> {
    let mut removed = Vec::new();
    let entries = std::fs::read_dir(scans).map_err(io_err(scans, "listing the scans folder"))?;
    for entry in entries {
        let entry = entry.map_err(io_err(scans, "listing the scans folder"))?;
        let name = entry.file_name();
        if !is_leftover_temp(&name.to_string_lossy()) {
            continue;
        }
        let path = entry.path();
        let is_dir = entry.file_type().is_ok_and(|t| t.is_dir());
        let result = if is_dir {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
        result.map_err(io_err(
            &path,
            "removing an interrupted capture's temporary folder",
        ))?;
        tracing::warn!(
            "removed {} (left by an interrupted capture)",
            path.display()
        );
        removed.push(path);
    }
    Ok(removed)
}

/// What `capture.toml` says of a scan's profile.
pub struct CaptureInfo {
    pub profile: String,
    pub given: Vec<matscan_scan::Param>,
}

/// Reads `scan/capture.toml`; the full profile when it is missing or
/// unreadable (a scan from elsewhere).
pub fn capture_info(scan: &Path) -> CaptureInfo {
    #[derive(serde::Deserialize)]
    struct Raw {
        profile: Option<String>,
        #[serde(default)]
        given: Vec<String>,
    }
    let raw = std::fs::read_to_string(scan.join(super::sequencer::CAPTURE_INFO_FILE))
        .ok()
        .and_then(|t| toml::from_str::<Raw>(&t).ok());
    CaptureInfo {
        profile: raw
            .as_ref()
            .and_then(|r| r.profile.clone())
            .unwrap_or_else(|| super::config::FULL_PROFILE.to_string()),
        given: raw
            .map(|r| r.given.iter().filter_map(|g| g.parse().ok()).collect())
            .unwrap_or_default(),
    }
}

/// The newest published scans (`scan-NNNN`, by number) after the last one
/// with an estimate (`estimate/result.toml`), oldest first: what an
/// interrupted worker left unestimated. Older scans without one had their
/// estimate fail or refused, and stay as they are.
pub fn unestimated_tail(scans: &Path) -> Vec<(PathBuf, CaptureInfo)> {
    use matscan_estimate::pipeline::output::{ESTIMATE_DIR, RESULT_FILE};
    let mut numbered: Vec<(u64, PathBuf)> = std::fs::read_dir(scans)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| Some((scan_number(&e.file_name())?, e.path())))
        .filter(|(_, p)| p.join(matscan_scan::bundle::MANIFEST_FILE).is_file())
        .collect();
    numbered.sort();
    let start = numbered
        .iter()
        .rposition(|(_, p)| p.join(ESTIMATE_DIR).join(RESULT_FILE).is_file())
        .map_or(0, |i| i + 1);
    numbered
        .into_iter()
        .skip(start)
        .map(|(_, p)| {
            let info = capture_info(&p);
            (p, info)
        })
        .collect()
}

/// N of a published scan's folder name `scan-NNNN`.
fn scan_number(name: &std::ffi::OsStr) -> Option<u64> {
    numbered(name, SCAN_PREFIX)
}

/// N of a folder name `<prefix>NNNN`.
fn numbered(name: &std::ffi::OsStr, prefix: &str) -> Option<u64> {
    name.to_str()?.strip_prefix(prefix)?.parse().ok()
}

/// Scans are `scan-NNNN`, calibration bundles `calib-NNNN`.
const SCAN_PREFIX: &str = "scan-";
const CALIBRATION_PREFIX: &str = "calib-";

/// `scans/scan-NNNN`, one past the highest number there.
pub fn next_scan_path(scans: &Path) -> Result<PathBuf, ServerError> {
    next_numbered_path(scans, SCAN_PREFIX)
}

/// `scans/calib-NNNN`, one past the highest number there.
pub fn next_calibration_path(scans: &Path) -> Result<PathBuf, ServerError> {
    next_numbered_path(scans, CALIBRATION_PREFIX)
}

/// `scans/<prefix>NNNN`, one past the highest number there.
fn next_numbered_path(scans: &Path, prefix: &str) -> Result<PathBuf, ServerError> {
    let mut highest = 0u64;
    let entries = std::fs::read_dir(scans).map_err(io_err(scans, "listing the scans folder"))?;
    for entry in entries.flatten() {
        if let Some(n) = numbered(&entry.file_name(), prefix) {
            highest = highest.max(n);
        }
    }
    Ok(scans.join(format!("{prefix}{:04}", highest + 1)))
}

/// Binds `path` with mode 0660 (and group `group` when given), replacing a
/// stale socket file but never a live daemon's.
fn bind_socket(path: &Path, group: Option<&str>) -> Result<UnixListener, ServerError> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(io_err(parent, "creating the socket's folder"))?;
    }
    if std::fs::symlink_metadata(path).is_ok() {
        if UnixStream::connect(path).is_ok() {
            return Err(ServerError::SocketInUse {
                path: path.to_path_buf(),
            });
        }
        std::fs::remove_file(path).map_err(io_err(path, "removing a stale socket"))?;
    }
    let listener = UnixListener::bind(path).map_err(io_err(path, "binding the control socket"))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o660))
        .map_err(io_err(path, "setting the socket's mode to 0660"))?;
    if let Some(group) = group {
        let gid = group_id(group)?.ok_or_else(|| ServerError::NoSuchGroup {
            group: group.to_string(),
        })?;
        // The daemon may give its socket to any group it is a member of.
        std::os::unix::fs::chown(path, None, Some(gid))
            .map_err(io_err(path, "giving the socket to `socket_group`"))?;
    }
    Ok(listener)
}

/// The id of group `name`, `None` when there is no such group.
pub fn group_id(name: &str) -> Result<Option<u32>, ServerError> {
    let lookup = |source| ServerError::Io {
        path: PathBuf::from("/etc/group"),
        action: "looking up `socket_group`",
        source,
    };
    let c = std::ffi::CString::new(name).map_err(|_| ServerError::NoSuchGroup {
        group: name.to_string(),
    })?;
    let mut buf = vec![0u8; 4096];
    loop {
        // SAFETY: `group` and `result` are valid out-pointers, `buf` is
        // writable for its length, `c` is NUL-terminated.
        let mut group: libc::group = unsafe { std::mem::zeroed() };
        let mut result: *mut libc::group = std::ptr::null_mut();
        let rc = unsafe {
            libc::getgrnam_r(
                c.as_ptr(),
                &mut group,
                buf.as_mut_ptr().cast(),
                buf.len(),
                &mut result,
            )
        };
        match rc {
            0 if result.is_null() => return Ok(None),
            0 => return Ok(Some(group.gr_gid)),
            libc::ERANGE if buf.len() < 1 << 20 => buf.resize(buf.len() * 4, 0),
            e => return Err(lookup(std::io::Error::from_raw_os_error(e))),
        }
    }
}

/// Set by SIGTERM and SIGINT once [`install_signal_handlers`] ran.
static SIGNALLED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    // Only an atomic store: async-signal-safe.
    SIGNALLED.store(true, Ordering::SeqCst);
}

/// Makes SIGTERM (systemd's stop) and SIGINT stop [`Server::run`]
/// gracefully.
pub fn install_signal_handlers() -> Result<(), ServerError> {
    for signal in [libc::SIGTERM, libc::SIGINT] {
        // SAFETY: `on_signal` only stores to an atomic, which is
        // async-signal-safe; the handler is a valid `extern "C"` function
        // for the whole program's life.
        let previous =
            unsafe { libc::signal(signal, on_signal as *const () as libc::sighandler_t) };
        if previous == libc::SIG_ERR {
            return Err(ServerError::Io {
                path: PathBuf::from("/"),
                action: "installing the SIGTERM/SIGINT handler",
                source: std::io::Error::last_os_error(),
            });
        }
    }
    Ok(())
}
