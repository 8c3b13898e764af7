//! The TI DLP LightCrafter 4500 (DLPC350 controller) as the rig's
//! projector, driven over its USB HID command channel, showing what the
//! controller's internal test pattern generator (TPG) can show exactly.
//!
//! Sources (only codes and layouts found in them are used):
//! - TI's `dlpc350_api.cpp` / `dlpc350_api.h` / `dlpc350_common.h`
//!   (LightCrafter 4500 GUI sources, © 2015 TI, as vendored in
//!   jakobwilm/slstudio `src/projector/LC4500API/`): the message struct
//!   (flags byte: bits 2:0 destination, bit 5 `nack` = command handler
//!   error, bit 6 `reply` = host wants a reply, bit 7 read = 1 / write = 0;
//!   then sequence byte, little-endian 16-bit length of command + payload,
//!   then the 16-bit command `CMD2 << 8 | CMD3` little-endian, i.e. CMD3
//!   first), `DLPC350_SendMsg` (64-byte reports; a longer message goes on
//!   in further 64-byte reports of bare data, at most `HID_MESSAGE_MAX_SIZE`
//!   = 512 bytes of command + payload), the command table `CmdList` and the
//!   payloads of `SetPowerMode`, `SetMode`, `SetInputSource`,
//!   `SetTPGSelect`, `SetTPGColor`, `SetLedEnables`, `SetLedCurrents`, and
//!   `PTN_WIDTH`/`PTN_HEIGHT` = 912 × 1140 (the DMD's native mirrors, "a
//!   pixel resolution of 912 x 1140" in `SetMode`).
//! - SivyerLab/pyCrafter4500 (`pycrafter4500.py`): the same packet layout
//!   written straight to interrupt endpoint 1 with no report-id byte (what
//!   a raw-USB host sends; hidapi's leading 0 is not on the wire), replies
//!   read from endpoint 0x81; pattern sequence start/stop (0x1A 0x24,
//!   0 = stop) sent before switching to video mode; and Gamma Correction
//!   (0x1A 0x0E) with payload 0 = do not apply.
//! - TI DLPU018 (DLPC900 programmer's guide, the same HID protocol family):
//!   "the controller responds with the same sequence byte that the host
//!   sent", so the host can match replies to commands.
//!
//! What it can show, and why so little:
//! - Black: a solid field of colour 0, and (by default) every LED switched
//!   off, because the DMD's off state still leaks some light.
//! - Uniform(level): a solid field; the level is the TPG colour, 10 bits per
//!   channel (0..=0x3FF), `round(level × 1023)` on R, G and B. That is
//!   linear because the TPG is injected at the start of the video
//!   processing path (TI: "all image processing is performed on the test
//!   images") and this driver switches the Gamma Correction (degamma) step
//!   off at open, so the code drives the DMD's duty cycle directly, and the
//!   DMD "is inherently linear in response". (TI's degamma curves are not
//!   published as formulas, so a gamma-encoded code could not be exact.)
//!   Brightness overall is the LED currents (8-bit PWM, 0xFF = maximum with
//!   normal PWM polarity), set once from the configuration.
//! - Checker: only when `low == high` (a uniform field). The TPG has a
//!   checkerboard (pattern 7), but no source documents its square size or
//!   phase, and it runs through the video scaler onto the diamond-pixel
//!   DMD, so no checker of a given period and phase in native pixels can be
//!   promised: every other checker is an `InvalidSetting` that says so and
//!   points at the DRM/HDMI output (`super::kms`, the projector's HDMI
//!   input), which draws checkers pixel-exact.
//!
//! Nothing here was run against a real projector.
//!
//! Boundaries: the codec ([`encode`], [`parse_reply`], [`Setting`]) is pure;
//! [`LightCrafter`] talks through a [`HidTransport`] (64-byte reports in
//! and out), so everything here is tested with a fake (that checks the
//! exact bytes) in the default build; the libusb transport is `transport`
//! (feature `hardware`): `transport::RusbHid` and `LightCrafter::open`, over the HID
//! plumbing of `crate::usb`.

#[cfg(feature = "hardware")]
pub mod transport;

use crate::error::DriverError;
use crate::traits::{Level, Projector, ProjectorPattern};
use std::io;
use std::time::{Duration, Instant};

/// One HID report, either direction.
pub const REPORT_LEN: usize = 64;
/// Flags, sequence, 16-bit length.
pub const HEADER_LEN: usize = 4;
/// `HID_MESSAGE_MAX_SIZE`: command bytes + payload of one message.
pub const MAX_MESSAGE_LEN: usize = 512;
/// The DMD's native mirror array (`PTN_WIDTH` × `PTN_HEIGHT`).
pub const NATIVE_RESOLUTION: (u32, u32) = (912, 1140);
/// Full scale of a TPG colour channel.
pub const TPG_MAX: u16 = 0x3FF;

const FLAG_READ: u8 = 0x80;
const FLAG_REPLY: u8 = 0x40;
const FLAG_ERROR: u8 = 0x20;

/// A DLPC350 USB command: `CMD2`, `CMD3` and a name for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    pub name: &'static str,
    pub cmd2: u8,
    pub cmd3: u8,
}

impl std::fmt::Display for Command {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "`{}` (CMD2 0x{:02X}, CMD3 0x{:02X})",
            self.name, self.cmd2, self.cmd3
        )
    }
}

/// The commands used here, from TI's `CmdList` (and pycrafter4500 for
/// gamma correction, which TI's table leaves empty).
pub mod cmd {
    use super::Command;

    const fn c(name: &'static str, cmd2: u8, cmd3: u8) -> Command {
        Command { name, cmd2, cmd3 }
    }
    /// POWER_CONTROL: 1 byte, 1 = standby, 0 = normal operation.
    pub const POWER_CONTROL: Command = c("power control", 0x02, 0x00);
    /// DISP_MODE: 1 byte, 0 = video mode, 1 = pattern display mode.
    pub const DISPLAY_MODE: Command = c("display mode", 0x1A, 0x1B);
    /// PAT_START_STOP: 1 byte, 0 = stop, 1 = pause, 2 = start.
    pub const PATTERN_START_STOP: Command = c("pattern sequence start/stop", 0x1A, 0x24);
    /// SOURCE_SEL: bits 2:0 source, bits 5:3 parallel port width.
    pub const INPUT_SOURCE: Command = c("input source", 0x1A, 0x00);
    /// Gamma correction (pycrafter4500): 1 byte, 0 = do not apply.
    pub const GAMMA_CORRECTION: Command = c("gamma correction", 0x1A, 0x0E);
    /// TPG_SEL: bits 3:0 the test pattern.
    pub const TPG_SELECT: Command = c("test pattern select", 0x12, 0x03);
    /// TPG_COLOR: 6 little-endian u16, R G B foreground then background.
    pub const TPG_COLOR: Command = c("test pattern colour", 0x12, 0x04);
    /// LED_ENABLE: bit 0 red, 1 green, 2 blue, 3 sequencer control.
    pub const LED_ENABLE: Command = c("LED enable", 0x1A, 0x07);
    /// LED_CURRENT: 3 bytes, red green blue PWM (0xFF = maximum).
    pub const LED_CURRENT: Command = c("LED current", 0x0B, 0x01);
    /// STATUS_MAIN (read): bit 0 DMD parked, 1 sequencer running, 2 frame
    /// buffer frozen, 3 gamma correction enabled.
    pub const MAIN_STATUS: Command = c("main status", 0x1A, 0x0C);
    /// GET_VERSION (read): four little-endian u32 (application, API,
    /// software configuration, sequence configuration).
    pub const VERSION: Command = c("version", 0x02, 0x05);
}

/// DISP_MODE values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DisplayMode {
    /// Streams (or the TPG) through the image processing path.
    Video = 0,
    /// Structured-light pattern sequences, processing bypassed.
    Pattern = 1,
}

/// SOURCE_SEL values (bits 2:0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputSource {
    Parallel = 0,
    TestPattern = 1,
    Flash = 2,
    FpdLink = 3,
}

/// TPG_SEL values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TestPattern {
    SolidField = 0x0,
    HorizontalRamp = 0x1,
    VerticalRamp = 0x2,
    HorizontalLines = 0x3,
    DiagonalLines = 0x4,
    VerticalLines = 0x5,
    Grid = 0x6,
    Checkerboard = 0x7,
    RgbRamp = 0x8,
    ColorBars = 0x9,
    StepBars = 0xA,
}

/// PAT_START_STOP values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SequenceAction {
    Stop = 0,
    Pause = 1,
    Start = 2,
}

/// Who switches the LEDs (LED_ENABLE).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LedEnables {
    /// The sequencer, as in normal video display (bit 3).
    Sequencer,
    /// Held on or off by hand, sequencer ignored.
    Manual { red: bool, green: bool, blue: bool },
}

/// A write command with its payload, as `dlpc350_api.cpp` builds them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `true`: low-power standby, DMD interface down.
    Standby(bool),
    DisplayMode(DisplayMode),
    PatternSequence(SequenceAction),
    /// The source, with parallel port width 0 (30 bits; irrelevant to the
    /// TPG).
    InputSource(InputSource),
    /// Gamma correction (degamma) off: payload 0.
    GammaCorrectionOff,
    TestPattern(TestPattern),
    /// R, G, B in 0..=0x3FF, foreground then background (the background is
    /// used by the two-colour patterns only).
    TestPatternColors {
        foreground: [u16; 3],
        background: [u16; 3],
    },
    LedEnables(LedEnables),
    /// Red, green, blue LED PWM, 0xFF = maximum current.
    LedCurrents([u8; 3]),
}

impl Setting {
    pub fn command(&self) -> Command {
        match self {
            Setting::Standby(_) => cmd::POWER_CONTROL,
            Setting::DisplayMode(_) => cmd::DISPLAY_MODE,
            Setting::PatternSequence(_) => cmd::PATTERN_START_STOP,
            Setting::InputSource(_) => cmd::INPUT_SOURCE,
            Setting::GammaCorrectionOff => cmd::GAMMA_CORRECTION,
            Setting::TestPattern(_) => cmd::TPG_SELECT,
            Setting::TestPatternColors { .. } => cmd::TPG_COLOR,
            Setting::LedEnables(_) => cmd::LED_ENABLE,
            Setting::LedCurrents(_) => cmd::LED_CURRENT,
        }
    }

    /// The payload after the command bytes; colours above 0x3FF are
    /// clamped (the field has 10 bits).
    pub fn payload(&self) -> Vec<u8> {
        match *self {
            Setting::Standby(standby) => vec![standby as u8],
            Setting::DisplayMode(mode) => vec![mode as u8],
            Setting::PatternSequence(action) => vec![action as u8],
            // Port width (bits 5:3) 0.
            Setting::InputSource(source) => vec![source as u8],
            Setting::GammaCorrectionOff => vec![0],
            Setting::TestPattern(pattern) => vec![pattern as u8],
            Setting::TestPatternColors {
                foreground,
                background,
            } => foreground
                .iter()
                .chain(background.iter())
                .flat_map(|c| (*c).min(TPG_MAX).to_le_bytes())
                .collect(),
            Setting::LedEnables(LedEnables::Sequencer) => vec![0x08],
            Setting::LedEnables(LedEnables::Manual { red, green, blue }) => {
                vec![red as u8 | (green as u8) << 1 | (blue as u8) << 2]
            }
            Setting::LedCurrents(rgb) => rgb.to_vec(),
        }
    }
}

/// Builds the reports of one message: the first carries the header, the
/// command (CMD3, CMD2) and up to 58 payload bytes; the rest carry 64 more
/// bytes each; all are zero-padded to 64. `None` when command + payload
/// exceed the controller's 512-byte message buffer.
pub fn encode(
    command: Command,
    read: bool,
    seq: u8,
    payload: &[u8],
) -> Option<Vec<[u8; REPORT_LEN]>> {
    let text_len = payload.len() + 2;
    if text_len > MAX_MESSAGE_LEN {
        return None;
    }
    let mut message = Vec::with_capacity(HEADER_LEN + text_len);
    // Destination 0 (projector control), reply wanted: every command is
    // acknowledged so an error is seen where it happened.
    message.push(FLAG_REPLY | if read { FLAG_READ } else { 0 });
    message.push(seq);
    message.extend_from_slice(&(text_len as u16).to_le_bytes());
    message.push(command.cmd3);
    message.push(command.cmd2);
    message.extend_from_slice(payload);
    Some(
        message
            .chunks(REPORT_LEN)
            .map(|chunk| {
                let mut report = [0u8; REPORT_LEN];
                report[..chunk.len()].copy_from_slice(chunk);
                report
            })
            .collect(),
    )
}

/// The header of a reply report.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplyHeader {
    pub seq: u8,
    /// The `nack` flag: the command handler rejected the command.
    pub error: bool,
    /// Bytes of data the reply carries (may continue in further reports).
    pub length: usize,
}

/// Reads the header of a reply report; `None` when it is shorter than the
/// header or says it carries more than the controller's message buffer.
pub fn parse_reply(report: &[u8]) -> Option<(ReplyHeader, &[u8])> {
    if report.len() < HEADER_LEN {
        return None;
    }
    let length = u16::from_le_bytes([report[2], report[3]]) as usize;
    if length > MAX_MESSAGE_LEN {
        return None;
    }
    let data = &report[HEADER_LEN..];
    Some((
        ReplyHeader {
            seq: report[1],
            error: report[0] & FLAG_ERROR != 0,
            length,
        },
        &data[..length.min(data.len())],
    ))
}

/// The 10-bit TPG code for a linear level (degamma off, see the module
/// doc).
pub fn tpg_code(level: Level) -> u16 {
    (level.get() * TPG_MAX as f32).round() as u16
}

/// 64-byte HID reports to and from the controller.
pub trait HidTransport {
    /// The device's name for messages (`usb:0451:6401`).
    fn name(&self) -> &str;
    fn write_report(&mut self, report: &[u8; REPORT_LEN]) -> io::Result<()>;
    /// One input report into `buf`, its length; `Ok(None)` when `timeout`
    /// passes without one.
    fn read_report(
        &mut self,
        buf: &mut [u8; REPORT_LEN],
        timeout: Duration,
    ) -> io::Result<Option<usize>>;
}

/// How the projector is driven.
#[derive(Debug, Clone, PartialEq)]
pub struct LightCrafterConfig {
    /// The command interface's USB id (used by `LightCrafter::open`).
    pub id: crate::usb::UsbId,
    /// How long one command may wait for its acknowledgement.
    pub reply_timeout: Duration,
    /// Wait after a pattern's commands are acknowledged before `show`
    /// returns: the TPG change reaches the mirrors on a later video frame
    /// (a guess of three 60 Hz frames; measure it with the camera).
    pub settle: Duration,
    /// LED PWM (red, green, blue; 0xFF = maximum), sent once at open;
    /// `None` leaves what the projector has (its flash defaults).
    pub led_currents: Option<[u8; 3]>,
    /// Black switches the LEDs off (really dark) rather than only showing
    /// colour 0 (the DMD's off state leaks some light).
    pub black_leds_off: bool,
}

impl Default for LightCrafterConfig {
    fn default() -> Self {
        LightCrafterConfig {
            id: crate::usb::UsbId::LIGHTCRAFTER_4500,
            reply_timeout: Duration::from_millis(500),
            settle: Duration::from_millis(50),
            led_currents: None,
            black_leds_off: true,
        }
    }
}

/// The LightCrafter as a [`Projector`].
pub struct LightCrafter<T: HidTransport> {
    transport: T,
    config: LightCrafterConfig,
    name: String,
    seq: u8,
    pattern: ProjectorPattern,
}

impl<T: HidTransport> LightCrafter<T> {
    /// Wakes the controller, selects video mode with the TPG as source,
    /// switches degamma off, sets the LED currents (if configured) and
    /// shows black; every command must be acknowledged.
    pub fn connect(transport: T, config: LightCrafterConfig) -> Result<Self, DriverError> {
        let name = transport.name().to_string();
        let mut lc = LightCrafter {
            transport,
            config,
            name,
            seq: 0,
            pattern: ProjectorPattern::Black,
        };
        lc.apply(&Setting::Standby(false))?;
        // As pycrafter4500's video_mode(): stop any pattern sequence first.
        lc.apply(&Setting::PatternSequence(SequenceAction::Stop))?;
        // The TPG feeds the video path, so video mode.
        lc.apply(&Setting::DisplayMode(DisplayMode::Video))?;
        lc.apply(&Setting::InputSource(InputSource::TestPattern))?;
        lc.apply(&Setting::GammaCorrectionOff)?;
        if let Some(rgb) = lc.config.led_currents {
            lc.apply(&Setting::LedCurrents(rgb))?;
        }
        lc.show(ProjectorPattern::Black)?;
        Ok(lc)
    }

    pub fn config(&self) -> &LightCrafterConfig {
        &self.config
    }

    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// Sends one write command and waits for its acknowledgement.
    pub fn apply(&mut self, setting: &Setting) -> Result<(), DriverError> {
        self.transact(setting.command(), false, &setting.payload())
            .map(|_| ())
    }

    /// Sends a read command and returns the reply's data.
    pub fn read(&mut self, command: Command, params: &[u8]) -> Result<Vec<u8>, DriverError> {
        let data = self.transact(command, true, params)?;
        if data.is_empty() {
            // dlpc350_api.cpp treats an empty read reply as a failure too.
            return Err(self.malformed(&[], command, "a read reply with data"));
        }
        Ok(data)
    }

    /// Sends one message and waits for the reply with its sequence byte;
    /// replies with another sequence byte are late answers to commands that
    /// timed out earlier and are skipped.
    fn transact(
        &mut self,
        command: Command,
        read: bool,
        payload: &[u8],
    ) -> Result<Vec<u8>, DriverError> {
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        let reports =
            encode(command, read, seq, payload).ok_or_else(|| DriverError::InvalidSetting {
                device: self.name.clone(),
                reason: format!(
                    "{command}: {} payload bytes exceed the controller's {MAX_MESSAGE_LEN}-byte \
                     message buffer",
                    payload.len()
                ),
            })?;
        for report in &reports {
            self.transport.write_report(report).map_err(|e| {
                DriverError::io(&self.name, "sending a command to the LightCrafter", e)
            })?;
        }
        let deadline = Instant::now() + self.config.reply_timeout;
        let mut buf = [0u8; REPORT_LEN];
        let (n, header) = loop {
            let n = self.read_before(&mut buf, deadline, command)?;
            let Some((header, _)) = parse_reply(&buf[..n]) else {
                return Err(self.malformed(
                    &buf[..n],
                    command,
                    "a DLPC350 reply: flags, sequence, 16-bit length (at most 512), data",
                ));
            };
            if header.seq == seq {
                break (n, header);
            }
            tracing::warn!(
                "{}: skipping a reply with sequence {} while waiting for {} of {command}",
                self.name,
                header.seq,
                seq
            );
        };
        if header.error {
            return Err(DriverError::InvalidSetting {
                device: self.name.clone(),
                reason: format!(
                    "the LightCrafter rejected {command} with payload [{}] (error flag in its \
                     reply); the command or value is not valid in its current mode",
                    hex(payload)
                ),
            });
        }
        let mut data = buf[HEADER_LEN..n].to_vec();
        data.truncate(header.length);
        // Long replies go on in further reports of bare data.
        while data.len() < header.length {
            let m = self.read_before(&mut buf, deadline, command)?;
            let want = header.length - data.len();
            data.extend_from_slice(&buf[..m.min(want)]);
        }
        Ok(data)
    }

    fn read_before(
        &mut self,
        buf: &mut [u8; REPORT_LEN],
        deadline: Instant,
        command: Command,
    ) -> Result<usize, DriverError> {
        let left = deadline.saturating_duration_since(Instant::now());
        let got = if left.is_zero() {
            None
        } else {
            self.transport
                .read_report(buf, left)
                .map_err(|e| DriverError::io(&self.name, "reading the LightCrafter's reply", e))?
        };
        got.ok_or_else(|| {
            DriverError::io(
                &self.name,
                "waiting for the LightCrafter's reply",
                io::Error::new(
                    io::ErrorKind::TimedOut,
                    format!(
                        "no reply to {command} within {:?} (is the projector powered, and is \
                         this its command interface?)",
                        self.config.reply_timeout
                    ),
                ),
            )
        })
    }

    fn malformed(&self, bytes: &[u8], command: Command, expected: &'static str) -> DriverError {
        DriverError::Malformed {
            device: self.name.clone(),
            line: format!("reply to {command}: [{}]", hex(bytes)),
            expected,
        }
    }

    /// The commands that show `pattern`, or why it cannot be shown.
    pub fn settings_for(&self, pattern: ProjectorPattern) -> Result<Vec<Setting>, DriverError> {
        let solid = |code: u16| Setting::TestPatternColors {
            foreground: [code; 3],
            background: [0; 3],
        };
        let lit = |code: u16| {
            vec![
                solid(code),
                Setting::TestPattern(TestPattern::SolidField),
                Setting::LedEnables(LedEnables::Sequencer),
            ]
        };
        Ok(match pattern {
            ProjectorPattern::Black if self.config.black_leds_off => vec![
                // LEDs off first, so nothing of the old pattern flashes.
                Setting::LedEnables(LedEnables::Manual {
                    red: false,
                    green: false,
                    blue: false,
                }),
                solid(0),
                Setting::TestPattern(TestPattern::SolidField),
            ],
            ProjectorPattern::Black => lit(0),
            ProjectorPattern::Uniform(level) => lit(tpg_code(level)),
            ProjectorPattern::Checker(c) if c.low == c.high => lit(tpg_code(c.low)),
            ProjectorPattern::GrayCode(g) => {
                return Err(DriverError::InvalidSetting {
                    device: self.name.clone(),
                    reason: format!(
                        "cannot show the Gray code of the projector's {} (bit {}): the \
                         LightCrafter's test pattern generator shows no stripes of a chosen \
                         width; drive the projector through its HDMI input with the DRM/KMS \
                         projector to calibrate it",
                        g.axis.name(),
                        g.bit
                    ),
                })
            }
            ProjectorPattern::Checker(c) => {
                return Err(DriverError::InvalidSetting {
                    device: self.name.clone(),
                    reason: format!(
                        "cannot show a checkerboard of period {} px, phase ({}, {}) px: the \
                         LightCrafter's test pattern generator shows no checkerboard of a known \
                         period or phase on its native {}x{} mirrors (its square size is not \
                         documented and it passes through the video scaler), so the periods and \
                         phases it can show are none; it shows black and uniform levels only. \
                         Drive the projector through its HDMI input with the DRM/KMS projector \
                         to show checkers",
                        c.period_px,
                        c.phase_px[0],
                        c.phase_px[1],
                        NATIVE_RESOLUTION.0,
                        NATIVE_RESOLUTION.1
                    ),
                })
            }
        })
    }
}

impl<T: HidTransport> Projector for LightCrafter<T> {
    fn id(&self) -> &str {
        &self.name
    }

    fn resolution(&self) -> (u32, u32) {
        NATIVE_RESOLUTION
    }

    /// Sends the pattern's commands, each acknowledged, then waits the
    /// settle time. After a failure the projector's state is unknown:
    /// [`Projector::pattern`] then still says the last pattern shown in
    /// full.
    fn show(&mut self, pattern: ProjectorPattern) -> Result<(), DriverError> {
        for setting in self.settings_for(pattern)? {
            self.apply(&setting)?;
        }
        std::thread::sleep(self.config.settle);
        self.pattern = pattern;
        Ok(())
    }

    fn pattern(&self) -> ProjectorPattern {
        self.pattern
    }

    /// Black and uniform levels; a checkerboard only when it is uniform.
    fn can_show(&self, pattern: &ProjectorPattern) -> bool {
        self.settings_for(*pattern).is_ok()
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02X}"))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traits::Checker;
    use std::collections::VecDeque;
    use std::num::NonZeroU32;

    /// What the fake controller does with the next complete message.
    #[derive(Debug, Clone)]
    enum Answer {
        Ack,
        Data(Vec<u8>),
        Nack,
        Silent,
        /// A stale reply (sequence − 1) before the right one.
        StaleThenAck,
        /// Only a reply with the wrong sequence.
        WrongSeq,
        Garbage(Vec<u8>),
    }

    /// A DLPC350 stand-in: records every report, reassembles messages from
    /// their length field, and answers each complete one from a script
    /// (default: acknowledge with the same sequence byte).
    struct FakeHid {
        sent: Vec<[u8; REPORT_LEN]>,
        script: VecDeque<Answer>,
        inbox: VecDeque<Vec<u8>>,
        /// Text bytes still expected in continuation reports.
        pending: usize,
        header: [u8; 2],
    }

    impl FakeHid {
        fn new(script: Vec<Answer>) -> FakeHid {
            FakeHid {
                sent: Vec::new(),
                script: script.into(),
                inbox: VecDeque::new(),
                pending: 0,
                header: [0; 2],
            }
        }

        fn reply(flags: u8, seq: u8, data: &[u8]) -> Vec<u8> {
            let mut r = vec![flags, seq];
            r.extend_from_slice(&(data.len() as u16).to_le_bytes());
            r.extend_from_slice(data);
            r.resize(REPORT_LEN.max(r.len()), 0);
            r
        }

        fn answer(&mut self) {
            let [flags, seq] = self.header;
            let reply_flags = flags & FLAG_READ;
            match self.script.pop_front().unwrap_or(Answer::Ack) {
                Answer::Ack => self.inbox.push_back(Self::reply(reply_flags, seq, &[])),
                Answer::Data(d) => {
                    let r = Self::reply(reply_flags, seq, &d);
                    for chunk in r.chunks(REPORT_LEN) {
                        self.inbox.push_back(chunk.to_vec());
                    }
                }
                Answer::Nack => {
                    self.inbox
                        .push_back(Self::reply(reply_flags | FLAG_ERROR, seq, &[]))
                }
                Answer::Silent => {}
                Answer::StaleThenAck => {
                    self.inbox
                        .push_back(Self::reply(reply_flags, seq.wrapping_sub(1), &[]));
                    self.inbox.push_back(Self::reply(reply_flags, seq, &[]));
                }
                Answer::WrongSeq => {
                    self.inbox
                        .push_back(Self::reply(reply_flags, seq.wrapping_add(7), &[]))
                }
                Answer::Garbage(g) => self.inbox.push_back(g),
            }
        }

        /// The (CMD2, CMD3, payload) of every message sent, reassembled.
        fn messages(&self) -> Vec<(u8, u8, Vec<u8>)> {
            let mut out = Vec::new();
            let mut i = 0;
            while i < self.sent.len() {
                let r = &self.sent[i];
                let len = u16::from_le_bytes([r[2], r[3]]) as usize;
                let mut text = r[HEADER_LEN..].to_vec();
                i += 1;
                while text.len() < len {
                    text.extend_from_slice(&self.sent[i]);
                    i += 1;
                }
                text.truncate(len);
                out.push((text[1], text[0], text[2..].to_vec()));
            }
            out
        }
    }

    impl HidTransport for FakeHid {
        fn name(&self) -> &str {
            "usb:0451:6401"
        }

        fn write_report(&mut self, report: &[u8; REPORT_LEN]) -> io::Result<()> {
            self.sent.push(*report);
            if self.pending > 0 {
                self.pending = self.pending.saturating_sub(REPORT_LEN);
            } else {
                let len = u16::from_le_bytes([report[2], report[3]]) as usize;
                self.header = [report[0], report[1]];
                self.pending = len.saturating_sub(REPORT_LEN - HEADER_LEN);
            }
            if self.pending == 0 {
                self.answer();
            }
            Ok(())
        }

        fn read_report(
            &mut self,
            buf: &mut [u8; REPORT_LEN],
            _timeout: Duration,
        ) -> io::Result<Option<usize>> {
            Ok(self.inbox.pop_front().map(|r| {
                buf[..r.len()].copy_from_slice(&r);
                r.len()
            }))
        }
    }

    fn config() -> LightCrafterConfig {
        LightCrafterConfig {
            settle: Duration::ZERO,
            reply_timeout: Duration::from_millis(50),
            ..LightCrafterConfig::default()
        }
    }

    fn connected(cfg: LightCrafterConfig) -> LightCrafter<FakeHid> {
        LightCrafter::connect(FakeHid::new(vec![]), cfg).expect("the fake acknowledges")
    }

    fn checker(period: u32, low: f32, high: f32) -> ProjectorPattern {
        ProjectorPattern::Checker(Checker {
            period_px: NonZeroU32::new(period).expect("nonzero"),
            phase_px: [0, 0],
            low: Level::new(low).expect("level"),
            high: Level::new(high).expect("level"),
        })
    }

    #[test]
    fn a_write_command_is_one_report_with_header_cmd3_cmd2_and_payload() {
        let reports = encode(cmd::TPG_SELECT, false, 0x2A, &[0x07]).expect("fits");
        assert_eq!(reports.len(), 1);
        let mut want = [0u8; REPORT_LEN];
        want[..7].copy_from_slice(&[0x40, 0x2A, 0x03, 0x00, 0x03, 0x12, 0x07]);
        assert_eq!(reports[0], want);
        // A read sets bit 7 as well.
        let read = encode(cmd::MAIN_STATUS, true, 5, &[]).expect("fits");
        assert_eq!(&read[0][..6], &[0xC0, 0x05, 0x02, 0x00, 0x0C, 0x1A]);
    }

    #[test]
    fn a_long_payload_continues_in_bare_64_byte_reports() {
        let payload: Vec<u8> = (0..100u8).collect();
        let reports = encode(cmd::TPG_COLOR, false, 1, &payload).expect("fits");
        assert_eq!(reports.len(), 2, "4 + 2 + 100 bytes");
        assert_eq!(&reports[0][..4], &[0x40, 0x01, 102, 0x00]);
        assert_eq!(&reports[0][6..], &payload[..58]);
        assert_eq!(&reports[1][..42], &payload[58..]);
        assert!(reports[1][42..].iter().all(|&b| b == 0), "zero padded");
        assert!(encode(cmd::TPG_COLOR, false, 1, &[0; 510]).is_some());
        assert!(encode(cmd::TPG_COLOR, false, 1, &[0; 511]).is_none());
    }

    #[test]
    fn settings_encode_the_documented_payloads() {
        let colors = Setting::TestPatternColors {
            foreground: [0x3FF, 0x200, 0x001],
            background: [0, 0x123, 0x5000],
        };
        assert_eq!(
            colors.payload(),
            vec![0xFF, 0x03, 0x00, 0x02, 0x01, 0x00, 0x00, 0x00, 0x23, 0x01, 0xFF, 0x03],
            "little-endian, clamped to 10 bits"
        );
        assert_eq!(
            Setting::LedEnables(LedEnables::Manual {
                red: true,
                green: false,
                blue: true
            })
            .payload(),
            vec![0b101]
        );
        assert_eq!(
            Setting::LedEnables(LedEnables::Sequencer).payload(),
            vec![0x08]
        );
        assert_eq!(
            Setting::LedCurrents([0x10, 0x20, 0xFF]).payload(),
            vec![0x10, 0x20, 0xFF]
        );
        assert_eq!(
            Setting::InputSource(InputSource::TestPattern).payload(),
            vec![1]
        );
        assert_eq!(
            Setting::TestPattern(TestPattern::Checkerboard).payload(),
            vec![7]
        );
        assert_eq!(Setting::Standby(true).payload(), vec![1]);
        assert_eq!(Setting::DisplayMode(DisplayMode::Video).payload(), vec![0]);
    }

    #[test]
    fn a_reply_header_gives_sequence_error_flag_and_data() {
        let mut report = [0u8; REPORT_LEN];
        report[..7].copy_from_slice(&[0x20, 9, 3, 0, 0xAA, 0xBB, 0xCC]);
        let (header, data) = parse_reply(&report).expect("valid");
        assert_eq!(
            header,
            ReplyHeader {
                seq: 9,
                error: true,
                length: 3
            }
        );
        assert_eq!(data, &[0xAA, 0xBB, 0xCC]);
        assert!(parse_reply(&[0x00, 1, 0]).is_none(), "short");
        assert!(parse_reply(&[0x00, 1, 0x01, 0x02]).is_none(), "513 bytes");
    }

    #[test]
    fn connecting_wakes_selects_the_tpg_and_shows_black() {
        let lc = connected(LightCrafterConfig {
            led_currents: Some([0x60, 0x70, 0x80]),
            ..config()
        });
        assert_eq!(
            lc.transport().messages(),
            vec![
                (0x02, 0x00, vec![0]),                // power: normal operation
                (0x1A, 0x24, vec![0]),                // pattern sequence stop
                (0x1A, 0x1B, vec![0]),                // video mode
                (0x1A, 0x00, vec![1]),                // source: test pattern
                (0x1A, 0x0E, vec![0]),                // degamma off
                (0x0B, 0x01, vec![0x60, 0x70, 0x80]), // LED currents
                (0x1A, 0x07, vec![0]),                // LEDs off
                (0x12, 0x04, vec![0; 12]),            // colour 0
                (0x12, 0x03, vec![0]),                // solid field
            ]
        );
        // Sequence bytes count up from 0.
        let seqs: Vec<u8> = lc.transport().sent.iter().map(|r| r[1]).collect();
        assert_eq!(seqs, (0..9).collect::<Vec<u8>>());
        assert_eq!(lc.pattern(), ProjectorPattern::Black);
        assert_eq!(lc.resolution(), (912, 1140));
        assert_eq!(lc.id(), "usb:0451:6401");
    }

    #[test]
    fn a_uniform_level_is_a_linear_10_bit_solid_field_with_leds_on() {
        let mut lc = connected(config());
        let before = lc.transport().sent.len();
        let half = Level::new(0.5).expect("level");
        lc.show(ProjectorPattern::Uniform(half))
            .expect("acknowledged");
        let msgs = lc.transport().messages();
        assert_eq!(
            &msgs[msgs.len() - 3..],
            &[
                (
                    0x12,
                    0x04,
                    vec![0x00, 0x02, 0x00, 0x02, 0x00, 0x02, 0, 0, 0, 0, 0, 0]
                ),
                (0x12, 0x03, vec![0]),
                (0x1A, 0x07, vec![0x08]),
            ],
            "512 = round(0.5 × 1023) on R, G, B"
        );
        assert_eq!(lc.transport().sent.len(), before + 3);
        assert_eq!(lc.pattern(), ProjectorPattern::Uniform(half));
        assert_eq!(tpg_code(Level::FULL), 0x3FF);
        assert_eq!(tpg_code(Level::ZERO), 0);
        assert_eq!(tpg_code(Level::new(0.25).expect("level")), 256);
    }

    #[test]
    fn black_without_leds_off_is_colour_zero_under_the_sequencer() {
        let lc = connected(LightCrafterConfig {
            black_leds_off: false,
            ..config()
        });
        let msgs = lc.transport().messages();
        assert_eq!(
            &msgs[msgs.len() - 3..],
            &[
                (0x12, 0x04, vec![0; 12]),
                (0x12, 0x03, vec![0]),
                (0x1A, 0x07, vec![0x08]),
            ]
        );
    }

    #[test]
    fn a_checker_is_refused_with_the_periods_it_can_show_and_the_alternative() {
        let mut lc = connected(config());
        let sent = lc.transport().sent.len();
        let err = lc.show(checker(16, 0.0, 1.0)).expect_err("not exact");
        let text = err.to_string();
        assert!(matches!(err, DriverError::InvalidSetting { .. }), "{text}");
        for want in [
            "usb:0451:6401",
            "period 16 px",
            "912x1140",
            "none",
            "DRM/KMS",
        ] {
            assert!(text.contains(want), "`{want}` missing: {text}");
        }
        assert_eq!(lc.transport().sent.len(), sent, "nothing was sent");
        assert_eq!(lc.pattern(), ProjectorPattern::Black, "unchanged");
        // The capture plan asks first, so it never plans what fails here.
        assert!(!lc.can_show(&checker(16, 0.0, 1.0)));
        assert!(lc.can_show(&checker(16, 1.0, 1.0)));
        assert!(lc.can_show(&ProjectorPattern::Black));
        assert_eq!(lc.transport().sent.len(), sent, "asking sends nothing");
        // A checker whose two levels are equal is a uniform field.
        lc.show(checker(16, 1.0, 1.0)).expect("uniform");
        let msgs = lc.transport().messages();
        assert_eq!(msgs[msgs.len() - 3].2[..2], [0xFF, 0x03]);
    }

    #[test]
    fn an_error_flag_reply_names_the_command_and_payload() {
        let mut lc = connected(config());
        lc.transport.script = vec![Answer::Nack].into();
        let err = lc
            .show(ProjectorPattern::Uniform(Level::FULL))
            .expect_err("nack");
        let text = err.to_string();
        assert!(matches!(err, DriverError::InvalidSetting { .. }), "{text}");
        assert!(text.contains("usb:0451:6401"), "{text}");
        assert!(text.contains("test pattern colour"), "{text}");
        assert!(text.contains("CMD2 0x12, CMD3 0x04"), "{text}");
        assert!(text.contains("FF 03 FF 03 FF 03"), "{text}");
        assert_eq!(lc.pattern(), ProjectorPattern::Black, "not shown");
    }

    #[test]
    fn no_reply_is_a_timeout_naming_the_device_and_command() {
        let mut lc = connected(config());
        lc.transport.script = vec![Answer::Silent].into();
        let err = lc
            .show(ProjectorPattern::Uniform(Level::FULL))
            .expect_err("silent");
        let text = err.to_string();
        match &err {
            DriverError::Io { source, .. } => {
                assert_eq!(source.kind(), io::ErrorKind::TimedOut)
            }
            other => panic!("expected a timed-out Io error, got {other:?}"),
        }
        assert!(text.contains("usb:0451:6401"), "{text}");
        assert!(text.contains("test pattern colour"), "{text}");
        assert!(text.contains("50ms"), "{text}");
    }

    #[test]
    fn a_stale_reply_is_skipped_and_a_wrong_sequence_alone_times_out() {
        let mut lc = connected(config());
        lc.transport.script = vec![Answer::StaleThenAck].into();
        lc.show(ProjectorPattern::Uniform(Level::FULL))
            .expect("the right reply follows the stale one");
        assert_eq!(lc.transport().inbox.len(), 0, "both replies consumed");
        lc.transport.script = vec![Answer::WrongSeq].into();
        let err = lc
            .show(ProjectorPattern::Black)
            .expect_err("never answered");
        assert!(
            matches!(&err, DriverError::Io { source, .. } if source.kind() == io::ErrorKind::TimedOut),
            "{err:?}"
        );
    }

    #[test]
    fn a_malformed_reply_is_reported_with_its_bytes() {
        let mut lc = connected(config());
        lc.transport.script = vec![Answer::Garbage(vec![0x00, 0x01])].into();
        let err = lc.show(ProjectorPattern::Black).expect_err("garbage");
        let text = err.to_string();
        assert!(matches!(err, DriverError::Malformed { .. }), "{text}");
        assert!(text.contains("[00 01]"), "{text}");
    }

    #[test]
    fn a_read_returns_the_reply_data_across_reports() {
        let mut lc = connected(config());
        let version: Vec<u8> = (1..=16).collect();
        lc.transport.script = vec![Answer::Data(version.clone())].into();
        assert_eq!(lc.read(cmd::VERSION, &[]).expect("data"), version);
        let long: Vec<u8> = (0..100).collect();
        lc.transport.script = vec![Answer::Data(long.clone())].into();
        assert_eq!(lc.read(cmd::VERSION, &[]).expect("data"), long);
        lc.transport.script = vec![Answer::Ack].into();
        let err = lc.read(cmd::MAIN_STATUS, &[]).expect_err("empty");
        assert!(matches!(err, DriverError::Malformed { .. }), "{err}");
    }

    #[test]
    fn show_waits_the_settle_time_after_the_acknowledgements() {
        let mut lc = connected(config());
        lc.config.settle = Duration::from_millis(30);
        let start = Instant::now();
        lc.show(ProjectorPattern::Uniform(Level::FULL)).expect("ok");
        assert!(start.elapsed() >= Duration::from_millis(30));
    }
}
