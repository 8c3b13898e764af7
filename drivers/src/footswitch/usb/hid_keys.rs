//! HID keyboard input reports, as a USB footswitch sends them, turned into
//! Linux key codes (the numbers `evtest` shows, so a footswitch is
//! configured the same way whether it is read through evdev or raw USB),
//! and the rising-edge rule that makes a report a press.
//!
//! The report layout is the HID 1.11 boot keyboard report (appendix B.1):
//! byte 0 the modifier bitmap (bit 0 left Ctrl … bit 7 right GUI), byte 1
//! reserved, bytes 2..8 up to six key usages of the Keyboard/Keypad page
//! (0 = no key). The raw footswitch driver asks the device for the boot
//! protocol (SET_PROTOCOL), which fixes that layout; two variants are still
//! accepted because some pedals ignore SET_PROTOCOL:
//! - 9 bytes: the same report behind a report id (devices whose report
//!   descriptor declares ids, usually keyboard + consumer composites);
//! - 1 to 7 bytes: the boot report cut short: modifiers, reserved, then as
//!   many key slots as the device sends (pedals that only ever hold one key
//!   send `[mod, 0, key]`).
//!
//! The usage → key code table is the kernel's `hid_keyboard[256]` in
//! `drivers/hid/hid-input.c` (torvalds/linux), copied entry by entry: `unk`
//! there is `KEY_UNKNOWN` (240) here, 0 means the kernel ignores the usage.
//! Modifier bits are usages 0xE0..=0xE7, so they go through the same table
//! (KEY_LEFTCTRL 29, KEY_LEFTSHIFT 42, KEY_LEFTALT 56, KEY_LEFTMETA 125,
//! KEY_RIGHTCTRL 97, KEY_RIGHTSHIFT 54, KEY_RIGHTALT 100, KEY_RIGHTMETA 126).
//!
//! Boundaries: pure byte parsing, no I/O; `super::reader` reads the
//! reports.

/// `KEY_UNKNOWN`, the kernel's `unk`.
const UNK: u8 = 240;

/// The kernel's `hid_keyboard[256]` (drivers/hid/hid-input.c): index = HID
/// usage on the Keyboard/Keypad page, value = Linux key code.
#[rustfmt::skip]
pub const HID_KEYBOARD: [u8; 256] = [
      0,  0,  0,  0, 30, 48, 46, 32, 18, 33, 34, 35, 23, 36, 37, 38,
     50, 49, 24, 25, 16, 19, 31, 20, 22, 47, 17, 45, 21, 44,  2,  3,
      4,  5,  6,  7,  8,  9, 10, 11, 28,  1, 14, 15, 57, 12, 13, 26,
     27, 43, 43, 39, 40, 41, 51, 52, 53, 58, 59, 60, 61, 62, 63, 64,
     65, 66, 67, 68, 87, 88, 99, 70,119,110,102,104,111,107,109,106,
    105,108,103, 69, 98, 55, 74, 78, 96, 79, 80, 81, 75, 76, 77, 71,
     72, 73, 82, 83, 86,127,116,117,183,184,185,186,187,188,189,190,
    191,192,193,194,134,138,130,132,128,129,131,137,133,135,136,113,
    115,114,UNK,UNK,UNK,121,UNK, 89, 93,124, 92, 94, 95,UNK,UNK,UNK,
    122,123, 90, 91, 85,UNK,UNK,UNK,UNK,UNK,UNK,UNK,111,UNK,UNK,UNK,
    UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,
    UNK,UNK,UNK,UNK,UNK,UNK,179,180,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,
    UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,
    UNK,UNK,UNK,UNK,UNK,UNK,UNK,UNK,111,UNK,UNK,UNK,UNK,UNK,UNK,UNK,
     29, 42, 56,125, 97, 54,100,126,164,166,165,163,161,115,114,113,
    150,158,159,128,136,177,178,176,142,152,173,140,UNK,UNK,UNK,UNK,
];

/// Usage 0x01, ErrorRollOver: the keyboard saw too many keys (phantom
/// state) and every slot carries it; 0x02 POSTFail and 0x03 ErrorUndefined
/// are the other error usages (HID Usage Tables, Keyboard page).
const FIRST_ERROR_USAGE: u8 = 0x01;
const LAST_ERROR_USAGE: u8 = 0x03;
/// The modifier bits are usages 0xE0 + bit.
const MODIFIER_USAGE_BASE: usize = 0xE0;
const BOOT_REPORT_LEN: usize = 8;

/// The Linux key code of a Keyboard-page usage; `None` where the kernel
/// ignores it (0 in its table).
pub fn usage_to_key(usage: u8) -> Option<u16> {
    match HID_KEYBOARD[usage as usize] {
        0 => None,
        code => Some(code as u16),
    }
}

/// What one input report says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum KeyReport {
    /// The keys held down now (Linux key codes, sorted, no duplicates).
    Down(Vec<u16>),
    /// ErrorRollOver or another error usage: the keyboard cannot tell which
    /// keys are down, so the previous state stands (as in the kernel).
    Phantom,
}

/// Why a report could not be read as a keyboard report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReportError {
    Empty,
    /// Longer than a boot report with a report id: some other layout
    /// (NKRO bitmap, vendor report) this parser does not know.
    TooLong(usize),
}

impl std::fmt::Display for ReportError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReportError::Empty => write!(f, "an empty input report"),
            ReportError::TooLong(n) => write!(
                f,
                "a {n}-byte input report; expected the 8-byte HID boot keyboard report \
                 (9 with a report id, or a shorter prefix of it)"
            ),
        }
    }
}

/// Reads one input report (see the module doc for the accepted layouts).
pub fn parse_report(report: &[u8]) -> Result<KeyReport, ReportError> {
    let boot = match report.len() {
        0 => return Err(ReportError::Empty),
        n if n <= BOOT_REPORT_LEN => report,
        n if n == BOOT_REPORT_LEN + 1 => &report[1..],
        n => return Err(ReportError::TooLong(n)),
    };
    let modifiers = boot[0];
    let slots = boot.get(2..).unwrap_or(&[]);
    if slots
        .iter()
        .any(|u| (FIRST_ERROR_USAGE..=LAST_ERROR_USAGE).contains(u))
    {
        return Ok(KeyReport::Phantom);
    }
    let mut down: Vec<u16> = (0..8)
        .filter(|bit| modifiers & (1 << bit) != 0)
        .filter_map(|bit| usage_to_key((MODIFIER_USAGE_BASE + bit) as u8))
        .chain(slots.iter().filter_map(|&u| usage_to_key(u)))
        .collect();
    down.sort_unstable();
    down.dedup();
    Ok(KeyReport::Down(down))
}

/// Turns a stream of reports into presses: a configured key that is down
/// in this report and was not in the previous one. Held keys (the device
/// repeats its report, or the host polls) and releases are not presses.
#[derive(Debug, Clone, Default)]
pub struct PressDetector {
    /// Key codes that count; empty: any key.
    keys: Vec<u16>,
    down: Vec<u16>,
}

impl PressDetector {
    pub fn new(keys: Vec<u16>) -> PressDetector {
        PressDetector {
            keys,
            down: Vec::new(),
        }
    }

    /// The configured keys newly down in `report`, in key-code order.
    pub fn feed(&mut self, report: &[u8]) -> Result<Vec<u16>, ReportError> {
        let now = match parse_report(report)? {
            KeyReport::Down(now) => now,
            KeyReport::Phantom => return Ok(Vec::new()),
        };
        let pressed = now
            .iter()
            .copied()
            .filter(|k| !self.down.contains(k))
            .filter(|k| self.keys.is_empty() || self.keys.contains(k))
            .collect();
        self.down = now;
        Ok(pressed)
    }

    /// Forgets which keys were down, for a reconnect: the first report of
    /// the reopened pedal is compared with nothing, so a pedal held through
    /// the replug counts once, as the fresh key-down evdev reports then.
    pub fn reset(&mut self) {
        self.down.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY_A: u16 = 30;
    const KEY_B: u16 = 48;
    const KEY_LEFTCTRL: u16 = 29;
    const KEY_LEFTSHIFT: u16 = 42;
    const KEY_RIGHTMETA: u16 = 126;
    const KEY_ENTER: u16 = 28;
    const KEY_PAGEDOWN: u16 = 109;
    const KEY_DELETE: u16 = 111;

    #[test]
    fn usages_map_like_the_kernel_table() {
        // Spot checks of hid_keyboard[] rows, one per kind of entry.
        assert_eq!(usage_to_key(0x04), Some(KEY_A)); // Keyboard a
        assert_eq!(usage_to_key(0x05), Some(KEY_B));
        assert_eq!(usage_to_key(0x1e), Some(2)); // 1 → KEY_1
        assert_eq!(usage_to_key(0x28), Some(KEY_ENTER));
        assert_eq!(usage_to_key(0x3a), Some(59)); // F1
        assert_eq!(usage_to_key(0x4e), Some(KEY_PAGEDOWN));
        assert_eq!(usage_to_key(0x68), Some(183)); // F13
        assert_eq!(usage_to_key(0x9c), Some(KEY_DELETE)); // Keyboard Clear
        assert_eq!(usage_to_key(0xd8), Some(KEY_DELETE)); // Keypad Clear
        assert_eq!(usage_to_key(0xb6), Some(179)); // Keypad ( → KEY_KPLEFTPAREN
        assert_eq!(usage_to_key(0x82), Some(240)); // unk → KEY_UNKNOWN
        assert_eq!(usage_to_key(0xe0), Some(KEY_LEFTCTRL));
        assert_eq!(usage_to_key(0xe7), Some(KEY_RIGHTMETA));
        assert_eq!(usage_to_key(0xfb), Some(140)); // KEY_CALC
        assert_eq!(usage_to_key(0x00), None);
        assert_eq!(usage_to_key(0x03), None);
        assert_eq!(HID_KEYBOARD.iter().filter(|&&c| c == UNK).count(), 82);
    }

    #[test]
    fn a_boot_report_gives_modifiers_and_keys_as_linux_codes() {
        // Left Ctrl + Left Shift held, `b` and `a` down (order in the slots
        // is the device's; the result is sorted).
        let report = [0x03, 0x00, 0x05, 0x04, 0, 0, 0, 0];
        assert_eq!(
            parse_report(&report),
            Ok(KeyReport::Down(vec![
                KEY_LEFTCTRL,
                KEY_A,
                KEY_LEFTSHIFT,
                KEY_B
            ]))
        );
        assert_eq!(
            parse_report(&[0; 8]),
            Ok(KeyReport::Down(vec![])),
            "all released"
        );
    }

    #[test]
    fn a_report_id_prefix_and_short_reports_are_understood() {
        // Report id 1 in front of the boot report.
        let with_id = [0x01, 0x00, 0x00, 0x4e, 0, 0, 0, 0, 0];
        assert_eq!(
            parse_report(&with_id),
            Ok(KeyReport::Down(vec![KEY_PAGEDOWN]))
        );
        // A pedal that sends only [modifiers, reserved, key].
        assert_eq!(
            parse_report(&[0x00, 0x00, 0x05]),
            Ok(KeyReport::Down(vec![KEY_B]))
        );
        // Modifier-only pedal (right GUI).
        assert_eq!(
            parse_report(&[0x80]),
            Ok(KeyReport::Down(vec![KEY_RIGHTMETA]))
        );
        assert_eq!(parse_report(&[]), Err(ReportError::Empty));
        assert_eq!(parse_report(&[0; 16]), Err(ReportError::TooLong(16)));
    }

    #[test]
    fn rollover_reports_keep_the_previous_state() {
        let rollover = [0x00, 0x00, 0x01, 0x01, 0x01, 0x01, 0x01, 0x01];
        assert_eq!(parse_report(&rollover), Ok(KeyReport::Phantom));
        let mut d = PressDetector::new(vec![]);
        assert_eq!(d.feed(&[0, 0, 0x04, 0, 0, 0, 0, 0]), Ok(vec![KEY_A]));
        assert_eq!(d.feed(&rollover), Ok(vec![]));
        // `a` was held through the rollover: not a new press.
        assert_eq!(d.feed(&[0, 0, 0x04, 0, 0, 0, 0, 0]), Ok(vec![]));
    }

    #[test]
    fn only_rising_edges_of_configured_keys_are_presses() {
        // A PCsensor-style pedal configured to send `b`: press, the
        // device re-sending the same report (held), release, press again.
        let b_down = [0x00, 0x00, 0x05, 0, 0, 0, 0, 0];
        let up = [0u8; 8];
        let mut d = PressDetector::new(vec![KEY_B]);
        assert_eq!(d.feed(&b_down), Ok(vec![KEY_B]));
        assert_eq!(d.feed(&b_down), Ok(vec![]), "held is not a press");
        assert_eq!(d.feed(&up), Ok(vec![]), "release is not a press");
        assert_eq!(d.feed(&b_down), Ok(vec![KEY_B]));
        // `a` pressed while `b` is held: not configured, and `b` is no new
        // press either.
        assert_eq!(d.feed(&[0, 0, 0x05, 0x04, 0, 0, 0, 0]), Ok(vec![]));
        // Slots reordered, same keys: nothing new.
        assert_eq!(d.feed(&[0, 0, 0x04, 0x05, 0, 0, 0, 0]), Ok(vec![]));
    }

    #[test]
    fn with_no_keys_configured_any_key_or_modifier_is_a_press() {
        let mut d = PressDetector::new(vec![]);
        assert_eq!(d.feed(&[0x01, 0, 0, 0, 0, 0, 0, 0]), Ok(vec![KEY_LEFTCTRL]));
        assert_eq!(
            d.feed(&[0x01, 0, 0x28, 0, 0, 0, 0, 0]),
            Ok(vec![KEY_ENTER]),
            "Ctrl still held, Enter new"
        );
        d.reset();
        assert_eq!(
            d.feed(&[0x01, 0, 0x28, 0, 0, 0, 0, 0]),
            Ok(vec![KEY_ENTER, KEY_LEFTCTRL]),
            "after a reconnect the first report is compared with nothing"
        );
    }
}
