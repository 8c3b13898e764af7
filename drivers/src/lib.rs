//! The rig's hardware behind traits: cameras, the light controller, the
//! pattern projector, the footswitch and an optional turntable.
//!
//! The modules follow the rig's roles; within a role, one module per way
//! of reaching the device:
//!
//! - [`traits`]: [`Camera`], [`LightController`], [`Projector`],
//!   [`Trigger`], [`Positioner`] and the values they exchange;
//! - [`error`]: [`DriverError`], whose messages name the device;
//! - [`camera`]:
//!   - `camera::v4l2` (feature `hardware`): V4L2 cameras over `v4l`;
//!   - `camera::nokhwa` (feature `hardware`): the portable camera backend,
//!     with the controls it cannot lock written down;
//!   - [`camera::convert`]: camera pixel formats (YUYV, MJPG, GREY, RGB24)
//!     to linear RGB, and the stale-frame rule after a change;
//! - [`lights`]: the light controller on a serial line: its line protocol,
//!   host and simulated board;
//! - [`projector`]:
//!   - [`projector::kms`]: the projector full screen on a DRM/KMS output
//!     (EDID, modes, the gamma-encoded pattern raster and the page-flip
//!     logic always; the device behind `hardware`);
//!   - [`projector::lightcrafter`]: a TI LightCrafter over its USB HID
//!     command channel (the codec always; libusb behind `hardware`);
//! - [`footswitch`]:
//!   - [`footswitch::evdev`]: USB footswitches read through evdev with an
//!     exclusive grab (only `libc`, so it builds without `hardware`);
//!   - [`footswitch::usb`]: USB footswitches read raw (the report codec
//!     always; libusb behind `hardware`);
//!   - [`footswitch::pipe`]: presses as lines written to a named pipe (the
//!     simulated rig's pedal; pedals read by another program);
//! - [`usb`]: the libusb plumbing the LightCrafter and the raw footswitch
//!   share ([`usb::UsbId`] always; finding and claiming a HID interface
//!   behind `hardware`);
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

pub mod camera;
pub mod error;
pub mod footswitch;
pub mod lights;
pub mod projector;
#[cfg(feature = "simulated-hardware")]
pub mod sim_rig;
pub mod traits;
pub mod usb;

pub use error::DriverError;
pub use traits::{
    monotonic_now, Camera, CameraSettings, Checker, Frame, GrayCode, Level, LightController,
    LightId, LightState, Positioner, Press, Projector, ProjectorPattern, TargetHand,
    TargetPlacement, Trigger,
};
