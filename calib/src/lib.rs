//! Calibration maps: turns a scan bundle's known geometry and calibration
//! into the per-pixel maps the thesis feeds its networks (sections 3.1.2,
//! 3.1.5, 3.1.6), for any scan that follows the `matscan-scan/1` contract.
//!
//! Per position ([`maps`]): ray-cast geometry (mask, world position, normal,
//! depth, view vector, UV; [`geometry`]), per posed light the light vector,
//! distance, BRDF angle cosines NL and VL and a shadow mask ([`lights`],
//! eqs. 3.2 to 3.4 in [`angles`]), and for projectors the expected sharp
//! checker pattern ([`projector`]). From the photos: the white reference's
//! light response ([`white_reference`]) and the bad-light verdict
//! ([`bad_light`]). Across positions: geometric correspondences and warped
//! photos ([`warp`]). [`check`] compares the calibration with the photos.
//!
//! Conventions, shared by every map: rasters have the camera's size, row 0
//! on top; vectors (normal, view, light) are unit and in the position's
//! camera frame (OpenCV), positions in world space; background pixels
//! (no hit) hold 0 in every map and false in every mask; no map ever holds
//! NaN or Inf.
//!
//! Entry points: [`calibrate()`] (a manifest, a
//! [`matscan_scan::bvh::RayCaster`] and any [`PhotoSource`]),
//! [`calibrate_bundle`] (a bundle on disk), [`write_maps`] (EXR maps and
//! `calib.json`) and [`check::check`] (a serializable
//! [`check::CheckReport`]); [`synthetic`] builds analytic scenes for tests
//! and benchmarks.
//!
//! Performance: per-pixel work runs on rayon, one row per task.
//! `examples/calib_bench.rs` (81 920-triangle displaced blob plus a
//! backplane, 3 positions x 7 captures at 256x256, the whole calibration
//! plus 42 warped photos) measured a median of 0.66 to 1.01 s wall with
//! `RAYON_NUM_THREADS=2` on the shared 2-core development machine under a
//! load average of 8 to 10, and 0.41 s of CPU time per run, i.e. about 0.2 s
//! on 2 idle cores.
//!
//! Boundaries: depends on `matscan-scan` only; no estimation, no rendering.

pub mod angles;
pub mod bad_light;
pub mod calibrate;
pub mod check;
pub mod error;
pub mod geometry;
pub mod lights;
pub mod maps;
mod par;
pub mod photos;
pub mod projector;
pub mod summary;
pub mod synthetic;
pub mod warp;
pub mod white_reference;
pub mod write;

pub use calibrate::{
    calibrate, calibrate_bundle, CalibOptions, PositionCalibration, ScanCalibration,
};
pub use error::CalibError;
pub use maps::{position_maps, PixelMaps};
pub use photos::{MemoryScan, PhotoSource};
pub use write::write_maps;

#[cfg(test)]
mod analytic_tests;
#[cfg(test)]
mod pipeline_tests;
