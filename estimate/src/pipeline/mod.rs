//! The estimation pipeline, scan to `estimate/`.
//!
//! - [`views`]: which (position, lit capture) pairs are used;
//! - [`inputs`]: each network's input tensors from photos and calibration;
//! - [`plan`]: estimated, given or skipped per parameter; network stages;
//! - [`method`]: networks, the physical fit, or both;
//! - [`run`]: runs it all ([`estimate`](run::estimate));
//! - [`metrics`]: MAD, MSE, PSNR against ground truth;
//! - [`oracle`]: truth fed one piece at a time (the error budget);
//! - [`output`]: the atomic `estimate/` folder and `result.toml`;
//! - [`truth_fed`]: scenes prepared for one network with the truth of its
//!   dependencies (training and the thesis's independent evaluation).

pub mod inputs;
pub mod method;
pub mod metrics;
pub mod oracle;
pub mod output;
pub mod plan;
pub mod run;
pub mod truth_fed;
pub mod views;
