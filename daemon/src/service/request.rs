//! A capture request, from the control socket or the footswitch: checked
//! against the profiles, then queued or refused by the busy policy. One
//! function for both sources, so a press and a `capture-now` obey the same
//! rules.
//!
//! Boundaries: bookkeeping on [`Shared`]; no I/O.

use super::config::{BusyPolicy, Config};
use super::sequencer::{BoardPlan, CalibrationPlan, SpherePlan, WhitePlan};
use super::state::{Shared, State};
use serde_json::{json, Value};

/// Error codes of refused requests.
pub mod code {
    pub const BAD_REQUEST: &str = "bad_request";
    pub const BUSY: &str = "busy";
    pub const UNKNOWN_PROFILE: &str = "unknown_profile";
    pub const UNKNOWN_JOB: &str = "unknown_job";
    pub const UNKNOWN_TARGET: &str = "unknown_target";
    pub const STOPPING: &str = "stopping";
}

/// Who asked for a capture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// A `capture` request on the control socket (`matscan capture-now`).
    Socket,
    /// The operator's footswitch, pressed while the daemon was idle.
    Footswitch,
    /// The footswitch, pressed while a capture was running: the busy
    /// policy applies even if that capture has ended by now.
    FootswitchDuringCapture,
}

impl Source {
    /// The name in events and `status`.
    pub fn name(self) -> &'static str {
        match self {
            Source::Socket => "socket",
            Source::Footswitch | Source::FootswitchDuringCapture => "footswitch",
        }
    }
}

/// A refusal reply.
pub fn refusal(code: &str, error: String) -> Value {
    json!({"ok": false, "code": code, "error": error})
}

/// Queues a capture with `profile` (the default one when `None`), or
/// refuses it as the configuration says; the reply as the socket sends it.
pub fn request_capture(
    shared: &Shared,
    config: &Config,
    profile: Option<String>,
    source: Source,
) -> Value {
    let profile = profile.unwrap_or_else(|| config.default_profile.clone());
    if !config.profiles.contains_key(&profile) {
        let known: Vec<&str> = config.profiles.keys().map(String::as_str).collect();
        return refusal(
            code::UNKNOWN_PROFILE,
            format!("no profile `{profile}` (defined: {})", known.join(", ")),
        );
    }
    admit(shared, config, source, |s| {
        s.enqueue(&profile, source.name())
    })
    .unwrap_or_else(|refused| refused)
}

/// Queues a calibration capture of `target`: `board` (a printed
/// chessboard) with `shots` poses per position and `projector_shots`
/// Gray-code poses, `sphere` (the glossy sphere that locates the
/// flashes) at `placements` places, or `white` (the white card that
/// measures the lights' intensities) at `exposures` exposures; the
/// configuration's counts where `None`. Refused like any capture.
pub fn request_calibration(
    shared: &Shared,
    config: &Config,
    target: &str,
    counts: CalibrationCounts,
) -> Value {
    let c = &config.calibration;
    let plan = match target {
        "board" => {
            let shots = counts.shots.unwrap_or(c.shots);
            let projector_shots = counts.projector_shots.unwrap_or(c.projector_shots);
            BoardPlan::new(shots, projector_shots, c.seat, c.frames).map(CalibrationPlan::Board)
        }
        "sphere" => {
            let placements = counts.placements.unwrap_or(c.sphere_placements);
            SpherePlan::new(placements)
                .map(CalibrationPlan::Sphere)
                .map_err(|e| format!("placements = {e}"))
        }
        "white" => {
            let exposures = counts.exposures.unwrap_or(c.white_exposures);
            WhitePlan::new(exposures, c.white_albedo, c.white_roughness)
                .map(CalibrationPlan::White)
                .map_err(|e| format!("exposures = {e}"))
        }
        other => {
            return refusal(
                code::UNKNOWN_TARGET,
                format!(
                    "no calibration target `{other}`: expected \"board\" (a printed \
                     chessboard), \"sphere\" (a glossy sphere) or \"white\" (a white card)"
                ),
            )
        }
    };
    let plan = match plan {
        Ok(p) => p,
        Err(e) => return refusal(code::BAD_REQUEST, e),
    };
    admit(shared, config, Source::Socket, |s| {
        s.enqueue_calibration(plan, Source::Socket.name())
    })
    .unwrap_or_else(|refused| refused)
}

/// The counts a calibration request may give.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CalibrationCounts {
    pub shots: Option<usize>,
    pub projector_shots: Option<usize>,
    pub placements: Option<usize>,
    pub exposures: Option<usize>,
}

/// Queues a job with `enqueue` unless the daemon is stopping or the busy
/// policy refuses it; the reply either way.
fn admit(
    shared: &Shared,
    config: &Config,
    source: Source,
    enqueue: impl FnOnce(&mut State) -> u64,
) -> Result<Value, Value> {
    let from = source.name();
    shared.update(|s| {
        if s.stopping {
            return Err(refusal(code::STOPPING, "the daemon is stopping".into()));
        }
        let busy =
            s.current.is_some() || !s.queue.is_empty() || source == Source::FootswitchDuringCapture;
        match config.busy {
            BusyPolicy::Refuse if busy => {
                let running = s.current.or(s.queue.front().copied());
                let what = running.map_or_else(
                    || "a capture was running".to_string(),
                    |id| format!("a capture is running (job {id})"),
                );
                tracing::info!("capture request ({from}) refused: {what}");
                return Err(refusal(code::BUSY, format!("{what} and busy = \"refuse\"")));
            }
            BusyPolicy::Queue { limit } if s.queue.len() >= limit => {
                tracing::info!("capture request ({from}) refused: the queue is full");
                return Err(refusal(
                    code::BUSY,
                    format!("the queue is full ({limit} captures waiting)"),
                ));
            }
            _ => {}
        }
        let ahead = s.queue.len() + usize::from(s.current.is_some());
        let id = enqueue(s);
        let profile = s
            .jobs
            .get(&id)
            .map(|j| j.profile.clone())
            .unwrap_or_default();
        tracing::info!("job {id}: {profile} capture queued by the {from} ({ahead} ahead)");
        Ok(json!({"ok": true, "job": id, "profile": profile, "ahead": ahead}))
    })
}
