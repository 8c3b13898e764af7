//! Cross-crate integration tests live in `tests/tests/`; this library is
//! empty. They prove that the parts agree with each other through the scan
//! bundle only: what the simulator writes, the reader accepts, calibration
//! reproduces pixel for pixel, and `calib check` passes.
//!
//! The `stability_*` files are property tests (`proptest`), one per
//! numerical stage (BSDF, calibration maps, input preprocessing, networks,
//! the whole estimate, the refinement fit): extreme inputs must give finite
//! values in range, and small input changes small output changes, within
//! bounds each test states and justifies. `common/` holds their shared tiny
//! simulated scan.
