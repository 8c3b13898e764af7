//! Inference core (in progress).
