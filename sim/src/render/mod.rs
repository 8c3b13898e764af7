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
//! - [`bundle_writer`]: a complete `matscan-scan/1` bundle of a scene;
//! - [`describe`]: the scene beside its bundle, for a second renderer.
//!
//! Design. Every capture is ambient plus its rig lights, and transport is
//! linear, so one path-traced pass per position fills one image per
//! emitter term (environment, each flash, the projector under each pattern,
//! the backlight) and photos are sums of those (`capture`). The `illum_`
//! truth is a second pass (white Lambertian object, environment off).
//! Primary rays come from `matscan_scan::PinholeCamera` with box-filter
//! jitter inside the pixel, so the renderer draws a world point in the
//! pixel the manifest's camera projects it to (with distortion too).
//! Random numbers are keyed by (seed, position, pass, pixel): images are
//! bit-identical for a seed whatever the thread count. Indirect light is
//! clamped at 10 per sample, Cycles' default that the thesis's renders had
//! (`integrator::DEFAULT_CLAMP_INDIRECT`); direct light is never clamped.
//! Known limits: point lights (flashes, projector) seen through perfectly
//! smooth glass or mirrors cast no caustics (no path can connect to them);
//! rough ones do.
//!
//! Measured (`cargo run --release -p matscan-sim --example render_bench`,
//! this project's 2-core machine, default 32 samples, max depth 8): a full
//! simulated scan of 3 positions x 7 captures at 256 x 256 plus truth and
//! `illum_` maps, written as a bundle, takes 10.6 s (multimat torus), 11.0 s
//! (multimat-noenv sphere), 15.6 s (sweep-subsurface sphere) and 17.5 s
//! (2mat-transmission sphere) of wall time (the last three 20 to 33 s of
//! CPU time). Time
//! against noise on one multimat position at 128 x 128 (5 captures, RMSE of
//! the exposure-scaled photos against a 512-sample reference, mean photo
//! value 0.18):
//!
//! | samples | time s | RMSE   | RMSE / mean |
//! |--------:|-------:|-------:|------------:|
//! |       4 |   0.08 | 0.0387 |       0.216 |
//! |       8 |   0.15 | 0.0278 |       0.155 |
//! |      16 |   0.29 | 0.0207 |       0.115 |
//! |      32 |   0.60 | 0.0158 |       0.088 |
//! |      64 |   1.20 | 0.0150 |       0.084 |
//!
//! Noise falls as 1/sqrt(samples) up to 32; beyond, rare bright
//! highlights of the point lights on near-mirror surfaces (correct, but
//! sampled only by the pixel jitter) dominate at this reference's length.
//!
//! Boundaries: renders what `crate::scene` describes; reads and writes
//! files only through `matscan-scan`.

pub mod bundle_writer;
pub mod capture;
pub mod describe;
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

pub use bundle_writer::{write_scan_bundle, write_truth, SimOptions};
pub use capture::{
    render_capture, CaptureSpec, ObjectMaterial, PositionImages, RenderOptions, Renderer,
    DEFAULT_MAX_DEPTH, DEFAULT_SAMPLES,
};
pub use environment::Environment;
pub use error::SimError;
pub use truth::TruthMaps;
