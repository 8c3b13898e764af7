//! The thesis's five parameter networks (chapter 3.2) in burn 0.22.
//!
//! - [`spec`]: each network's named input and output channels;
//! - [`blocks`]: input stem, core / core', output stem (inception units);
//! - [`pyramid`]: padding, the input pyramid, nearest upsampling;
//! - [`fusion`]: the balanced max-fusion tree over views;
//! - [`network`]: [`ParamNet`](network::ParamNet), one parameter network
//!   over any number of views;
//! - [`models`]: the networks a run uses and their model ids;
//! - [`weights`]: versioned weight files, and the shipped ones embedded.

pub mod blocks;
pub mod fusion;
pub mod models;
pub mod network;
pub mod pyramid;
pub mod spec;
pub mod weights;
