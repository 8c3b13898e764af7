//! Texture baking: turns the per-position parameter maps of a scan (the
//! estimate's `estimate/<position>/<param>.exr`, or a simulated scan's
//! truth maps) into UV textures of the object's mesh, and writes them in the
//! layout `estimate/texture/` ([`textures`]).
//!
//! Boundaries: reads bundles and maps through `matscan-scan`; no
//! estimation, no rendering. The glTF export lives beside the baker
//! so that the daemon's `matscan export` is a thin edge.

pub mod error;
pub mod textures;

pub use error::BakeError;
pub use textures::{
    read_textures, texel_uv, texture_dir, texture_path, write_textures, BakedTextures,
};
