//! Cameras through nokhwa (placeholder: being written).
