//! USB devices through libusb: the TI DLP LightCrafter 4500 projector
//! driven over its HID command channel, and footswitches read raw (the
//! alternative to the evdev reader in `crate::footswitch`).
//!
//! - [`id`]: [`UsbId`], `VVVV:PPPP` as `lsusb` prints it;
//! - [`hid_keys`]: HID keyboard reports → Linux key codes (the kernel's
//!   `hid_keyboard[]` table) and the rising-edge press rule;
//! - [`lightcrafter`]: the DLPC350 packet codec, the commands a
//!   structured-light rig needs, and [`LightCrafter`], a
//!   [`crate::Projector`] over any [`HidTransport`];
//! - `transport` (feature `hardware`): `RusbHid`, the rusb transport, and
//!   `LightCrafter::open`;
//! - `footswitch` (feature `hardware`): `UsbFootswitch`, a
//!   [`crate::Trigger`].
//!
//! Boundaries: the codecs are pure and compile and test in the default
//! build (with a fake transport that checks the exact bytes); only the code
//! that touches libusb needs `hardware`. Nothing here knows of scans.
//!
//! Crate choice: `rusb` with `vendored` builds libusb from source, so the
//! scanner PC needs no libusb package, and libusb can detach the kernel's
//! usbhid driver from an interface while we hold it (and give it back on
//! release), which hidraw-only crates cannot.
//!
//! The LightCrafter's limits: this driver uses the controller's internal
//! test pattern generator, so it shows black and uniform levels exactly
//! (10-bit linear codes, degamma off) and no checkerboards: those are
//! refused with an `InvalidSetting` naming the DRM/KMS output (the
//! projector's HDMI input) as the way to show them. Its resolution is the
//! DMD's native 912 × 1140 mirrors. Sources of every command are listed in
//! [`lightcrafter`]'s doc; nothing here was run against a real projector.
//!
//! The footswitch's unplug behaviour: when the pedal disappears mid-wait,
//! `wait` keeps looking for it every 250 ms and reopens it when it comes
//! back; if it is still gone at the timeout `wait` returns `Ok(None)`, as
//! for a timeout without a press, so an unplugged pedal never stops the
//! daemon. Only a pedal absent at `open` is an error (naming its id,
//! `lsusb` and the udev rule).

#[cfg(feature = "hardware")]
mod device;
#[cfg(feature = "hardware")]
pub mod footswitch;
pub mod hid_keys;
pub mod id;
pub mod lightcrafter;
#[cfg(feature = "hardware")]
pub mod transport;

#[cfg(feature = "hardware")]
pub use device::present;
#[cfg(feature = "hardware")]
pub use footswitch::UsbFootswitch;
pub use hid_keys::{parse_report, usage_to_key, KeyReport, PressDetector};
pub use id::UsbId;
pub use lightcrafter::{HidTransport, LightCrafter, LightCrafterConfig, Setting};
#[cfg(feature = "hardware")]
pub use transport::RusbHid;
