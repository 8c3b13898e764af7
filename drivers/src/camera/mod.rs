//! The cameras: devices that deliver frames as linear RGB, each a
//! [`crate::Camera`] with its automatic controls locked.
//!
//! - [`convert`]: camera pixel formats (YUYV, MJPG, GREY, RGB24) to linear
//!   RGB, the response curve and the stale-frame rule after a change,
//!   shared by both drivers and built in the default build;
//! - `v4l2` (feature `hardware`): V4L2 cameras over `v4l`;
//! - `nokhwa` (feature `hardware`): the portable camera backend, with the
//!   controls it cannot lock written down.
//!
//! Boundaries: capture and controls only; what to photograph and when is
//! the sequencer's.

pub mod convert;
#[cfg(feature = "hardware")]
pub mod nokhwa;
#[cfg(feature = "hardware")]
pub mod v4l2;
