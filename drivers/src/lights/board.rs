//! The light controller's firmware as a state machine: what
//! `drivers/firmware/light_controller/light_controller.ino` does, in Rust,
//! with fault injection. Tests talk to it over a pseudo-terminal and the
//! simulated rig reads its outputs to know which lights shine.
//!
//! Boundaries: pure state; the caller passes the time and moves the bytes
//! (see [`super::board_runner`]).

use super::wire::{frame, unframe, Command, PROTOCOL_VERSION};
use crate::traits::LightId;
use std::time::{Duration, Instant};

/// The firmware version the simulated board reports.
pub const SIM_FIRMWARE: &str = "sim-1.0";

/// Faults to inject. Request numbers count every line the board accepts
/// (CRC valid), retries included, starting at 1 after each construction.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BoardFaults {
    /// Execute these requests but lose the reply.
    pub drop_reply: Vec<u64>,
    /// Execute these requests but garble the reply's CRC.
    pub corrupt_reply: Vec<u64>,
    /// Reset (lights off, READY banner) on receiving these requests,
    /// without executing them.
    pub reset_on: Vec<u64>,
    /// Stop answering after this many requests (a hung or unplugged board).
    pub silent_after: Option<u64>,
    /// Lights that acknowledge but never emit (a dead LED or driver).
    pub dead_lights: Vec<LightId>,
}

/// The board's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardConfig {
    pub protocol: u32,
    pub firmware: String,
    /// Every light goes off when no valid request arrived for this long.
    pub heartbeat: Duration,
}

impl Default for BoardConfig {
    fn default() -> Self {
        BoardConfig {
            protocol: PROTOCOL_VERSION,
            firmware: SIM_FIRMWARE.to_string(),
            heartbeat: Duration::from_millis(2000),
        }
    }
}

/// The firmware's state.
#[derive(Debug, Clone)]
pub struct Board {
    config: BoardConfig,
    faults: BoardFaults,
    duty: [u8; 3],
    last: Option<(u16, String)>,
    last_request_at: Option<Instant>,
    accepted: u64,
    executed: u64,
    resets: u64,
    heartbeat_expiries: u64,
}

impl Board {
    pub fn new(config: BoardConfig, faults: BoardFaults) -> Board {
        Board {
            config,
            faults,
            duty: [0; 3],
            last: None,
            last_request_at: None,
            accepted: 0,
            executed: 0,
            resets: 0,
            heartbeat_expiries: 0,
        }
    }

    /// Power-on or reset: every light off, the dedup memory forgotten; the
    /// returned banner is what the board prints.
    pub fn boot(&mut self) -> String {
        self.duty = [0; 3];
        self.last = None;
        self.last_request_at = None;
        self.resets += 1;
        frame(&format!(
            "READY {} {}",
            self.config.protocol, self.config.firmware
        ))
    }

    /// Handles one received line (without its newline) at `now`; returns the
    /// lines to send back.
    pub fn on_line(&mut self, line: &str, now: Instant) -> Vec<String> {
        self.tick(now);
        let Ok(tokens) = unframe(line) else {
            // A corrupted request cannot be trusted even for its sequence
            // number; the host's retry recovers.
            return Vec::new();
        };
        self.accepted += 1;
        let n = self.accepted;
        if self.faults.reset_on.contains(&n) {
            return vec![self.boot()];
        }
        if self.faults.silent_after.is_some_and(|s| n > s) {
            return Vec::new();
        }
        let Some(seq) = tokens.first().and_then(|s| s.parse::<u16>().ok()) else {
            return vec![frame("0 ERR BADSEQ")];
        };
        self.last_request_at = Some(now);
        let reply = match &self.last {
            // A retry of the request just executed: same answer, no second
            // execution, so retries are idempotent.
            Some((last_seq, reply)) if *last_seq == seq => reply.clone(),
            _ => {
                let reply = self.execute(seq, &tokens[1..]);
                self.last = Some((seq, reply.clone()));
                reply
            }
        };
        if self.faults.drop_reply.contains(&n) {
            return Vec::new();
        }
        if self.faults.corrupt_reply.contains(&n) {
            let garbled = reply.replacen('*', "*F", 1);
            return vec![garbled];
        }
        vec![reply]
    }

    fn execute(&mut self, seq: u16, tokens: &[&str]) -> String {
        self.executed += 1;
        match Command::parse(tokens) {
            Ok(Command::Hello) => frame(&format!(
                "{seq} OK HELLO {} {} {}",
                self.config.protocol,
                self.config.firmware,
                self.config.heartbeat.as_millis()
            )),
            Ok(Command::On(light, duty)) => {
                self.duty[light.index()] = duty;
                frame(&format!("{seq} OK"))
            }
            Ok(Command::Off(light)) => {
                self.duty[light.index()] = 0;
                frame(&format!("{seq} OK"))
            }
            Ok(Command::AllOff) => {
                self.duty = [0; 3];
                frame(&format!("{seq} OK"))
            }
            Ok(Command::Ping) => frame(&format!("{seq} OK")),
            Err(reason) => frame(&format!("{seq} ERR {reason}")),
        }
    }

    /// Lets time pass: switches every light off once the heartbeat expired.
    pub fn tick(&mut self, now: Instant) {
        if let Some(at) = self.last_request_at {
            if now.saturating_duration_since(at) > self.config.heartbeat {
                if self.duty.iter().any(|&d| d > 0) {
                    self.heartbeat_expiries += 1;
                }
                self.duty = [0; 3];
                self.last_request_at = None;
            }
        }
    }

    /// The duty the board was told for `light`.
    pub fn commanded(&self, light: LightId) -> u8 {
        self.duty[light.index()]
    }

    /// What `light` really emits (0 for a dead light).
    pub fn output(&self, light: LightId) -> u8 {
        if self.faults.dead_lights.contains(&light) {
            0
        } else {
            self.duty[light.index()]
        }
    }

    /// Requests executed (retries answered from memory do not count).
    pub fn executed(&self) -> u64 {
        self.executed
    }

    /// Boots so far, the first power-on included.
    pub fn resets(&self) -> u64 {
        self.resets
    }

    pub fn heartbeat_expiries(&self) -> u64 {
        self.heartbeat_expiries
    }

    pub fn heartbeat(&self) -> Duration {
        self.config.heartbeat
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::wire::{request_line, BoardLine};

    fn reply(board: &mut Board, seq: u16, cmd: Command, now: Instant) -> Option<BoardLine> {
        let out = board.on_line(request_line(seq, &cmd).trim_end(), now);
        let line = out.first()?;
        BoardLine::parse(&unframe(line).ok()?)
    }

    #[test]
    fn executes_requests_and_answers_a_repeated_seq_from_memory() {
        let mut b = Board::new(BoardConfig::default(), BoardFaults::default());
        b.boot();
        let t = Instant::now();
        let ok = Some(BoardLine::Ok {
            seq: 5,
            args: vec![],
        });
        assert_eq!(reply(&mut b, 5, Command::On(LightId::Flash0, 255), t), ok);
        assert_eq!(b.output(LightId::Flash0), 255);
        b.on_line(
            request_line(6, &Command::Off(LightId::Flash0)).trim_end(),
            t,
        );
        // A late duplicate of seq 6 must not be executed a second time.
        b.on_line(
            request_line(6, &Command::Off(LightId::Flash0)).trim_end(),
            t,
        );
        assert_eq!(b.executed(), 2);
        assert_eq!(b.output(LightId::Flash0), 0);
    }

    #[test]
    fn heartbeat_expiry_switches_every_light_off() {
        let config = BoardConfig {
            heartbeat: Duration::from_millis(500),
            ..BoardConfig::default()
        };
        let mut b = Board::new(config, BoardFaults::default());
        b.boot();
        let t0 = Instant::now();
        reply(&mut b, 1, Command::On(LightId::Backlight, 128), t0);
        reply(
            &mut b,
            2,
            Command::On(LightId::Flash1, 64),
            t0 + Duration::from_millis(400),
        );
        b.tick(t0 + Duration::from_millis(800));
        assert_eq!(
            b.output(LightId::Backlight),
            128,
            "a request 400 ms ago keeps it alive"
        );
        b.tick(t0 + Duration::from_millis(901));
        assert_eq!(b.output(LightId::Backlight), 0);
        assert_eq!(b.output(LightId::Flash1), 0);
        assert_eq!(b.heartbeat_expiries(), 1);
    }

    #[test]
    fn dead_light_acknowledges_but_does_not_emit() {
        let faults = BoardFaults {
            dead_lights: vec![LightId::Flash1],
            ..BoardFaults::default()
        };
        let mut b = Board::new(BoardConfig::default(), faults);
        b.boot();
        let r = reply(&mut b, 1, Command::On(LightId::Flash1, 255), Instant::now());
        assert_eq!(
            r,
            Some(BoardLine::Ok {
                seq: 1,
                args: vec![]
            })
        );
        assert_eq!(b.commanded(LightId::Flash1), 255);
        assert_eq!(b.output(LightId::Flash1), 0);
    }

    #[test]
    fn bad_requests_get_err_replies_and_corrupt_lines_none() {
        let mut b = Board::new(BoardConfig::default(), BoardFaults::default());
        b.boot();
        let out = b.on_line(&frame("3 ON Q9 1").replace('\n', ""), Instant::now());
        let parsed = BoardLine::parse(&unframe(&out[0]).unwrap());
        assert_eq!(
            parsed,
            Some(BoardLine::Err {
                seq: 3,
                reason: "BADLIGHT".into()
            })
        );
        assert!(b.on_line("3 PING *0000", Instant::now()).is_empty());
    }
}
