//! `matscan capture-now` and `matscan status`: clients of the daemon's
//! control socket (protocol in `docs/daemon-protocol.md`).
//!
//! Exit codes (also documented there): 0 success; 1 a usage or protocol
//! error; 3 the daemon is unreachable; 4 the daemon refused the request
//! (busy, unknown profile, stopping); 5 the capture failed; 6 the scan was
//! captured but its estimate failed (`--wait` only).
//!
//! Boundaries: talks to the socket and prints; no capture logic.

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct CaptureNowOptions {
    /// The daemon's control socket.
    pub socket: PathBuf,
    /// Follow the capture and print the scan's folder and summary.
    pub wait: bool,
    /// Print one JSON object (with `--wait`: `scan` and `summary`).
    pub json: bool,
    /// Capture profile (default: the daemon's `default_profile`).
    pub profile: Option<String>,
}

#[derive(Clone, Debug)]
pub struct StatusOptions {
    /// The daemon's control socket.
    pub socket: PathBuf,
    /// Print the daemon's reply as JSON.
    pub json: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error("{socket}: cannot reach the matscan daemon ({source}); is `matscan daemon` running?")]
    Unreachable {
        socket: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{socket}: {message}")]
    Protocol { socket: PathBuf, message: String },
    #[error("the daemon refused: {0}")]
    Refused(String),
    #[error("capture failed: {0}")]
    CaptureFailed(String),
}

impl ClientError {
    /// The process exit code for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            ClientError::Protocol { .. } => 1,
            ClientError::Unreachable { .. } => 3,
            ClientError::Refused(_) => 4,
            ClientError::CaptureFailed(_) => 5,
        }
    }
}

/// A line-oriented JSON connection to the daemon.
pub struct Connection {
    socket: PathBuf,
    writer: UnixStream,
    reader: BufReader<UnixStream>,
}

impl Connection {
    pub fn open(socket: &Path) -> Result<Connection, ClientError> {
        let unreachable = |source| ClientError::Unreachable {
            socket: socket.to_path_buf(),
            source,
        };
        let writer = UnixStream::connect(socket).map_err(unreachable)?;
        let reader = BufReader::new(writer.try_clone().map_err(unreachable)?);
        Ok(Connection {
            socket: socket.to_path_buf(),
            writer,
            reader,
        })
    }

    fn protocol(&self, message: String) -> ClientError {
        ClientError::Protocol {
            socket: self.socket.clone(),
            message,
        }
    }

    pub fn send(&mut self, request: &Value) -> Result<(), ClientError> {
        let mut line = request.to_string();
        line.push('\n');
        self.writer
            .write_all(line.as_bytes())
            .map_err(|e| self.protocol(format!("sending a request: {e}")))
    }

    /// The next reply line; an error if the daemon hung up.
    pub fn receive(&mut self) -> Result<Value, ClientError> {
        let mut line = String::new();
        let n = self
            .reader
            .read_line(&mut line)
            .map_err(|e| self.protocol(format!("reading a reply: {e}")))?;
        if n == 0 {
            return Err(self.protocol("the daemon closed the connection".into()));
        }
        serde_json::from_str(&line).map_err(|e| self.protocol(format!("bad reply `{line}`: {e}")))
    }

    /// Sends `request` and returns its reply, or `Refused` for `ok: false`.
    pub fn request(&mut self, request: &Value) -> Result<Value, ClientError> {
        self.send(request)?;
        let reply = self.receive()?;
        if reply["ok"] == false {
            return Err(ClientError::Refused(
                reply["error"]
                    .as_str()
                    .unwrap_or("no reason given")
                    .to_string(),
            ));
        }
        Ok(reply)
    }
}

/// What `capture-now` produced.
#[derive(Debug, Clone, PartialEq)]
pub enum CaptureNow {
    /// Queued (without `--wait`).
    Queued { job: u64 },
    /// Captured, published and processed by the worker (with `--wait`).
    Captured {
        job: u64,
        scan: PathBuf,
        /// The capture's summary (positions, photos, retries, seconds).
        summary: Value,
        /// The calibration verdict.
        check: Value,
        /// The estimate's outcome (`null` when the daemon does not
        /// estimate).
        estimate: Value,
    },
}

/// Asks for a capture and, with `wait`, follows it to the end; `progress`
/// hears each progress event.
pub fn request_capture(
    socket: &Path,
    profile: Option<&str>,
    wait: bool,
    progress: &mut dyn FnMut(&Value),
) -> Result<CaptureNow, ClientError> {
    let mut conn = Connection::open(socket)?;
    let mut request = json!({"cmd": "capture"});
    if let Some(p) = profile {
        request["profile"] = json!(p);
    }
    let reply = conn.request(&request)?;
    let job = reply["job"]
        .as_u64()
        .ok_or_else(|| conn.protocol(format!("a capture reply without a job: {reply}")))?;
    if !wait {
        return Ok(CaptureNow::Queued { job });
    }
    conn.send(&json!({"cmd": "watch", "job": job}))?;
    let mut captured: Option<(PathBuf, Value)> = None;
    let (mut check, mut estimate) = (Value::Null, Value::Null);
    loop {
        let event = conn.receive()?;
        match event["event"].as_str() {
            Some("done") => {
                let scan = event["scan"].as_str().map(PathBuf::from).ok_or_else(|| {
                    conn.protocol(format!("a done event without a scan: {event}"))
                })?;
                progress(&event);
                captured = Some((scan, event["summary"].clone()));
            }
            Some("checked") => {
                progress(&event);
                check = event["check"].clone();
            }
            Some("estimated") => {
                progress(&event);
                estimate = event["estimate"].clone();
            }
            Some("finished") => {
                let (scan, summary) = captured
                    .ok_or_else(|| conn.protocol(format!("job {job} finished without a scan")))?;
                return Ok(CaptureNow::Captured {
                    job,
                    scan,
                    summary,
                    check,
                    estimate,
                });
            }
            Some("failed") => {
                return Err(ClientError::CaptureFailed(
                    event["error"]
                        .as_str()
                        .unwrap_or("no reason given")
                        .to_string(),
                ))
            }
            Some(_) => progress(&event),
            None if event["ok"] == false => {
                return Err(ClientError::Refused(
                    event["error"]
                        .as_str()
                        .unwrap_or("no reason given")
                        .to_string(),
                ))
            }
            None => return Err(conn.protocol(format!("unexpected reply {event}"))),
        }
    }
}

/// `matscan capture-now`: prints what happened; returns the exit code.
pub fn capture_now(args: &CaptureNowOptions) -> u8 {
    let show_progress = args.wait && !args.json;
    let mut progress = |e: &Value| {
        if show_progress && e["event"] == "progress" {
            eprintln!(
                "{}/{} {}",
                e["done"],
                e["total"],
                e["what"].as_str().unwrap_or("")
            );
        }
    };
    match request_capture(
        &args.socket,
        args.profile.as_deref(),
        args.wait,
        &mut progress,
    ) {
        Ok(CaptureNow::Queued { job }) => {
            if args.json {
                println!("{}", json!({"job": job}));
            } else {
                println!("capture queued as job {job}");
            }
            0
        }
        Ok(CaptureNow::Captured {
            job,
            scan,
            summary,
            check,
            estimate,
        }) => {
            if args.json {
                println!(
                    "{}",
                    json!({"job": job, "scan": scan, "summary": summary,
                           "check": check, "estimate": estimate})
                );
            } else {
                println!("{}", scan.display());
                println!(
                    "job {job}: {} positions, {} photos, {} retries, {:.1} s (profile {})",
                    summary["positions"],
                    summary["photos"],
                    summary["retries"],
                    summary["seconds"].as_f64().unwrap_or(0.0),
                    summary["profile"].as_str().unwrap_or("?"),
                );
                if let Some(left) = summary["left_out"].as_array().filter(|l| !l.is_empty()) {
                    for l in left {
                        println!("  left out {}", l.as_str().unwrap_or(""));
                    }
                }
                println!("calibration check: {}", format_check(&check));
                print!("{}", format_estimate(&estimate));
            }
            match estimate["outcome"].as_str() {
                Some("failed") => 6,
                _ => 0,
            }
        }
        Err(e) => report(&e, args.json),
    }
}

#[derive(Clone, Debug)]
pub struct CalibCaptureOptions {
    /// The daemon's control socket.
    pub socket: PathBuf,
    /// What to photograph (`board`).
    pub target: String,
    /// Board poses per position (default: the daemon's `[calibration]`).
    pub shots: Option<usize>,
    /// Gray-code poses for the projector (default: the daemon's).
    pub projector_shots: Option<usize>,
    /// Places of the sphere (default: the daemon's).
    pub placements: Option<usize>,
    /// Exposures of the white card (default: the daemon's).
    pub exposures: Option<usize>,
    /// Print one JSON object (`bundle` and `summary`).
    pub json: bool,
}

/// Asks for a calibration capture and follows it to the end; `event` hears
/// each prompt and progress event. Returns the published bundle and its
/// summary.
pub fn request_calibration(
    socket: &Path,
    target: &str,
    counts: [(&str, Option<usize>); 4],
    event: &mut dyn FnMut(&Value),
) -> Result<(PathBuf, Value), ClientError> {
    let mut conn = Connection::open(socket)?;
    let mut request = json!({"cmd": "calib_capture", "target": target});
    for (key, n) in counts {
        if let Some(n) = n {
            request[key] = json!(n);
        }
    }
    let reply = conn.request(&request)?;
    let job = reply["job"]
        .as_u64()
        .ok_or_else(|| conn.protocol(format!("a calibration reply without a job: {reply}")))?;
    conn.send(&json!({"cmd": "watch", "job": job}))?;
    let mut published: Option<(PathBuf, Value)> = None;
    loop {
        let e = conn.receive()?;
        match e["event"].as_str() {
            Some("done") => {
                let bundle = e["bundle"]
                    .as_str()
                    .map(PathBuf::from)
                    .ok_or_else(|| conn.protocol(format!("a done event without a bundle: {e}")))?;
                published = Some((bundle, e["summary"].clone()));
            }
            Some("finished") => {
                return published
                    .ok_or_else(|| conn.protocol(format!("job {job} finished without a bundle")))
            }
            Some("failed") => {
                return Err(ClientError::CaptureFailed(
                    e["error"].as_str().unwrap_or("no reason given").to_string(),
                ))
            }
            Some(_) => event(&e),
            None if e["ok"] == false => {
                return Err(ClientError::Refused(
                    e["error"].as_str().unwrap_or("no reason given").to_string(),
                ))
            }
            None => return Err(conn.protocol(format!("unexpected reply {e}"))),
        }
    }
}

/// `matscan calib capture`: prompts the operator, follows the photos and
/// prints the bundle; returns the exit code.
pub fn calib_capture(args: &CalibCaptureOptions) -> u8 {
    let json = args.json;
    let mut event = |e: &Value| match e["event"].as_str() {
        Some("prompt") if !json => eprintln!(
            "> {}, then press the footswitch",
            e["what"].as_str().unwrap_or("")
        ),
        Some("progress") if !json => eprintln!(
            "{}/{} {}",
            e["done"],
            e["total"],
            e["what"].as_str().unwrap_or("")
        ),
        _ => {}
    };
    let counts = [
        ("shots", args.shots),
        ("projector_shots", args.projector_shots),
        ("placements", args.placements),
        ("exposures", args.exposures),
    ];
    match request_calibration(&args.socket, &args.target, counts, &mut event) {
        Ok((bundle, summary)) => {
            if json {
                println!("{}", json!({"bundle": bundle, "summary": summary}));
            } else {
                println!("{}", bundle.display());
                let seconds = summary["seconds"].as_f64().unwrap_or(0.0);
                if summary["target"] == "white" {
                    println!(
                        "the white card under every light, {} photos, {seconds:.1} s",
                        summary["photos"]
                    );
                    println!(
                        "next: matscan calib radiometry {} --rig <the rig file with the flashes located>",
                        bundle.display()
                    );
                } else if summary["target"] == "sphere" {
                    println!(
                        "the sphere at {} places, {} photos, {seconds:.1} s",
                        summary["shots"], summary["photos"]
                    );
                    println!(
                        "next: matscan calib lights {} --rig <the rig file from calib rig>",
                        bundle.display()
                    );
                } else {
                    println!(
                        "{} positions, {} board shots ({} with Gray codes), {} photos, {seconds:.1} s",
                        summary["positions"],
                        summary["shots"],
                        summary["graycode_shots"],
                        summary["photos"],
                    );
                    println!(
                        "next: matscan calib rig {} --lights-from <the current rig file>",
                        bundle.display()
                    );
                }
            }
            0
        }
        Err(e) => report(&e, json),
    }
}

/// The daemon's `status` reply.
pub fn fetch_status(socket: &Path) -> Result<Value, ClientError> {
    Connection::open(socket)?.request(&json!({"cmd": "status"}))
}

/// `matscan status`: prints the rig, the queue and the last scans; returns
/// the exit code.
pub fn status(args: &StatusOptions) -> u8 {
    match fetch_status(&args.socket) {
        Ok(s) if args.json => {
            println!("{s}");
            0
        }
        Ok(s) => {
            print!("{}", format_status(&s));
            0
        }
        Err(e) => report(&e, args.json),
    }
}

/// The human-readable form of a `status` reply.
pub fn format_status(s: &Value) -> String {
    let text = |v: &Value| v.as_str().unwrap_or("?").to_string();
    let mut out = format!(
        "rig:    {}\nstate:  {}\n",
        text(&s["rig"]),
        text(&s["state"])
    );
    if let Some(f) = s["footswitch"].as_str() {
        out += &format!("pedal:  {f}\n");
    }
    if let Some(c) = s["current"].as_object() {
        let p = &c["progress"];
        out += &format!(
            "now:    job {} (profile {}, from the {}) {}\n",
            c["job"],
            text(&c["profile"]),
            text(&c["source"]),
            if p.is_null() {
                "starting".to_string()
            } else {
                format!("{}/{} {}", p["done"], p["total"], text(&p["what"]))
            }
        );
    }
    let queue = s["queue"].as_array().map_or(0, Vec::len);
    out += &format!("queue:  {queue} waiting\n");
    if let Some(e) = s["last_error"].as_str() {
        out += &format!("error:  {e}\n");
    }
    let scans = s["last_scans"].as_array().cloned().unwrap_or_default();
    if scans.is_empty() {
        out += "scans:  none yet\n";
    } else {
        out += "scans:\n";
        for scan in scans {
            let check = match scan["check"]["verdict"].as_str() {
                Some(_) => format!("check {}", format_check(&scan["check"])),
                None => "checking".to_string(),
            };
            let estimate = match scan["estimate"]["outcome"].as_str() {
                Some("estimated") => format!(
                    "; estimated in {:.1} s",
                    scan["estimate"]["summary"]["seconds"]
                        .as_f64()
                        .unwrap_or(0.0)
                ),
                Some("failed") => {
                    format!("; estimate failed: {}", text(&scan["estimate"]["error"]))
                }
                _ => String::new(),
            };
            out += &format!(
                "  job {} {} (from the {}; {check}{estimate})\n",
                scan["job"],
                text(&scan["scan"]),
                text(&scan["source"])
            );
        }
    }
    out
}

/// The calibration verdict in words.
pub fn format_check(check: &Value) -> String {
    match check["verdict"].as_str() {
        Some("passed") => "passed".to_string(),
        Some("problems") => format!("problems: {}", check["problems"]),
        Some("failed") => format!("failed: {}", check["error"].as_str().unwrap_or("?")),
        _ => "not done".to_string(),
    }
}

/// The estimate outcome (the worker's `estimated` event) as a table: each
/// parameter's status, its error against the truth where the scan has one,
/// and the network run times.
pub fn format_estimate(estimate: &Value) -> String {
    match estimate["outcome"].as_str() {
        Some("estimated") => {}
        Some("failed") => {
            return format!(
                "estimate failed: {}\n",
                estimate["error"].as_str().unwrap_or("no reason given")
            )
        }
        _ => return "no estimate (estimation is off in the daemon's config)\n".to_string(),
    }
    let s = &estimate["summary"];
    let mut out = format!(
        "estimate: {} views -> {}\n{:<13} {:<10} {:<9} {:>8} {:>8} {:>8}\n",
        s["views"],
        s["out"].as_str().unwrap_or("?"),
        "parameter",
        "status",
        "method",
        "MAD",
        "PSNR dB",
        "seconds"
    );
    if let Some(params) = s["params"].as_object() {
        for (name, p) in params {
            let num = |key: &str, digits: usize| {
                p[key]
                    .as_f64()
                    .map_or("-".to_string(), |v| format!("{v:.digits$}"))
            };
            out += &format!(
                "{:<13} {:<10} {:<9} {:>8} {:>8} {:>8}",
                name,
                p["status"].as_str().unwrap_or("?"),
                p["method"].as_str().unwrap_or("?"),
                num("mad", 4),
                num("psnr", 2),
                num("seconds", 2)
            );
            let mut notes = Vec::new();
            if let Some(share) = p["constrained"].as_f64() {
                notes.push(format!(
                    "the photos pinned {:.0}% of the object",
                    100.0 * share
                ));
            }
            if let Some(r) = p["reason"].as_str() {
                notes.push(r.to_string());
            }
            if !notes.is_empty() {
                out += &format!("  ({})", notes.join("; "));
            }
            out += "\n";
        }
    }
    if let Some(stages) = s["stages"].as_object() {
        let spent: Vec<String> = stages
            .iter()
            .filter_map(|(k, v)| v.as_f64().map(|v| (k, v)))
            // Stages that took no measurable time say nothing.
            .filter(|(_, v)| *v >= 0.005)
            .map(|(k, v)| format!("{k} {v:.2}"))
            .collect();
        out += &format!("stages, s: {}\n", spent.join(", "));
    }
    out += &format!(
        "estimate total {:.2} s\n",
        s["seconds"].as_f64().unwrap_or(0.0)
    );
    out
}

fn report(e: &ClientError, json: bool) -> u8 {
    if json {
        println!(
            "{}",
            json!({"error": e.to_string(), "exit_code": e.exit_code()})
        );
    } else {
        eprintln!("error: {e}");
    }
    e.exit_code()
}
