//! The crate's integration tests as one test binary: one link instead of
//! one per file (each links the libraries, and at the test profile's
//! opt-level every binary instantiates their generic code again), which
//! is most of a clean test build's time. A new test file is a `mod` line
//! here (the package sets `autotests = false`).

mod bake_truth;
mod export_gltf;
mod support;
mod textures_layout;
mod viewer;
