//! A USB device's vendor and product id, as `lsusb` prints it
//! (`0451:6401`), and as the configuration names a device.
//!
//! Boundaries: parsing and printing only; finding the device is the
//! transports' job.

use crate::error::DriverError;
use std::fmt;
use std::str::FromStr;

/// Vendor and product id of a USB device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UsbId {
    pub vendor: u16,
    pub product: u16,
}

impl UsbId {
    /// The TI DLP LightCrafter 4500 (DLPC350) command interface.
    pub const LIGHTCRAFTER_4500: UsbId = UsbId {
        vendor: 0x0451,
        product: 0x6401,
    };

    /// The device name used in messages and `id()`: `usb:0451:6401`.
    pub fn device_name(&self) -> String {
        format!("usb:{self}")
    }
}

impl fmt::Display for UsbId {
    /// Lower-case hex, four digits each, like `lsusb`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:04x}:{:04x}", self.vendor, self.product)
    }
}

impl FromStr for UsbId {
    type Err = DriverError;

    /// `VVVV:PPPP` in hex (case-insensitive, an optional `0x` on either
    /// half), as `lsusb` prints it.
    fn from_str(s: &str) -> Result<UsbId, DriverError> {
        let bad = |why: &str| DriverError::InvalidSetting {
            device: "usb".to_string(),
            reason: format!(
                "`{s}` is not a USB id ({why}); expected VVVV:PPPP in hex as `lsusb` shows it, \
                 e.g. 0451:6401"
            ),
        };
        let (v, p) = s
            .trim()
            .split_once(':')
            .ok_or_else(|| bad("no `:` between vendor and product"))?;
        let half = |h: &str, what: &str| {
            let h = h
                .strip_prefix("0x")
                .or_else(|| h.strip_prefix("0X"))
                .unwrap_or(h);
            // from_str_radix accepts a leading `+`, which is no hex digit.
            if h.is_empty() || h.len() > 4 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
                return Err(bad(&format!(
                    "the {what} id `{h}` is not 1 to 4 hex digits"
                )));
            }
            u16::from_str_radix(h, 16).map_err(|_| bad(&format!("the {what} id `{h}` is not hex")))
        };
        Ok(UsbId {
            vendor: half(v, "vendor")?,
            product: half(p, "product")?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_lsusb_form_and_prints_it_back() {
        let id: UsbId = "0451:6401".parse().expect("a valid id");
        assert_eq!(id, UsbId::LIGHTCRAFTER_4500);
        assert_eq!(id.to_string(), "0451:6401");
        assert_eq!(id.device_name(), "usb:0451:6401");
        let upper: UsbId = "0C45:7403".parse().expect("upper-case hex");
        assert_eq!((upper.vendor, upper.product), (0x0c45, 0x7403));
        let prefixed: UsbId = " 0x0c45:0x7403 ".parse().expect("0x prefixes");
        assert_eq!(prefixed, upper);
    }

    #[test]
    fn a_malformed_id_names_the_string_and_the_expected_form() {
        for bad in [
            "04516401",
            "0451:",
            "g451:6401",
            "0451:64011",
            "+451:6401",
            "",
        ] {
            let err = bad.parse::<UsbId>().expect_err(bad).to_string();
            assert!(err.contains(&format!("`{bad}`")), "{err}");
            assert!(err.contains("VVVV:PPPP"), "{err}");
        }
    }
}
