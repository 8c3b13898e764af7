//! Calibration maps (in progress).
