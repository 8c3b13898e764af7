//! The pattern projector as a full-screen DRM/KMS output: the projector is
//! plugged into a GPU output (HDMI, DP) that no desktop uses, and this
//! driver sets its mode and flips whole frames onto it, with no window
//! system in between to scale, composite, tear or colour-manage them.
//!
//! - [`edid`]: the EDID base block (who the projector is, its preferred
//!   timing), for logs and the connector listing;
//! - [`mode`]: the mode request (`1280x800@60`), the choice among the
//!   connector's modes and the forced CVT-RB mode;
//! - [`raster`]: patterns into XRGB8888 buffers through the projector's
//!   gamma;
//! - [`flip`]: the double-buffer page-flip state machine and its latency
//!   rule, over a trait so it is tested without a GPU;
//! - [`connector`]: which output drives the projector;
//! - `device` (feature `hardware`): [`DrmProjector`] over `/dev/dri/card*`.
//!
//! **Latency rule.** [`crate::traits::Projector::show`] returns once the
//! projector emits the new pattern: after the kernel's flip-complete event
//! (the new buffer is scanned out from that vblank) plus the projector's own
//! latency (scaler, DLP sequencing, frame buffering; `latency`, 100 ms by
//! default, counted from the event's timestamp; measure it for a new
//! projector by filming a flip). A camera frame started after `show` sees
//! only the new pattern. A modeset (the first show, or recovery after a
//! missed flip) also waits for the projector to lock onto the signal.
//!
//! **Gamma.** Pattern levels are linear light, as the scan contract means
//! them; projectors take gamma-encoded video, so each level is sent as
//! `round(255 * level^(1/gamma))`, gamma 2.2 by default and configurable.
//!
//! **Forced mode.** A projector without EDID (or with an unreadable one, or
//! behind a converter) lists no modes or only the kernel's fallback VESA
//! modes; a configured size it does not list is then set anyway, with
//! timings computed by VESA CVT reduced blanking, like the kernel's
//! `video=` option.
//!
//! **DRM master.** Setting modes needs DRM master on the card, which the
//! first program to open it gets and keeps: a running desktop session or
//! display manager has it, and opening then fails with a message saying to
//! stop it or to give the projector an output of a GPU no session uses.
//! The previous CRTC state is restored when the projector is dropped.
//!
//! Boundaries: the display device only; the patterns are the scan
//! contract's ([`crate::traits::ProjectorPattern`]). Crate choice: `drm`
//! (Smithay's drm-rs), a safe wrapper over the kernel's mode-setting ioctls
//! with pregenerated bindings, so the build needs no system package
//! (libdrm); only `device` uses it, behind the `hardware` feature, and the
//! rest builds and is tested everywhere.

pub mod connector;
#[cfg(feature = "hardware")]
pub mod device;
pub mod edid;
pub mod flip;
pub mod mode;
pub mod raster;

pub use connector::{pick_connector, ConnectorInfo};
#[cfg(feature = "hardware")]
pub use device::{list_connectors, DrmConfig, DrmProjector};
pub use edid::{Edid, EdidError};
pub use flip::{FlipChain, FlipTiming, Scanout};
pub use mode::{
    cvt_reduced_blanking, select_mode, ListedMode, ModeChoice, ModeRequest, ModeRequestError,
    Timing,
};
pub use raster::{render, Gamma, RasterError};
