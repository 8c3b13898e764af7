//! Inference core: the thesis's five BSDF parameter networks (chapter 3.2)
//! in burn 0.22, their multi-view fusion and their weight files.
//!
//! - [`spec`]: each network's named input and output channels.
//! - [`blocks`]: input stem, core / core', output stem (inception units).
//! - [`pyramid`]: padding, the input pyramid, nearest upsampling.
//! - [`fusion`]: the balanced max-fusion tree over views.
//! - [`network`]: [`ParamNet`], one parameter network over any number of views.
//! - [`weights`]: versioned weight files.
//! - [`backend`]: explicit CPU device choice (flex by default).
//!
//! Out of scope: building the input channels from a scan, running the five
//! networks in order, and training loops. Feature `train` adds burn's
//! autodiff and optimizers (and `backend::training_device`) for a trainer;
//! the test build enables them too, for `tests/training.rs`.
//!
//! # Performance
//!
#![doc = include_str!("../PERFORMANCE.md")]

pub mod backend;
pub mod blocks;
pub mod fusion;
pub mod network;
pub mod pyramid;
pub mod spec;
pub mod weights;

pub use backend::{cpu_device, CpuBackend};
pub use network::{ConfigError, InputError, NetConfig, NetOutput, ParamNet};
pub use spec::{InputChannel, OutputChannel, ParamKind};
pub use weights::{WeightSource, WeightsError};
