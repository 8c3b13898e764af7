//! Cross-crate integration tests live in `tests/tests/`; this library is
//! empty. They prove that the parts agree with each other through the scan
//! bundle only: what the simulator writes, the reader accepts, calibration
//! reproduces pixel for pixel, and `calib check` passes.
