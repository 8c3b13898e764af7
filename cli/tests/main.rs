//! The crate's integration tests as one test binary: one link instead of
//! one per file (each links the libraries, and at the test profile's
//! opt-level every binary instantiates their generic code again), which
//! is most of a clean test build's time. A new test file is a `mod` line
//! here (the package sets `autotests = false`).

mod bench_eval;
mod calib_capture;
mod capture_now_cli;
mod cli;
mod daemon_e2e;
mod daemon_footswitch;
mod daemon_soak;
mod daemon_support;
mod render;
