//! The rig's hardware behind traits: cameras, the light controller, the
//! pattern projector, the footswitch and an optional turntable.
//!
//! - [`traits`]: [`Camera`], [`LightController`], [`Projector`],
//!   [`Trigger`], [`Positioner`] and the values they exchange;
//! - [`error`]: [`DriverError`], whose messages name the device;
//! - [`serial`]: the light controller's line protocol, host and simulated
//!   board;
//! - [`convert`]: camera pixel formats (YUYV, MJPG, GREY, RGB24) to linear
//!   RGB, and the stale-frame rule after a change;
//! - `v4l2` (feature `hardware`): V4L2 cameras over `v4l`;
//! - `nokhwa_camera` (feature `hardware`): the portable camera backend,
//!   with the controls it cannot lock written down;
//! - [`kms`]: the projector full screen on a DRM/KMS output (EDID, modes,
//!   the gamma-encoded pattern raster and the page-flip logic always; the
//!   device behind `hardware`);
//! - [`usb`]: a TI LightCrafter's USB HID command channel and raw USB
//!   footswitches (codecs always; libusb behind `hardware`);
//! - [`footswitch`]: USB footswitches read through evdev with an exclusive
//!   grab (only `libc`, so it builds without `hardware`);
//! - [`pipe_trigger`]: presses as lines written to a named pipe (the
//!   simulated rig's pedal; pedals read by another program);
//! - `sim_rig` (feature `simulated-hardware`): the same traits backed by
//!   the renderer and a scene, with fault injection.
//!
//! Boundaries: talks to devices and renders simulated photos; knows nothing
//! of scan bundles beyond the pattern and raster types, and nothing of
//! estimation. Crate choices: `serialport` (no libudev), `libc` for the
//! pseudo-terminal, evdev and clock calls, `zune-jpeg` (pure Rust) for MJPG;
//! behind `hardware`: `v4l` and `nokhwa` (their bindings need libclang),
//! `drm` (safe KMS ioctls, pregenerated bindings) and `rusb` (libusb built
//! from source, no libudev), so the default build needs no system package.

pub mod convert;
pub mod error;
pub mod footswitch;
pub mod kms;
#[cfg(feature = "hardware")]
pub mod nokhwa_camera;
pub mod pipe_trigger;
pub mod serial;
#[cfg(feature = "simulated-hardware")]
pub mod sim_rig;
pub mod traits;
pub mod usb;
#[cfg(feature = "hardware")]
pub mod v4l2;

pub use error::DriverError;
pub use traits::{
    monotonic_now, Camera, CameraSettings, Checker, Frame, Level, LightController, LightId,
    LightState, Positioner, Press, Projector, ProjectorPattern, Trigger,
};
