//! The LightCrafter's HID command interface over libusb (rusb), feature
//! `hardware`: 64-byte reports on the interrupt endpoints of interface 0,
//! as pycrafter4500 talks to it, with the kernel's usbhid detached while
//! the projector is open.
//!
//! Boundaries: reports and timeouts only; the protocol is `super`'s, and
//! finding, opening and claiming the interface is `crate::usb`'s.

use super::{HidTransport, LightCrafter, LightCrafterConfig, REPORT_LEN};
use crate::error::DriverError;
use crate::usb::device::{self, HidInterface};
use crate::usb::UsbId;
use rusb::{Context, DeviceHandle};
use std::io;
use std::time::Duration;

/// The controller's command interface.
const COMMAND_INTERFACE: u8 = 0;
/// How long one report may take to go out.
const WRITE_TIMEOUT: Duration = Duration::from_secs(1);
/// HID class request SET_REPORT, output report type (2) in wValue's high
/// byte, for devices without an interrupt OUT endpoint.
const REQUEST_TYPE_CLASS_INTERFACE_OUT: u8 = 0x21;
const HID_SET_REPORT: u8 = 0x09;
const OUTPUT_REPORT: u16 = 0x0200;

/// The LightCrafter's interface 0, claimed.
pub struct RusbHid {
    name: String,
    handle: DeviceHandle<Context>,
    interface: HidInterface,
}

impl RusbHid {
    /// Finds the device with `id`, detaches usbhid and claims interface 0.
    pub fn open(id: UsbId) -> Result<RusbHid, DriverError> {
        let context = device::context(id)?;
        let found = device::find(&context, id)
            .map_err(|e| device::usb_error(id, "listing USB devices", e))?
            .ok_or_else(|| device::not_found(id, "LightCrafter"))?;
        let interfaces = device::hid_interfaces(&found)
            .map_err(|e| device::usb_error(id, "reading the USB descriptors", e))?;
        let interface = interfaces
            .into_iter()
            .find(|i| i.number == COMMAND_INTERFACE)
            .ok_or_else(|| DriverError::InvalidSetting {
                device: id.device_name(),
                reason: format!(
                    "expected a HID interface {COMMAND_INTERFACE} with an interrupt IN \
                     endpoint (the DLPC350 command interface); is {id} a LightCrafter 4500?"
                ),
            })?;
        let handle = device::open_claimed(&found, interface.number)
            .map_err(|e| device::usb_error(id, "opening and claiming the LightCrafter", e))?;
        Ok(RusbHid {
            name: id.device_name(),
            handle,
            interface,
        })
    }

    fn io_error(&self, e: rusb::Error) -> io::Error {
        let kind = match e {
            rusb::Error::NoDevice => io::ErrorKind::NotConnected,
            rusb::Error::Timeout => io::ErrorKind::TimedOut,
            _ => io::ErrorKind::Other,
        };
        io::Error::new(kind, format!("{}: {e}", self.name))
    }
}

impl HidTransport for RusbHid {
    fn name(&self) -> &str {
        &self.name
    }

    fn write_report(&mut self, report: &[u8; REPORT_LEN]) -> io::Result<()> {
        let written = match self.interface.out_endpoint {
            Some(ep) => self.handle.write_interrupt(ep, report, WRITE_TIMEOUT),
            None => self.handle.write_control(
                REQUEST_TYPE_CLASS_INTERFACE_OUT,
                HID_SET_REPORT,
                OUTPUT_REPORT,
                self.interface.number as u16,
                report,
                WRITE_TIMEOUT,
            ),
        }
        .map_err(|e| self.io_error(e))?;
        if written != REPORT_LEN {
            return Err(io::Error::new(
                io::ErrorKind::WriteZero,
                format!("wrote {written} of {REPORT_LEN} bytes of a report"),
            ));
        }
        Ok(())
    }

    fn read_report(
        &mut self,
        buf: &mut [u8; REPORT_LEN],
        timeout: Duration,
    ) -> io::Result<Option<usize>> {
        // libusb reads a zero timeout as "wait forever".
        let timeout = timeout.max(Duration::from_millis(1));
        match self
            .handle
            .read_interrupt(self.interface.in_endpoint, buf, timeout)
        {
            Ok(n) => Ok(Some(n)),
            Err(rusb::Error::Timeout) => Ok(None),
            Err(e) => Err(self.io_error(e)),
        }
    }
}

impl Drop for RusbHid {
    fn drop(&mut self) {
        // Releasing hands the interface back to usbhid (auto-detach).
        let _ = self.handle.release_interface(self.interface.number);
    }
}

impl LightCrafter<RusbHid> {
    /// Opens the LightCrafter at `config.id` and connects (see
    /// [`LightCrafter::connect`]).
    pub fn open(config: LightCrafterConfig) -> Result<LightCrafter<RusbHid>, DriverError> {
        let transport = RusbHid::open(config.id)?;
        LightCrafter::connect(transport, config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::projector::lightcrafter::cmd;
    use crate::traits::{Level, Projector, ProjectorPattern};

    #[test]
    fn a_real_lightcrafter_shows_a_uniform_level_and_black() {
        let id = UsbId::LIGHTCRAFTER_4500;
        if !device::present(id) {
            println!("skipped: no LightCrafter (0451:6401) on USB");
            return;
        }
        let mut lc = LightCrafter::open(LightCrafterConfig::default()).expect("opens");
        assert_eq!(lc.resolution(), (912, 1140));
        let version = lc.read(cmd::VERSION, &[]).expect("version");
        assert!(version.len() >= 16, "{version:?}");
        let half = Level::new(0.5).expect("level");
        lc.show(ProjectorPattern::Uniform(half)).expect("uniform");
        assert_eq!(lc.pattern(), ProjectorPattern::Uniform(half));
        lc.show(ProjectorPattern::Black).expect("black");
    }

    #[test]
    fn a_missing_lightcrafter_is_an_error_naming_the_id_and_lsusb() {
        // An id no device has.
        let id = UsbId {
            vendor: 0xFFFE,
            product: 0x0001,
        };
        let err = RusbHid::open(id)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(err.contains("usb:fffe:0001"), "{err}");
        assert!(err.contains("lsusb") || err.contains("libusb"), "{err}");
    }
}
