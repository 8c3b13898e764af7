//! USB plumbing through libusb that the USB devices of two roles share:
//! the LightCrafter projector (`crate::projector::lightcrafter`) and the
//! raw footswitch (`crate::footswitch::usb`).
//!
//! - [`id`]: [`UsbId`], `VVVV:PPPP` as `lsusb` prints it and as the
//!   configuration names a USB device;
//! - `device` (feature `hardware`): finding a device by id, its HID
//!   interfaces, opening and claiming one, and error messages that name the
//!   device and say what to do (`lsusb`, a udev rule); `present` for
//!   hardware tests.
//!
//! Why a module of its own: both roles find, open and claim a HID
//! interface the same way and word its errors the same way, and the
//! configuration names both by [`UsbId`]; kept here, the roles depend on
//! this plumbing and not on each other, and neither knows the other's
//! protocol. What is one device's own (the LightCrafter's report
//! transport, the footswitch's report reader) stays with its role.
//!
//! Boundaries: ids, descriptors, claiming and error wording; no device
//! protocol. [`UsbId`] is pure and builds in the default build; only the
//! code that touches libusb needs `hardware`.
//!
//! Crate choice: `rusb` with `vendored` builds libusb from source, so the
//! scanner PC needs no libusb package, and libusb can detach the kernel's
//! usbhid driver from an interface while we hold it (and give it back on
//! release), which hidraw-only crates cannot.

#[cfg(feature = "hardware")]
pub(crate) mod device;
pub mod id;

#[cfg(feature = "hardware")]
pub use device::present;
pub use id::UsbId;
