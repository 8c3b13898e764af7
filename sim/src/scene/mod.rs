//! What the simulator renders: an object mesh with spatially varying
//! material, an environment, and the rig at each position.
//!
//! The types of [`model`] are the interface between scene generation and
//! the renderer (`crate::render`). Generation lives in the submodules:
//!
//! - [`geometry`]: procedural meshes with UVs, and user meshes;
//! - [`maps`]: random parameter maps (thesis 3.1.3.1), on [`noise`];
//! - [`kinds`]: the scene kinds and the material each authors (thesis 3.1.7);
//! - [`realworld`]: wood, stone, fabric and painted metal for the
//!   `realworld` kind;
//! - [`rig`]: the scan head, its randomization and its manifest lights;
//! - [`generate`](mod@generate): a whole scene from a seed;
//! - [`framing`]: cameras aimed at the object, which fills the frame.

pub mod color;
pub mod framing;
pub mod generate;
pub mod geometry;
pub mod kinds;
pub mod maps;
pub mod model;
pub mod noise;
pub mod realworld;
pub mod rig;

pub use framing::{frame_object, FramingError};
pub use generate::{generate, GeometrySource, SceneOptions};
pub use geometry::{GeometryKind, UserMesh, UvProjection};
pub use kinds::SceneKind;
pub use model::{
    Backlight, EnvSource, EnvSpec, MaterialField, PointLight, Projector, Rig, RigPosition, Scene,
    SceneError, TexelMix, Texture,
};
pub use rig::{random_rig, rig_from_manifest, rig_to_manifest_lights, RigOptions};
