//! The control socket's protocol (documented in `docs/daemon-protocol.md`):
//! one JSON object per line each way. Requests: `{"cmd":"capture",
//! "profile":P}` (profile optional), `{"cmd":"status"}`, `{"cmd":"watch",
//! "job":N}`; `watch` streams the job's events until it has failed or the
//! worker is done with its scan (`finished`). A connection may send several requests in turn.
//!
//! Boundaries: parses requests and answers them from the shared state;
//! captures happen on the capture thread (`super::server`).

use super::config::{BusyPolicy, Config};
use super::state::{JobStage, Shared};
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::time::Duration;

#[derive(Debug, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    Capture { profile: Option<String> },
    Status,
    Watch { job: u64 },
}

/// Error codes of refused requests.
pub mod code {
    pub const BAD_REQUEST: &str = "bad_request";
    pub const BUSY: &str = "busy";
    pub const UNKNOWN_PROFILE: &str = "unknown_profile";
    pub const UNKNOWN_JOB: &str = "unknown_job";
    pub const STOPPING: &str = "stopping";
}

fn refusal(code: &str, error: String) -> Value {
    json!({"ok": false, "code": code, "error": error})
}

/// Serves one connection until the peer closes it.
pub fn serve_connection(stream: UnixStream, shared: &Shared, config: &Config) {
    let reader = match stream.try_clone() {
        Ok(s) => BufReader::new(s),
        Err(e) => {
            tracing::warn!("control connection: {e}");
            return;
        }
    };
    let mut writer = stream;
    for line in reader.lines() {
        let Ok(line) = line else { return };
        if line.trim().is_empty() {
            continue;
        }
        let sent = match serde_json::from_str::<Request>(&line) {
            Err(e) => send(
                &mut writer,
                &refusal(code::BAD_REQUEST, format!("cannot parse `{line}`: {e}")),
            ),
            Ok(Request::Status) => send(&mut writer, &shared.lock().status_json()),
            Ok(Request::Capture { profile }) => {
                send(&mut writer, &capture(shared, config, profile))
            }
            Ok(Request::Watch { job }) => watch(&mut writer, shared, job),
        };
        if sent.is_err() {
            return;
        }
    }
}

fn send(w: &mut UnixStream, value: &Value) -> std::io::Result<()> {
    let mut line = value.to_string();
    line.push('\n');
    w.write_all(line.as_bytes())
}

/// Queues a capture, or refuses it as the configuration says.
fn capture(shared: &Shared, config: &Config, profile: Option<String>) -> Value {
    let profile = profile.unwrap_or_else(|| config.default_profile.clone());
    if !config.profiles.contains_key(&profile) {
        let known: Vec<&str> = config.profiles.keys().map(String::as_str).collect();
        return refusal(
            code::UNKNOWN_PROFILE,
            format!("no profile `{profile}` (defined: {})", known.join(", ")),
        );
    }
    shared.update(|s| {
        if s.stopping {
            return refusal(code::STOPPING, "the daemon is stopping".into());
        }
        let busy = s.current.is_some() || !s.queue.is_empty();
        match config.busy {
            BusyPolicy::Refuse if busy => {
                let id = s.current.or(s.queue.front().copied()).unwrap_or_default();
                tracing::info!("capture request refused: job {id} is capturing");
                return refusal(
                    code::BUSY,
                    format!("a capture is running (job {id}) and busy = \"refuse\""),
                );
            }
            BusyPolicy::Queue { limit } if s.queue.len() >= limit => {
                tracing::info!("capture request refused: the queue is full");
                return refusal(
                    code::BUSY,
                    format!("the queue is full ({limit} captures waiting)"),
                );
            }
            _ => {}
        }
        let ahead = s.queue.len() + usize::from(s.current.is_some());
        let id = s.enqueue(&profile);
        tracing::info!("job {id}: capture queued (profile {profile}, {ahead} ahead)");
        json!({"ok": true, "job": id, "profile": profile, "ahead": ahead})
    })
}

/// Streams job `id`'s events until it is finished.
fn watch(w: &mut UnixStream, shared: &Shared, id: u64) -> std::io::Result<()> {
    let mut sent = 0;
    let mut guard = shared.lock();
    loop {
        let Some(job) = guard.jobs.get(&id) else {
            let reply = refusal(code::UNKNOWN_JOB, format!("no job {id}"));
            drop(guard);
            return send(w, &reply);
        };
        let new: Vec<Value> = job.events[sent..].to_vec();
        let finished = job.finished();
        let stopping = guard.stopping;
        sent = job.events.len();
        drop(guard);
        for e in &new {
            send(w, e)?;
        }
        if finished {
            return Ok(());
        }
        guard = shared.lock();
        let queued = guard
            .jobs
            .get(&id)
            .is_some_and(|j| matches!(j.stage, JobStage::Queued));
        if stopping && queued {
            // A queued job never runs once the daemon stops.
            drop(guard);
            return send(
                w,
                &json!({"event": "failed", "job": id, "error": "the daemon stopped before the capture ran"}),
            );
        }
        if guard.jobs.get(&id).is_some_and(|j| j.events.len() == sent) {
            guard = shared.wait(guard, Duration::from_millis(500));
        }
    }
}
