//! The light controller's line format: framing, CRC and parsing, shared by
//! the host ([`super::host`]) and the simulated board ([`super::board`]).
//!
//! A line is `<text> *<crc>\n` where `<crc>` is the CRC-16/CCITT-FALSE of
//! every byte before the `*` (the trailing space included), as four
//! upper-case hex digits. `docs/light-protocol.md` is the full
//! specification. Boundaries: text only; no I/O and no timing.

use crate::traits::LightId;

/// The protocol version this host speaks (`HELLO` checks the board's).
pub const PROTOCOL_VERSION: u32 = 1;

/// Longest line either side sends or accepts, newline excluded.
pub const MAX_LINE: usize = 96;

/// CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no
/// reflection, no final XOR (check value 0x29B1 for `123456789`).
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &b in bytes {
        crc ^= (b as u16) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// Frames `text` (tokens separated by single spaces) as one line.
pub fn frame(text: &str) -> String {
    let head = format!("{text} ");
    let crc = crc16(head.as_bytes());
    format!("{head}*{crc:04X}\n")
}

/// Why a received line was not accepted.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LineError {
    NoCrc,
    BadCrc { got: String, computed: u16 },
}

/// The tokens of a received line (without its newline) once its CRC checks.
pub fn unframe(line: &str) -> Result<Vec<&str>, LineError> {
    let line = line.trim_end_matches(['\r', '\n']);
    let star = line.rfind('*').ok_or(LineError::NoCrc)?;
    let (head, crc) = (&line[..star], &line[star + 1..]);
    let computed = crc16(head.as_bytes());
    match u16::from_str_radix(crc, 16) {
        Ok(got) if crc.len() == 4 && got == computed => Ok(head.split_whitespace().collect()),
        _ => Err(LineError::BadCrc {
            got: crc.to_string(),
            computed,
        }),
    }
}

/// A host request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    Hello,
    On(LightId, u8),
    Off(LightId),
    AllOff,
    Ping,
}

impl Command {
    pub fn text(&self) -> String {
        match self {
            Command::Hello => "HELLO".to_string(),
            Command::On(l, duty) => format!("ON {} {duty}", l.wire_code()),
            Command::Off(l) => format!("OFF {}", l.wire_code()),
            Command::AllOff => "ALLOFF".to_string(),
            Command::Ping => "PING".to_string(),
        }
    }

    /// Parses the tokens after the sequence number.
    pub fn parse(tokens: &[&str]) -> Result<Command, &'static str> {
        let light = |t: Option<&&str>| t.and_then(|c| LightId::from_wire_code(c)).ok_or("BADLIGHT");
        match tokens.first().copied() {
            Some("HELLO") if tokens.len() == 1 => Ok(Command::Hello),
            Some("PING") if tokens.len() == 1 => Ok(Command::Ping),
            Some("ALLOFF") if tokens.len() == 1 => Ok(Command::AllOff),
            Some("OFF") if tokens.len() == 2 => Ok(Command::Off(light(tokens.get(1))?)),
            Some("ON") if tokens.len() == 3 => {
                let l = light(tokens.get(1))?;
                let duty = tokens[2].parse::<u8>().map_err(|_| "BADLEVEL")?;
                Ok(Command::On(l, duty))
            }
            _ => Err("BADCMD"),
        }
    }
}

/// A request line: `<seq> <command>`.
pub fn request_line(seq: u16, command: &Command) -> String {
    frame(&format!("{seq} {}", command.text()))
}

/// A line from the board, once its CRC checks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BoardLine {
    /// The banner after a reset: `READY <proto> <fw>`.
    Ready {
        proto: String,
        firmware: String,
    },
    Ok {
        seq: u16,
        args: Vec<String>,
    },
    Err {
        seq: u16,
        reason: String,
    },
}

impl BoardLine {
    pub fn parse(tokens: &[&str]) -> Option<BoardLine> {
        match tokens {
            ["READY", proto, firmware] => Some(BoardLine::Ready {
                proto: proto.to_string(),
                firmware: firmware.to_string(),
            }),
            [seq, "OK", args @ ..] => Some(BoardLine::Ok {
                seq: seq.parse().ok()?,
                args: args.iter().map(|a| a.to_string()).collect(),
            }),
            [seq, "ERR", reason, ..] => Some(BoardLine::Err {
                seq: seq.parse().ok()?,
                reason: reason.to_string(),
            }),
            _ => None,
        }
    }
}

/// Splits a byte stream into lines, dropping `\r` and any line longer than
/// [`MAX_LINE`] (garbage from a board booting, or line noise).
#[derive(Debug, Default)]
pub struct LineBuffer {
    current: Vec<u8>,
    overflowed: bool,
    ready: std::collections::VecDeque<String>,
}

impl LineBuffer {
    pub fn push(&mut self, bytes: &[u8]) {
        for &b in bytes {
            match b {
                b'\n' => {
                    if !self.overflowed {
                        self.ready
                            .push_back(String::from_utf8_lossy(&self.current).into_owned());
                    }
                    self.current.clear();
                    self.overflowed = false;
                }
                b'\r' => {}
                _ if self.current.len() >= MAX_LINE => self.overflowed = true,
                _ => self.current.push(b),
            }
        }
    }

    pub fn pop(&mut self) -> Option<String> {
        self.ready.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc_matches_the_ccitt_false_check_value() {
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn framed_line_round_trips_and_a_flipped_byte_fails() {
        let line = request_line(42, &Command::On(LightId::Flash1, 200));
        assert!(line.starts_with("42 ON F1 200 *"));
        assert!(line.ends_with('\n'));
        let tokens = unframe(&line).unwrap();
        assert_eq!(tokens, ["42", "ON", "F1", "200"]);
        assert_eq!(
            Command::parse(&tokens[1..]),
            Ok(Command::On(LightId::Flash1, 200))
        );
        let bad = line.replace("200", "201");
        assert!(matches!(unframe(&bad), Err(LineError::BadCrc { .. })));
        assert_eq!(unframe("42 OK"), Err(LineError::NoCrc));
    }

    #[test]
    fn documented_example_lines_check() {
        // The worked example of docs/light-protocol.md.
        for line in [
            "READY 1 uno-1.0 *84A8",
            "1 HELLO *7B58",
            "1 OK HELLO 1 uno-1.0 2000 *2041",
            "2 ON F0 255 *68D3",
            "2 OK *AAE7",
            "4 ERR BADLIGHT *6446",
        ] {
            assert!(unframe(line).is_ok(), "{line}");
        }
        assert_eq!(
            request_line(2, &Command::On(LightId::Flash0, 255)),
            "2 ON F0 255 *68D3\n"
        );
    }

    #[test]
    fn board_lines_parse() {
        let ready = frame("READY 1 fw-0.3");
        let t = unframe(&ready).unwrap();
        assert_eq!(
            BoardLine::parse(&t),
            Some(BoardLine::Ready {
                proto: "1".into(),
                firmware: "fw-0.3".into()
            })
        );
        let err = frame("7 ERR BADLIGHT");
        let t = unframe(&err).unwrap();
        assert_eq!(
            BoardLine::parse(&t),
            Some(BoardLine::Err {
                seq: 7,
                reason: "BADLIGHT".into()
            })
        );
        assert_eq!(Command::parse(&["ON", "XX", "3"]), Err("BADLIGHT"));
        assert_eq!(Command::parse(&["ON", "F0", "256"]), Err("BADLEVEL"));
        assert_eq!(Command::parse(&["FLY"]), Err("BADCMD"));
    }

    #[test]
    fn line_buffer_splits_strips_cr_and_drops_overlong_lines() {
        let mut b = LineBuffer::default();
        b.push(b"ab\r\ncd");
        assert_eq!(b.pop().as_deref(), Some("ab"));
        assert_eq!(b.pop(), None);
        b.push(b"e\n");
        assert_eq!(b.pop().as_deref(), Some("cde"));
        b.push(&[b'x'; MAX_LINE + 10]);
        b.push(b"\nok\n");
        assert_eq!(b.pop().as_deref(), Some("ok"));
    }
}
