//! The estimator: from a scan's photos, calibration and mesh to the five
//! Principled BSDF parameter maps in `estimate/`.
//!
//! - [`net`]: the thesis's five parameter networks (chapter 3.2) in burn
//!   0.22: their channel tables ([`net::spec`]), blocks, input pyramid,
//!   max-fusion over views, the network, the models a run loads and the
//!   versioned weight files.
//! - [`device`]: which backend runs them ([`Backend`]: flex or ndarray on
//!   the CPU, Vulkan on a GPU).
//! - [`pipeline`]: scan to `estimate/`: which views are used, each
//!   network's input tensors, the plan (estimated, given or skipped per
//!   parameter), the run itself ([`estimate`]), metrics against truth, the
//!   atomic output folder, and scenes prepared with truth dependencies for
//!   training and the thesis's independent evaluation.
//! - [`fit`]: the physical fit (`--method fit|hybrid`): basecolor,
//!   roughness and metallic measured from the photos under the calibrated
//!   lights, per material, with the share of the object the photos pinned;
//!   transmission through the backlight and subsurface from renders of
//!   the object under the flashes.
//! - [`refine`]: optional per-pixel analysis-by-synthesis fit after the
//!   networks (basecolor, roughness, metallic) with confidence maps.
//! - `train` (feature `train`): the trainer of section 3.2.2 and its
//!   losses, with burn's autodiff and optimizers; the shipped build has
//!   neither.
//!
//! Boundaries: reads scans through `matscan-scan` and calibrates through
//! `matscan-calib`; the forward model of the fit and the refinement is
//! `matscan-bsdf`'s Principled BSDF, the renderer's own. The renderer
//! itself (`matscan-sim`) is linked for one measurement: how far light
//! travels under a surface depends on the whole object's shape, so
//! `fit::scattering` renders the scan's mesh with its random walk. Crate choices: burn (flex CPU backend by default, ndarray
//! selectable, wgpu/Vulkan behind `vulkan`): one model definition for
//! inference, training and every backend; `rayon` for per-pixel work.
//!
//! # Performance
//!
#![doc = include_str!("../PERFORMANCE.md")]

pub mod device;
pub mod fit;
pub mod net;
pub mod pipeline;
pub mod refine;
#[cfg(feature = "train")]
pub mod train;

pub use device::backend::{cpu_device, Backend, BackendError, CpuBackend};
pub use device::gpu::{gpu_device, gpu_is_built, GpuAdapter, GpuUnavailable};
pub use net::models::{ModelSource, Models, ModelsError};
pub use net::network::{ConfigError, InputError, NetConfig, NetOutput, ParamNet};
pub use net::spec::{InputChannel, NetworkSpec, OutputChannel, PIPELINE_ORDER};
pub use net::weights::{WeightSource, WeightsError};
pub use pipeline::output::{ResultFile, Status};
pub use pipeline::plan::{Given, PlanError};
pub use pipeline::run::{estimate, EstimateError, EstimateOptions, EstimateReport, References};
pub use pipeline::views::ViewFilter;
