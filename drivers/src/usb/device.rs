//! Finding, opening and claiming a USB HID interface through rusb, shared
//! by the LightCrafter's transport (`crate::projector::lightcrafter`) and
//! the raw footswitch (`crate::footswitch::usb`) (feature `hardware`).
//!
//! Boundaries: descriptors, claiming and error wording only; no protocol.

use crate::error::DriverError;
use crate::usb::id::UsbId;
use rusb::{Context, Device, DeviceHandle, Direction, TransferType, UsbContext};
use std::io;

/// USB interface class code of HID.
const CLASS_HID: u8 = 0x03;
/// HID subclass "boot interface" and its keyboard protocol.
pub(crate) const SUBCLASS_BOOT: u8 = 0x01;
pub(crate) const PROTOCOL_KEYBOARD: u8 = 0x01;

/// A HID interface's number and interrupt endpoints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct HidInterface {
    pub number: u8,
    pub sub_class: u8,
    pub protocol: u8,
    pub in_endpoint: u8,
    /// HID allows output reports over the control pipe instead.
    pub out_endpoint: Option<u8>,
}

/// A libusb context, or an error naming the device and the likely cause.
pub(crate) fn context(id: UsbId) -> Result<Context, DriverError> {
    Context::new().map_err(|e| {
        DriverError::io(
            &id.device_name(),
            "starting libusb",
            io::Error::other(format!(
                "{e}: libusb found no USB bus to use (is /dev/bus/usb there? in a container, \
                 pass the USB bus through)"
            )),
        )
    })
}

/// The first device with `id`, if any is plugged in.
pub(crate) fn find(context: &Context, id: UsbId) -> rusb::Result<Option<Device<Context>>> {
    for device in context.devices()?.iter() {
        let Ok(desc) = device.device_descriptor() else {
            continue;
        };
        if desc.vendor_id() == id.vendor && desc.product_id() == id.product {
            return Ok(Some(device));
        }
    }
    Ok(None)
}

/// The HID interfaces (first alternate setting) with an interrupt IN
/// endpoint, in interface order.
pub(crate) fn hid_interfaces(device: &Device<Context>) -> rusb::Result<Vec<HidInterface>> {
    let config = device.active_config_descriptor()?;
    let mut out = Vec::new();
    for interface in config.interfaces() {
        let Some(alt) = interface.descriptors().next() else {
            continue;
        };
        if alt.class_code() != CLASS_HID {
            continue;
        }
        let endpoint = |dir: Direction| {
            alt.endpoint_descriptors()
                .find(|e| e.transfer_type() == TransferType::Interrupt && e.direction() == dir)
                .map(|e| e.address())
        };
        if let Some(in_endpoint) = endpoint(Direction::In) {
            out.push(HidInterface {
                number: alt.interface_number(),
                sub_class: alt.sub_class_code(),
                protocol: alt.protocol_code(),
                in_endpoint,
                out_endpoint: endpoint(Direction::Out),
            });
        }
    }
    Ok(out)
}

/// Opens `device` and claims `interface`, letting libusb detach the
/// kernel's usbhid driver (and give it back when the interface is
/// released).
pub(crate) fn open_claimed(
    device: &Device<Context>,
    interface: u8,
) -> rusb::Result<DeviceHandle<Context>> {
    let handle = device.open()?;
    // Not supported off Linux; claiming then fails clearly if a driver
    // holds the interface.
    match handle.set_auto_detach_kernel_driver(true) {
        Ok(()) | Err(rusb::Error::NotSupported) => {}
        Err(e) => return Err(e),
    }
    handle.claim_interface(interface)?;
    Ok(handle)
}

/// What to do about a rusb error, for the operator.
fn hint(e: rusb::Error, id: UsbId) -> String {
    match e {
        rusb::Error::Access => format!(
            "no permission to open it: add a udev rule such as SUBSYSTEM==\"usb\", \
             ATTRS{{idVendor}}==\"{:04x}\", ATTRS{{idProduct}}==\"{:04x}\", MODE=\"0660\", \
             GROUP=\"plugdev\" and replug it",
            id.vendor, id.product
        ),
        rusb::Error::Busy => "another program has claimed the interface".to_string(),
        rusb::Error::NoDevice => "it was unplugged".to_string(),
        _ => "check the cable and `lsusb`".to_string(),
    }
}

/// A rusb error as the driver error naming the device.
pub(crate) fn usb_error(id: UsbId, action: &'static str, e: rusb::Error) -> DriverError {
    let kind = match e {
        rusb::Error::Access => io::ErrorKind::PermissionDenied,
        rusb::Error::Timeout => io::ErrorKind::TimedOut,
        rusb::Error::NoDevice | rusb::Error::NotFound => io::ErrorKind::NotFound,
        rusb::Error::Interrupted => io::ErrorKind::Interrupted,
        _ => io::ErrorKind::Other,
    };
    DriverError::io(
        &id.device_name(),
        action,
        io::Error::new(kind, format!("{e} ({})", hint(e, id))),
    )
}

/// The error for a device that is not on the bus at all.
pub(crate) fn not_found(id: UsbId, what: &str) -> DriverError {
    DriverError::io(
        &id.device_name(),
        "finding the device",
        io::Error::new(
            io::ErrorKind::NotFound,
            format!(
                "no {what} with USB id {id} is plugged in: check `lsusb` for its id and the \
                 cable; if `lsusb` lists it, a udev rule must give this user access \
                 (SUBSYSTEM==\"usb\", ATTRS{{idVendor}}==\"{:04x}\", ATTRS{{idProduct}}==\"{:04x}\", \
                 MODE=\"0660\", GROUP=\"plugdev\")",
                id.vendor, id.product
            ),
        ),
    )
}

/// Whether a device with `id` is on the bus (for hardware tests).
pub fn present(id: UsbId) -> bool {
    Context::new()
        .ok()
        .and_then(|c| find(&c, id).ok().flatten())
        .is_some()
}
