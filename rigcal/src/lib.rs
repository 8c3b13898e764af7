//! The rig calibrated from its own photos: the camera's intrinsics,
//! distortion and pose at every position, from shots of a printed
//! chessboard (a `matscan-calib/1` bundle, see
//! `matscan_scan::calib_bundle`), written as the rig calibration file the
//! daemon reads (a scan manifest without captures) with a report that says
//! how well the result explains the photos and which shots to retake.
//!
//! The steps: [`detect`] finds and labels every inner corner; [`zhang`]
//! gives the closed-form start (homographies, intrinsics, poses);
//! [`refine`] moves intrinsics, distortion and every pose together
//! (Levenberg-Marquardt on the reprojection error); [`camera`] runs them
//! over a bundle and judges the result; [`projector`] calibrates the
//! projector as an inverse camera from Gray codes; [`lights`] locates the
//! flashes from a glossy sphere's highlights (a `matscan-lights/1`
//! bundle); [`radiometry`] measures each light's intensity from a white
//! card (a `matscan-white/1` bundle) and checks the camera's linearity;
//! [`compare`] measures two rig files apart; [`write`](mod@write) publishes
//! the rig file and the reports.
//!
//! Crate choices: `calib-targets` (MIT OR Apache-2.0) for the board: ChESS
//! corners with subpixel refinement, grid growth that rejects a board
//! rather than mislabel it, and ChArUco and marker boards behind the same
//! API for rigs where a plain board cannot be seen whole. `nalgebra`
//! (Apache-2.0; the version `calib-targets` builds on, so one copy) for the
//! SVDs and the Cholesky factorization of the solver. The
//! Levenberg-Marquardt loop is ours: calibration's normal equations have a
//! fixed block structure (9 shared unknowns, 6 per shot) that makes them a
//! few hundred unknowns, where a general dense solver (the
//! `levenberg-marquardt` crate factors the whole Jacobian) would do a
//! hundred times the work; the bundle-adjustment toolboxes that exploit it
//! (`vision-calibration`) bring a sparse solver stack that doubles the
//! workspace's build time on CI's two cores.
//!
//! Boundaries: depends on `matscan-scan` and `matscan-bsdf` (the white
//! card's reflectance, in the estimator's own model) among matscan crates; no
//! rendering (the simulated rig writes bundles for the tests), no device
//! I/O (the daemon captures them).

pub mod camera;
pub mod compare;
pub mod detect;
pub mod error;
pub mod lights;
pub mod model;
pub mod projector;
pub mod radiometry;
pub mod refine;
pub mod sheet;
pub mod write;
pub mod zhang;

pub use camera::{calibrate_camera, Acceptance, CameraCalibration, CameraReport};
pub use error::RigcalError;

#[cfg(test)]
mod tests;
