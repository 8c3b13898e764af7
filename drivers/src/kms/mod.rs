//! The projector over DRM/KMS (placeholder: being written).
