//! USB footswitches: they present as HID keyboards, so they are read
//! through evdev (`/dev/input/by-id/...-event-kbd`) with an exclusive grab
//! (`EVIOCGRAB`), which keeps their key presses out of the desktop and the
//! terminal. An unplugged footswitch is reopened (and grabbed again) when
//! it comes back.
//!
//! Boundaries: Linux evdev through `libc` only (no system library, so this
//! builds without the `hardware` feature); the [`Trigger`] trait is all the
//! sequencer sees.

use crate::error::DriverError;
use crate::traits::{monotonic_now, Press, Trigger};
use std::fs::File;
use std::io::Read;
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

/// `_IOW('E', 0x90, int)`: grab or release a device exclusively.
const EVIOCGRAB: libc::c_ulong = 0x4004_4590;
const EV_KEY: u16 = 0x01;
/// Key event values: 0 release, 1 press, 2 autorepeat.
const KEY_PRESSED: i32 = 1;

/// A footswitch on an evdev node.
pub struct EvdevFootswitch {
    path: String,
    /// Key codes that count as a press; empty: any key.
    keys: Vec<u16>,
    file: Option<File>,
    pending: Vec<u8>,
}

impl EvdevFootswitch {
    /// Opens and grabs `path` (prefer `/dev/input/by-id/...-event-kbd`).
    pub fn open(path: &str, keys: Vec<u16>) -> Result<EvdevFootswitch, DriverError> {
        let file = open_grabbed(path)?;
        Ok(EvdevFootswitch {
            path: path.to_string(),
            keys,
            file: Some(file),
            pending: Vec::new(),
        })
    }
}

fn open_grabbed(path: &str) -> Result<File, DriverError> {
    let file = File::open(path).map_err(|e| DriverError::io(path, "opening the footswitch", e))?;
    // SAFETY: EVIOCGRAB takes an int argument by value on a valid fd.
    let rc = unsafe { libc::ioctl(file.as_raw_fd(), EVIOCGRAB as _, 1 as libc::c_int) };
    if rc != 0 {
        return Err(DriverError::io(
            path,
            "grabbing the footswitch (another program holds it?)",
            std::io::Error::last_os_error(),
        ));
    }
    Ok(file)
}

/// The key presses (value 1 of `EV_KEY`) among whole `input_event` records
/// in `bytes`; returns them and how many bytes were consumed.
pub fn key_presses(bytes: &[u8], keys: &[u16]) -> (Vec<u16>, usize) {
    let size = std::mem::size_of::<libc::input_event>();
    let mut out = Vec::new();
    let whole = bytes.len() / size * size;
    for rec in bytes[..whole].chunks_exact(size) {
        // The record ends with type (u16), code (u16), value (i32) after the
        // timeval, on every Linux ABI.
        let tail = &rec[size - 8..];
        let typ = u16::from_ne_bytes([tail[0], tail[1]]);
        let code = u16::from_ne_bytes([tail[2], tail[3]]);
        let value = i32::from_ne_bytes([tail[4], tail[5], tail[6], tail[7]]);
        if typ == EV_KEY && value == KEY_PRESSED && (keys.is_empty() || keys.contains(&code)) {
            out.push(code);
        }
    }
    (out, whole)
}

impl Trigger for EvdevFootswitch {
    fn id(&self) -> &str {
        &self.path
    }

    /// A press, `None` after `timeout`, or `Disconnected` when the switch was
    /// unplugged and did not come back within `timeout`.
    fn wait(&mut self, timeout: Duration) -> Result<Option<Press>, DriverError> {
        let deadline = Instant::now() + timeout;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(file) = self.file.as_mut() else {
                match open_grabbed(&self.path) {
                    Ok(f) => {
                        tracing::info!("{}: footswitch is back", self.path);
                        self.file = Some(f);
                        self.pending.clear();
                        continue;
                    }
                    Err(_) if left.is_zero() => {
                        return Err(DriverError::Disconnected {
                            device: self.path.clone(),
                            waited: timeout,
                        })
                    }
                    Err(_) => {
                        std::thread::sleep(left.min(Duration::from_millis(200)));
                        continue;
                    }
                }
            };
            let mut pfd = libc::pollfd {
                fd: file.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            let ms = left.as_millis().min(i32::MAX as u128) as libc::c_int;
            // SAFETY: one valid pollfd.
            let n = unsafe { libc::poll(&mut pfd, 1, ms) };
            if n == 0 {
                return Ok(None);
            }
            if n < 0 && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted {
                // A signal (SIGTERM on stop) is no unplug: poll again.
                continue;
            }
            let mut buf = [0u8; 24 * 16];
            match (n > 0).then(|| file.read(&mut buf)) {
                Some(Ok(r)) if r > 0 => {
                    self.pending.extend_from_slice(&buf[..r]);
                    let (presses, used) = key_presses(&self.pending, &self.keys);
                    self.pending.drain(..used);
                    if !presses.is_empty() {
                        return Ok(Some(Press {
                            timestamp: monotonic_now(),
                        }));
                    }
                }
                _ => {
                    // ENODEV / EOF / POLLERR: unplugged. Reopen on the next
                    // pass, when udev has recreated the node.
                    tracing::warn!("{}: footswitch disconnected", self.path);
                    self.file = None;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn event(typ: u16, code: u16, value: i32) -> Vec<u8> {
        let size = std::mem::size_of::<libc::input_event>();
        let mut rec = vec![0u8; size - 8];
        rec.extend_from_slice(&typ.to_ne_bytes());
        rec.extend_from_slice(&code.to_ne_bytes());
        rec.extend_from_slice(&value.to_ne_bytes());
        rec
    }

    #[test]
    fn only_key_presses_of_the_chosen_keys_count() {
        const KEY_B: u16 = 48;
        const KEY_A: u16 = 30;
        let mut bytes = Vec::new();
        bytes.extend(event(0x04, 4, 458757)); // EV_MSC scan code
        bytes.extend(event(EV_KEY, KEY_B, 1)); // press
        bytes.extend(event(0, 0, 0)); // EV_SYN
        bytes.extend(event(EV_KEY, KEY_B, 2)); // autorepeat
        bytes.extend(event(EV_KEY, KEY_B, 0)); // release
        bytes.extend(event(EV_KEY, KEY_A, 1));
        let partial = bytes.len();
        bytes.extend(&event(EV_KEY, KEY_A, 1)[..5]);
        let (any, used) = key_presses(&bytes, &[]);
        assert_eq!(any, vec![KEY_B, KEY_A]);
        assert_eq!(used, partial, "a partial record waits for the rest");
        assert_eq!(key_presses(&bytes, &[KEY_A]).0, vec![KEY_A]);
    }

    #[test]
    fn a_missing_footswitch_names_its_path() {
        let err =
            EvdevFootswitch::open("/dev/input/by-id/usb-no-such-footswitch-event-kbd", vec![])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
        assert!(err.contains("usb-no-such-footswitch"), "{err}");
    }
}
