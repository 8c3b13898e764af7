//! Path tracer (in progress).
