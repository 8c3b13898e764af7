//! The simulated rig's renderer: a Monte Carlo path tracer with next-event
//! estimation and multiple importance sampling over the rig's lights and the
//! environment, and the writer of whole scan bundles.
//!
//! - [`sampling`]: random numbers, warps, distributions, MIS weights;
//! - [`environment`]: procedural sky or HDR map, rotation, strength,
//!   importance sampling;
//! - [`lights`]: flashes, the pattern projector, the backlight panel;
//! - [`world`]: what rays hit (object BVH plus the panel) and ray offsets;
//! - [`shading`]: the scattering function at a vertex;
//! - [`subsurface`]: the random walk inside subsurface materials;
//! - [`integrator`]: the path tracer, one pass filling several emitter slots;
//! - [`capture`]: captures of a position as sums of slots, `illum_` images;
//! - [`truth`]: ground-truth maps and the object mask;
//! - [`drowned`]: positions where the environment drowns the rig lights;
//! - [`bundle_writer`]: a complete `matscan-scan/1` bundle of a scene.
//!
//! Boundaries: renders what `crate::scene` describes; reads and writes
//! files only through `matscan-scan`.

pub mod bundle_writer;
pub mod capture;
pub mod drowned;
pub mod environment;
pub mod error;
pub mod integrator;
pub mod lights;
pub mod sampling;
pub mod shading;
pub mod subsurface;
pub mod truth;
pub mod world;

pub use capture::{
    render_capture, CaptureSpec, ObjectMaterial, PositionImages, RenderOptions, Renderer, DEFAULT_MAX_DEPTH,
    DEFAULT_SAMPLES,
};
pub use bundle_writer::{write_scan_bundle, SimOptions};
pub use environment::Environment;
pub use error::SimError;
pub use truth::TruthMaps;
