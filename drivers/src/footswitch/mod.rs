//! The footswitch: what starts a capture, as a [`crate::Trigger`] whose
//! presses the sequencer waits for.
//!
//! - [`evdev`]: USB footswitches read through evdev with an exclusive grab
//!   (only `libc`, so it builds without `hardware`);
//! - [`usb`]: USB footswitches read raw through libusb (the report codec
//!   always; the reader behind `hardware`);
//! - [`pipe`]: presses as lines written to a named pipe (the simulated
//!   rig's pedal; pedals read by another program).
//!
//! Boundaries: presses and their timestamps only; what a press starts is
//! the sequencer's.

pub mod evdev;
pub mod pipe;
pub mod usb;
