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
//! The estimation pipeline, scan to `estimate/`:
//! - [`views`]: which (position, lit capture) pairs are used.
//! - [`inputs`]: each network's input tensors from photos and calibration.
//! - [`plan`]: estimated, given or skipped per parameter; network stages.
//! - [`models`]: the networks a run uses and their model ids.
//! - [`pipeline`]: runs it all ([`estimate`]).
//! - [`metrics`]: MAD, MSE, PSNR against ground truth.
//! - [`output`]: the atomic `estimate/` folder and `result.toml`.
//! - [`refine`]: optional per-pixel analysis-by-synthesis fit after the
//!   networks (basecolor, roughness, metallic) with confidence maps.
//!
//! Training: feature `train` adds burn's autodiff and optimizers,
//! `backend::training_device` and the [`train`](mod@train) module (the
//! trainer of section 3.2.2 and its losses); the shipped build has neither.
//!
//! # Performance
//!
#![doc = include_str!("../PERFORMANCE.md")]

pub mod backend;
pub mod blocks;
pub mod fusion;
pub mod gpu;
pub mod inputs;
pub mod metrics;
pub mod models;
pub mod network;
pub mod output;
pub mod pipeline;
pub mod plan;
pub mod pyramid;
pub mod refine;
pub mod spec;
#[cfg(feature = "train")]
pub mod train;
pub mod views;
pub mod weights;

pub use backend::{cpu_device, CpuBackend};
pub use gpu::{gpu_device, gpu_is_built, GpuAdapter, GpuUnavailable};
pub use models::{ModelSource, Models, ModelsError};
pub use network::{ConfigError, InputError, NetConfig, NetOutput, ParamNet};
pub use output::{ResultFile, Status};
pub use pipeline::{estimate, EstimateError, EstimateOptions, EstimateReport, References};
pub use plan::{Given, PlanError};
pub use spec::{InputChannel, OutputChannel, ParamKind};
pub use views::ViewFilter;
pub use weights::{WeightSource, WeightsError};
