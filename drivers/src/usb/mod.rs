//! USB devices through rusb (placeholder: being written).
