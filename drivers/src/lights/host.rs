//! The host side of the light-controller protocol: [`SerialLights`], a
//! [`LightController`] over any [`Port`].
//!
//! Every request gets a fresh sequence number and is retried with the same
//! number on timeout or a corrupt reply (the board answers a repeated number
//! from memory, so retries never execute twice). A READY banner in the middle
//! of a session means the board reset and lost its state: the host says
//! HELLO again, re-applies every light it had switched on, then carries on
//! with the request. A background thread sends PING so the board's heartbeat
//! never expires while the host is alive; if the host dies, the board
//! switches every light off by itself.
//!
//! Boundaries: protocol logic only; bytes come from `super::port`.

use super::port::Port;
use super::wire::{request_line, unframe, BoardLine, Command, LineBuffer, PROTOCOL_VERSION};
use crate::error::DriverError;
use crate::traits::{LightController, LightId, LightState};
use std::io::ErrorKind;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Timing and retry policy.
#[derive(Debug, Clone, PartialEq)]
pub struct HostConfig {
    /// How long one attempt waits for its reply.
    pub reply_timeout: Duration,
    /// Attempts per request (the first one included), at least 1.
    pub attempts: u32,
    /// How long to wait for READY after opening (boards with an auto-reset
    /// circuit take 1-2 s to boot).
    pub ready_timeout: Duration,
    /// Board resets tolerated during one request before giving up.
    pub max_resets: u32,
    /// PING period; `None` to ping from [`SerialLights::ping`] only. Capped
    /// at a third of the board's heartbeat.
    pub keepalive: Option<Duration>,
}

impl Default for HostConfig {
    fn default() -> Self {
        HostConfig {
            reply_timeout: Duration::from_millis(250),
            attempts: 3,
            ready_timeout: Duration::from_secs(3),
            max_resets: 2,
            keepalive: Some(Duration::from_millis(500)),
        }
    }
}

/// What the board said in its HELLO reply.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoardInfo {
    pub protocol: u32,
    pub firmware: String,
    pub heartbeat: Duration,
}

enum Failure {
    /// The board printed READY: it reset and lost its state.
    Reset,
    Fatal(DriverError),
}

struct Link {
    port: Box<dyn Port>,
    name: String,
    lines: LineBuffer,
    seq: u16,
    lights: [LightState; 3],
    info: Option<BoardInfo>,
    last_sent: Instant,
    config: HostConfig,
    resyncs: u64,
}

/// A light controller on a serial line.
pub struct SerialLights {
    link: Arc<Mutex<Link>>,
    name: String,
    info: BoardInfo,
    stop: Arc<AtomicBool>,
    keepalive: Option<JoinHandle<()>>,
}

impl SerialLights {
    /// Waits for the board's READY banner, checks its protocol with HELLO,
    /// switches every light off and starts the keepalive. A board that does
    /// not reset on open (no banner) is accepted if it answers HELLO.
    pub fn connect(port: Box<dyn Port>, config: HostConfig) -> Result<SerialLights, DriverError> {
        let name = port.name().to_string();
        let mut link = Link {
            port,
            name: name.clone(),
            lines: LineBuffer::default(),
            seq: 0,
            lights: [LightState::Off; 3],
            info: None,
            last_sent: Instant::now(),
            config: HostConfig {
                attempts: config.attempts.max(1),
                ..config.clone()
            },
            resyncs: 0,
        };
        let banner = link.wait_ready(config.ready_timeout)?;
        let hello = match link.transact(Command::Hello) {
            Err(DriverError::Timeout { .. }) if !banner => {
                return Err(DriverError::NotReady {
                    port: name,
                    waited: config.ready_timeout,
                })
            }
            other => other?,
        };
        let info = parse_hello(&name, &hello)?;
        link.info = Some(info.clone());
        link.transact(Command::AllOff)?;
        let link = Arc::new(Mutex::new(link));
        let stop = Arc::new(AtomicBool::new(false));
        let keepalive = config.keepalive.map(|period| {
            let period = period.min(info.heartbeat / 3).max(Duration::from_millis(1));
            let (l, s) = (link.clone(), stop.clone());
            std::thread::spawn(move || keep_alive(&l, &s, period))
        });
        Ok(SerialLights {
            link,
            name,
            info,
            stop,
            keepalive,
        })
    }

    pub fn board_info(&self) -> &BoardInfo {
        &self.info
    }

    /// Sends one PING now (the keepalive does this on its own).
    pub fn ping(&mut self) -> Result<(), DriverError> {
        self.lock().transact(Command::Ping).map(|_| ())
    }

    /// How many times the host re-synchronised after a board reset.
    pub fn resyncs(&self) -> u64 {
        self.lock().resyncs
    }

    fn lock(&self) -> MutexGuard<'_, Link> {
        // Link updates are single assignments after each acknowledged
        // request, so a panicked keepalive leaves a usable link.
        self.link.lock().unwrap_or_else(|p| p.into_inner())
    }
}

impl Drop for SerialLights {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.keepalive.take() {
            t.thread().unpark();
            let _ = t.join();
        }
        // Leave the rig dark; the board's heartbeat would do it anyway, but
        // later.
        if let Err(e) = self.lock().transact(Command::AllOff) {
            tracing::warn!("{e}");
        }
    }
}

impl LightController for SerialLights {
    fn id(&self) -> &str {
        &self.name
    }

    fn set(&mut self, light: LightId, state: LightState) -> Result<(), DriverError> {
        let command = match state {
            LightState::Off => Command::Off(light),
            LightState::On(level) => Command::On(light, level.to_u8()),
        };
        let mut link = self.lock();
        link.transact(command)?;
        link.lights[light.index()] = state;
        Ok(())
    }

    fn all_off(&mut self) -> Result<(), DriverError> {
        let mut link = self.lock();
        link.transact(Command::AllOff)?;
        link.lights = [LightState::Off; 3];
        Ok(())
    }

    fn state(&self, light: LightId) -> LightState {
        self.lock().lights[light.index()]
    }
}

fn keep_alive(link: &Mutex<Link>, stop: &AtomicBool, period: Duration) {
    while !stop.load(Ordering::Relaxed) {
        std::thread::park_timeout(period / 2);
        if stop.load(Ordering::Relaxed) {
            return;
        }
        let mut l = link.lock().unwrap_or_else(|p| p.into_inner());
        if l.last_sent.elapsed() >= period {
            if let Err(e) = l.transact(Command::Ping) {
                tracing::warn!("keepalive: {e}");
            }
        }
    }
}

fn parse_hello(port: &str, args: &[String]) -> Result<BoardInfo, DriverError> {
    let malformed = || DriverError::Malformed {
        device: port.to_string(),
        line: args.join(" "),
        expected: "`OK HELLO <protocol> <firmware> <heartbeat_ms>`",
    };
    match args {
        [hello, proto, firmware, heartbeat] if hello == "HELLO" => {
            let protocol = proto
                .parse::<u32>()
                .ok()
                .filter(|p| *p == PROTOCOL_VERSION)
                .ok_or_else(|| DriverError::ProtocolMismatch {
                    port: port.to_string(),
                    expected: PROTOCOL_VERSION,
                    got: proto.clone(),
                })?;
            let ms = heartbeat
                .parse::<u64>()
                .ok()
                .filter(|&ms| ms > 0)
                .ok_or_else(malformed)?;
            Ok(BoardInfo {
                protocol,
                firmware: firmware.clone(),
                heartbeat: Duration::from_millis(ms),
            })
        }
        _ => Err(malformed()),
    }
}

impl Link {
    /// Reads lines until READY or `timeout`; true when READY was seen.
    fn wait_ready(&mut self, timeout: Duration) -> Result<bool, DriverError> {
        let deadline = Instant::now() + timeout;
        while let Some(line) = self.read_line(deadline)? {
            if let Ok(tokens) = unframe(&line) {
                if let Some(BoardLine::Ready { .. }) = BoardLine::parse(&tokens) {
                    return Ok(true);
                }
            }
        }
        Ok(false)
    }

    /// One request, with re-synchronisation after board resets.
    fn transact(&mut self, command: Command) -> Result<Vec<String>, DriverError> {
        let mut resets = 0;
        let mut resync = false;
        loop {
            let step = if resync {
                self.resync().map(|()| None)
            } else {
                self.exchange(command).map(Some)
            };
            match step {
                Ok(Some(reply)) => return Ok(reply),
                Ok(None) => resync = false,
                Err(Failure::Fatal(e)) => return Err(e),
                Err(Failure::Reset) => {
                    resets += 1;
                    if resets > self.config.max_resets {
                        return Err(DriverError::KeepsResetting {
                            port: self.name.clone(),
                            command: command.text(),
                            resets,
                        });
                    }
                    tracing::warn!(
                        "{}: the light controller reset; re-applying its state",
                        self.name
                    );
                    resync = true;
                }
            }
        }
    }

    /// After a reset: HELLO (the firmware may have changed), then every
    /// light that was on.
    fn resync(&mut self) -> Result<(), Failure> {
        let hello = self.exchange(Command::Hello)?;
        self.info = Some(parse_hello(&self.name, &hello).map_err(Failure::Fatal)?);
        for light in LightId::ALL {
            if let LightState::On(level) = self.lights[light.index()] {
                self.exchange(Command::On(light, level.to_u8()))?;
            }
        }
        self.resyncs += 1;
        Ok(())
    }

    /// One request under one sequence number, retried on silence or a
    /// corrupt reply.
    fn exchange(&mut self, command: Command) -> Result<Vec<String>, Failure> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let line = request_line(seq, &command);
        for attempt in 1..=self.config.attempts {
            if attempt > 1 {
                tracing::debug!(
                    "{}: retrying `{}` (attempt {attempt})",
                    self.name,
                    command.text()
                );
            }
            self.port
                .write_all(line.as_bytes())
                .and_then(|()| self.port.flush())
                .map_err(|e| {
                    Failure::Fatal(DriverError::io(
                        &self.name,
                        "writing to the light controller",
                        e,
                    ))
                })?;
            self.last_sent = Instant::now();
            let deadline = Instant::now() + self.config.reply_timeout;
            while let Some(reply) = self.read_line(deadline).map_err(Failure::Fatal)? {
                let Ok(tokens) = unframe(&reply) else {
                    tracing::debug!("{}: dropped a reply with a bad CRC: {reply:?}", self.name);
                    continue;
                };
                match BoardLine::parse(&tokens) {
                    Some(BoardLine::Ready { .. }) => return Err(Failure::Reset),
                    Some(BoardLine::Ok { seq: s, args }) if s == seq => return Ok(args),
                    Some(BoardLine::Err { seq: s, reason }) if s == seq => {
                        return Err(Failure::Fatal(DriverError::Refused {
                            port: self.name.clone(),
                            command: command.text(),
                            reason,
                        }))
                    }
                    // A late reply to an earlier request.
                    _ => {}
                }
            }
        }
        Err(Failure::Fatal(DriverError::Timeout {
            port: self.name.clone(),
            command: command.text(),
            attempts: self.config.attempts,
            timeout: self.config.reply_timeout,
        }))
    }

    /// The next line, or `None` at `deadline`.
    fn read_line(&mut self, deadline: Instant) -> Result<Option<String>, DriverError> {
        let mut buf = [0u8; 128];
        loop {
            if let Some(line) = self.lines.pop() {
                return Ok(Some(line));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.port
                .set_read_timeout(left)
                .map_err(|e| DriverError::io(&self.name, "setting the read timeout", e))?;
            match self.port.read(&mut buf) {
                Ok(0) => {
                    return Err(DriverError::io(
                        &self.name,
                        "reading from the light controller",
                        std::io::Error::new(ErrorKind::UnexpectedEof, "the port closed"),
                    ))
                }
                Ok(n) => self.lines.push(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) => {}
                Err(e) => {
                    return Err(DriverError::io(
                        &self.name,
                        "reading from the light controller",
                        e,
                    ))
                }
            }
        }
    }
}
