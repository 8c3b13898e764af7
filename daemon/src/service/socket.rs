//! The control socket's protocol (documented in `docs/daemon-protocol.md`):
//! one JSON object per line each way. Requests: `{"cmd":"capture",
//! "profile":P}` (profile optional), `{"cmd":"calib_capture",
//! "target":"board","shots":N,"projector_shots":M}` or `{"cmd":
//! "calib_capture","target":"sphere","placements":N}`, `{"cmd":
//! "calib_capture","target":"white","exposures":N}` (counts optional),
//! `{"cmd":"status"}`, `{"cmd":"watch","job":N}`; `watch` streams the job's
//! events until it has failed or is done (a scan: the worker is done with
//! it, `finished`). A connection may send several requests in turn.
//!
//! Boundaries: parses requests and answers them from the shared state;
//! captures happen on the capture thread (`super::server`).

use super::config::Config;
use super::state::{JobStage, Shared};
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::time::Duration;

#[derive(Debug, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    Capture {
        profile: Option<String>,
    },
    CalibCapture {
        target: String,
        shots: Option<usize>,
        projector_shots: Option<usize>,
        placements: Option<usize>,
        exposures: Option<usize>,
    },
    Status,
    Watch {
        job: u64,
    },
}

pub use super::request::code;
use super::request::{refusal, request_calibration, request_capture, CalibrationCounts, Source};

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
            Ok(Request::Capture { profile }) => send(
                &mut writer,
                &request_capture(shared, config, profile, Source::Socket),
            ),
            Ok(Request::CalibCapture {
                target,
                shots,
                projector_shots,
                placements,
                exposures,
            }) => send(
                &mut writer,
                &request_calibration(
                    shared,
                    config,
                    &target,
                    CalibrationCounts {
                        shots,
                        projector_shots,
                        placements,
                        exposures,
                    },
                ),
            ),
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
