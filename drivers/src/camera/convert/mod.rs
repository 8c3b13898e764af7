//! What a camera delivers, made into linear RGB: pixel formats
//! ([`formats`]), the camera's response curve ([`response`]) and the rule
//! for which frames are stale after a change ([`stale`]).
//!
//! Boundaries: pure functions on byte slices; built without the `hardware`
//! feature so that they are tested in the default build. The camera
//! devices themselves are `super::v4l2` and `super::nokhwa`.

pub mod formats;
pub mod response;
pub mod stale;

pub use formats::{decode_frame, PixelFormat};
pub use response::Response;
pub use stale::StaleFrames;
