//! The crate's integration tests as one test binary: one link instead of
//! one per file (each links the libraries, and at the test profile's
//! opt-level every binary instantiates their generic code again), which
//! is most of a clean test build's time. A new test file is a `mod` line
//! here (the package sets `autotests = false`).

mod common;
mod estimate_pipeline;
mod mitsuba_tiny;
mod recipe_shards;
mod simulate_then_calibrate;
mod stability_bsdf;
mod stability_calib;
mod stability_estimate;
mod stability_inputs;
mod stability_network;
mod stability_refine;
mod training_resume;
