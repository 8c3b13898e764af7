//! A USB footswitch read raw through libusb (feature `hardware`), the
//! alternative to the evdev reader (`crate::footswitch::evdev`) for
//! machines where the pedal has no usable evdev node (no permission on
//! /dev/input, or a pedal whose keys would otherwise type into the
//! desktop): it detaches usbhid from the pedal's keyboard interface, reads
//! its HID reports from the interrupt IN endpoint and turns them into
//! presses with `super::hid_keys` (keys as Linux key codes, what `evtest`
//! shows, empty = any key; a press is a key going down, not a held or
//! released one).
//!
//! Unplugging does not kill the daemon: a read that fails because the
//! device is gone drops the handle, and `wait` keeps trying to reopen it
//! every 250 ms until its timeout, then returns `Ok(None)` like a timeout
//! without a press. Only a device that was never there at `open` is an
//! error.
//!
//! Boundaries: one pedal, one interface; the [`Trigger`] trait is all the
//! sequencer sees.

use super::hid_keys::PressDetector;
use crate::error::DriverError;
use crate::traits::{monotonic_now, Press, Trigger};
use crate::usb::device::{self, HidInterface, PROTOCOL_KEYBOARD, SUBCLASS_BOOT};
use crate::usb::UsbId;
use rusb::{Context, DeviceHandle};
use std::time::{Duration, Instant};

/// How often an unplugged pedal is looked for.
const REOPEN_POLL: Duration = Duration::from_millis(250);
/// HID class request SET_PROTOCOL, value 0 = boot protocol.
const REQUEST_TYPE_CLASS_INTERFACE_OUT: u8 = 0x21;
const HID_SET_PROTOCOL: u8 = 0x0B;
const BOOT_PROTOCOL: u16 = 0;
const CONTROL_TIMEOUT: Duration = Duration::from_millis(500);
/// Larger than any report we parse, so an odd one is seen whole.
const READ_BUF: usize = 64;

struct Open {
    handle: DeviceHandle<Context>,
    interface: HidInterface,
}

impl Drop for Open {
    fn drop(&mut self) {
        // Gives the interface back to usbhid (auto-detach reattaches it).
        let _ = self.handle.release_interface(self.interface.number);
    }
}

/// A footswitch on raw USB.
pub struct UsbFootswitch {
    id: UsbId,
    name: String,
    context: Context,
    detector: PressDetector,
    open: Option<Open>,
}

impl UsbFootswitch {
    /// Opens the first device with `id` and claims its keyboard interface;
    /// `keys` are Linux key codes (empty: any key).
    pub fn open(id: UsbId, keys: Vec<u16>) -> Result<UsbFootswitch, DriverError> {
        let context = device::context(id)?;
        let open = open_pedal(&context, id)?.ok_or_else(|| device::not_found(id, "footswitch"))?;
        Ok(UsbFootswitch {
            id,
            name: id.device_name(),
            context,
            detector: PressDetector::new(keys),
            open: Some(open),
        })
    }

    fn reopen(&mut self) -> bool {
        // A fresh context scans sysfs anew: a long-lived one learns of a
        // replugged device only from netlink uevents, which never arrive
        // inside systemd's PrivateNetwork namespace.
        match device::context(self.id) {
            Ok(context) => self.context = context,
            Err(e) => {
                tracing::debug!("{}: a new USB context failed: {e}", self.name);
                return false;
            }
        }
        match open_pedal(&self.context, self.id) {
            Ok(Some(open)) => {
                tracing::info!("{}: footswitch is back", self.name);
                self.open = Some(open);
                self.detector.reset();
                true
            }
            Ok(None) => false,
            Err(e) => {
                tracing::debug!("{}: reopening failed: {e}", self.name);
                false
            }
        }
    }
}

/// Finds, opens and claims the pedal; `Ok(None)` when it is not plugged
/// in.
fn open_pedal(context: &Context, id: UsbId) -> Result<Option<Open>, DriverError> {
    let Some(found) =
        device::find(context, id).map_err(|e| device::usb_error(id, "listing USB devices", e))?
    else {
        return Ok(None);
    };
    let interfaces = device::hid_interfaces(&found)
        .map_err(|e| device::usb_error(id, "reading the USB descriptors", e))?;
    // The boot keyboard interface if there is one (pedals often add a
    // mouse or vendor interface), else the first HID interface.
    let interface = interfaces
        .iter()
        .find(|i| i.sub_class == SUBCLASS_BOOT && i.protocol == PROTOCOL_KEYBOARD)
        .or(interfaces.first())
        .copied()
        .ok_or_else(|| DriverError::InvalidSetting {
            device: id.device_name(),
            reason: "expected a HID interface with an interrupt IN endpoint (a keyboard-like \
                     footswitch); this device has none"
                .to_string(),
        })?;
    let handle = device::open_claimed(&found, interface.number)
        .map_err(|e| device::usb_error(id, "opening and claiming the footswitch", e))?;
    if interface.sub_class == SUBCLASS_BOOT {
        // The boot protocol fixes the 8-byte report layout; a pedal that
        // refuses keeps its own, which hid_keys also reads.
        if let Err(e) = handle.write_control(
            REQUEST_TYPE_CLASS_INTERFACE_OUT,
            HID_SET_PROTOCOL,
            BOOT_PROTOCOL,
            interface.number as u16,
            &[],
            CONTROL_TIMEOUT,
        ) {
            tracing::debug!("{}: SET_PROTOCOL(boot) failed: {e}", id.device_name());
        }
    }
    Ok(Some(Open { handle, interface }))
}

impl Trigger for UsbFootswitch {
    /// `usb:VVVV:PPPP`.
    fn id(&self) -> &str {
        &self.name
    }

    /// The next press, or `None` after `timeout`, also when the pedal is
    /// unplugged and not back by then.
    fn wait(&mut self, timeout: Duration) -> Result<Option<Press>, DriverError> {
        let deadline = Instant::now() + timeout;
        let mut buf = [0u8; READ_BUF];
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let Some(open) = self.open.as_ref() else {
                if self.reopen() {
                    continue;
                }
                if left.is_zero() {
                    return Ok(None);
                }
                std::thread::sleep(left.min(REOPEN_POLL));
                continue;
            };
            if left.is_zero() {
                return Ok(None);
            }
            // libusb reads a zero timeout as "wait forever".
            let read = open.handle.read_interrupt(
                open.interface.in_endpoint,
                &mut buf,
                left.max(Duration::from_millis(1)),
            );
            match read {
                Ok(n) => match self.detector.feed(&buf[..n]) {
                    Ok(presses) if !presses.is_empty() => {
                        return Ok(Some(Press {
                            timestamp: monotonic_now(),
                        }))
                    }
                    Ok(_) => {}
                    Err(e) => tracing::warn!("{}: ignoring {e}", self.name),
                },
                Err(rusb::Error::Timeout) => return Ok(None),
                Err(rusb::Error::Interrupted) | Err(rusb::Error::Overflow) => {}
                Err(rusb::Error::NoDevice) | Err(rusb::Error::Io) | Err(rusb::Error::Pipe) => {
                    tracing::warn!("{}: footswitch disconnected", self.name);
                    self.open = None;
                }
                Err(e) => {
                    return Err(device::usb_error(
                        self.id,
                        "reading the footswitch's key reports",
                        e,
                    ))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// PCsensor FootSwitch, the common single and triple pedals.
    const PCSENSOR: UsbId = UsbId {
        vendor: 0x0c45,
        product: 0x7403,
    };

    #[test]
    fn a_real_footswitch_opens_and_waits() {
        if !device::present(PCSENSOR) {
            println!("skipped: no USB footswitch");
            return;
        }
        let mut pedal = UsbFootswitch::open(PCSENSOR, vec![]).expect("opens");
        assert_eq!(pedal.id(), "usb:0c45:7403");
        let start = Instant::now();
        // Nobody presses it during the test.
        let got = pedal.wait(Duration::from_millis(300)).expect("waits");
        assert!(got.is_none() || start.elapsed() <= Duration::from_millis(400));
    }

    #[test]
    fn a_footswitch_that_is_not_plugged_in_names_its_id_lsusb_and_udev() {
        let id = UsbId {
            vendor: 0xFFFE,
            product: 0x0002,
        };
        let err = UsbFootswitch::open(id, vec![])
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("usb:fffe:0002"), "{err}");
        if !err.contains("starting libusb") {
            assert!(err.contains("lsusb") && err.contains("udev"), "{err}");
        }
    }
}
