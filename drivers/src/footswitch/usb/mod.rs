//! USB footswitches read raw through libusb rather than through evdev
//! (the alternative to `super::evdev`): HID keyboard reports turned into
//! presses.
//!
//! - [`hid_keys`]: HID keyboard reports → Linux key codes (the kernel's
//!   `hid_keyboard[]` table) and the rising-edge press rule;
//! - `reader` (feature `hardware`): `UsbFootswitch`, a
//!   [`crate::Trigger`] over the shared HID plumbing of `crate::usb`.
//!
//! Unplug behaviour: when the pedal disappears mid-wait, `wait` keeps
//! looking for it every 250 ms and reopens it when it comes back; if it is
//! still gone at the timeout `wait` returns `Ok(None)`, as for a timeout
//! without a press, so an unplugged pedal never stops the daemon. Only a
//! pedal absent at `open` is an error (naming its id, `lsusb` and the udev
//! rule).
//!
//! Boundaries: the report codec is pure and compiles and tests in the
//! default build; only the reader, which touches libusb, needs `hardware`.

pub mod hid_keys;
#[cfg(feature = "hardware")]
pub mod reader;

pub use hid_keys::{parse_report, usage_to_key, KeyReport, PressDetector};
#[cfg(feature = "hardware")]
pub use reader::UsbFootswitch;
