//! The `matscan` daemon service and its clients, as a library so that the
//! binary (`src/main.rs`) and the integration tests (`tests/daemon*.rs`)
//! share one implementation.
//!
//! - [`service`]: the capture sequencer, the control socket, systemd
//!   notification and the estimation worker (`matscan daemon`);
//! - [`client`]: `matscan capture-now` and `matscan status`;
//! - [`procstat`]: file descriptors, threads and memory of this process
//!   (the soak harness);
//! - [`soak`]: many captures in a row, with resources sampled;
//! - [`rerender`]: the scanned object with UV-textured material under
//!   novel lights and views (`matscan render`, `eval --textures`);
//! - [`image_metrics`]: PSNR and SSIM of two renders.

pub mod client;
pub mod image_metrics;
pub mod procstat;
pub mod rerender;
pub mod service;
pub mod soak;
