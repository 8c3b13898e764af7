//! The pattern projector: what lights the object with black, uniform
//! levels and checkerboards, each driver a [`crate::Projector`].
//!
//! - [`kms`]: the projector full screen on a DRM/KMS output (EDID, modes,
//!   the gamma-encoded pattern raster and the page-flip logic always; the
//!   device behind `hardware`);
//! - [`lightcrafter`]: a TI DLP LightCrafter 4500 over its USB HID command
//!   channel (the codec always; the libusb transport behind `hardware`).
//!
//! Boundaries: showing patterns only; the patterns are the scan contract's
//! ([`crate::traits::ProjectorPattern`]).

pub mod kms;
pub mod lightcrafter;
