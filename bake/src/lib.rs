//! Texture baking: turns the per-position parameter maps of a scan (the
//! estimate's `estimate/<position>/<param>.exr`, or a simulated scan's
//! truth maps) into UV textures of the object's mesh, writes them in the
//! layout `estimate/texture/` ([`textures`]) and exports the mesh with
//! that material as glTF 2.0 ([`gltf_export`]).
//!
//! Entry points: [`bake_scan`] (a scan and its estimate folder),
//! [`bake_truth`] and [`bake_maps`] (any per-position maps, baked the same
//! way), [`write_textures`] / [`read_textures`] (the file layout),
//! [`gltf_export::export_gltf`].
//!
//! Boundaries: reads bundles and maps through `matscan-scan`, illumination
//! through `matscan-calib`; no estimation, no rendering. The glTF export
//! lives beside the baker so that the daemon's `matscan export` is a thin
//! edge.
//!
//! Crate choices: `rayon` (one texel row per task); the texture files go
//! through `matscan_scan::image_io`, `image` (PNG only) encodes the glTF
//! export's packed textures.

pub mod atlas;
pub mod bake;
pub mod distance;
pub mod error;
pub mod fuse;
pub mod gltf_export;
pub mod maps;
pub mod pushpull;
mod sampling;
pub mod textures;
mod views;

pub use bake::{
    bake_bundle, bake_maps, bake_scan, bake_truth, read_estimate_maps, read_truth_maps,
    BakeOptions, DEFAULT_SIZE,
};
pub use error::BakeError;
pub use fuse::FuseOptions;
pub use gltf_export::{export_gltf, metres_per_unit, GltfFormat};
pub use maps::BakeInput;
pub use textures::{
    read_textures, texel_uv, texture_dir, texture_path, write_textures, BakedTextures,
};
