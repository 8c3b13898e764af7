//! Principled BSDF (in progress).
