//! The crate's integration tests as one test binary: one link instead of
//! one per file (each links the libraries, and at the test profile's
//! opt-level every binary instantiates their generic code again), which
//! is most of a clean test build's time. A new test file is a `mod` line
//! here (the package sets `autotests = false`).

mod bundle_io;
mod bvh;
mod common;
mod image_files;
mod manifest_rules;
mod mesh_io;
mod mesh_io_fuzz;
mod robustness;
