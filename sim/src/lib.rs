//! The simulated rig: matscan's own physically based renderer and the
//! procedural scenes it renders, standing in for real hardware in tests, in
//! the demo and as the source of training data.
//!
//! - [`scene`]: procedural geometry, parameter maps, rig randomization;
//! - [`render`]: a Monte Carlo path tracer with next-event estimation and
//!   multiple importance sampling over the rig's lights and the environment,
//!   and the writer of whole scan bundles;
//! - [`calib_target`]: a printed chessboard before a rig's camera, written
//!   as a calibration bundle with the true rig beside it;
//! - [`sphere_target`] and [`white_target`]: the glossy sphere that locates
//!   the flashes and the white card that measures the lights' intensities,
//!   as the simulated operator holds them;
//! - [`dataset`]: sets of scans, by seed run or by recipe, resumable and
//!   sharded.
//!
//! The material model is `matscan-bsdf`'s Principled BSDF, the same code
//! the estimator fits.
//!
//! Boundaries: reads and writes bundles only through `matscan-scan`; knows
//! nothing of estimation. It uses one rule of `matscan-calib`, thesis
//! 3.1.6's bad-light test, to flag drowned positions in its metadata, so
//! the simulator and the estimator judge a position alike.
//!
//! Crate choices: `rayon` for tile-parallel rendering (work stealing keeps
//! both cores busy when tiles differ in cost); `rand_pcg` for a small,
//! seedable, platform-independent generator so renders are deterministic per
//! seed.

pub mod calib_target;
pub mod dataset;
pub mod render;
pub mod scene;
pub mod sphere_target;
pub mod white_target;
