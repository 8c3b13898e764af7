//! The scene's data: what generation produces and the renderer reads (the
//! object's mesh and material field, the environment, the rig at each
//! position), and what can go wrong building it.

use glam::{DMat4, Vec2, Vec3};
use matscan_bsdf::material::Material;
use matscan_scan::{camera::Intrinsics, raster::Raster, Light, LightKind, Mesh, SurfacePoint};
use std::path::PathBuf;

/// What can go wrong building a scene from user input.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SceneError {
    #[error("unknown scene kind `{name}` (expected one of: {expected})")]
    UnknownKind { name: String, expected: String },
    #[error("unknown geometry `{name}` (expected one of: {expected})")]
    UnknownGeometry { name: String, expected: String },
    #[error("the mesh has no triangles")]
    EmptyMesh,
    #[error("triangle {triangle} refers to vertex {index}, but the mesh has {count} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        count: usize,
    },
    #[error("vertex {0} has a non-finite position")]
    NonFinitePosition(usize),
    #[error("the mesh has {got} {what} for {count} vertices")]
    AttributeLength {
        what: &'static str,
        got: usize,
        count: usize,
    },
    #[error("vertex {0} has a non-finite texture coordinate")]
    NonFiniteUv(usize),
    #[error("the mesh has no extent (all its vertices coincide)")]
    Degenerate,
}

/// A texture in the mesh's UV space (origin bottom left, wrapped), or one
/// value everywhere.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture<T> {
    Constant(T),
    /// Row 0 is v = 1 (the top of the image), as image files store it.
    Map(Raster<T>),
}

/// The authored material of the object, per UV.
#[derive(Debug, Clone, PartialEq)]
pub struct MaterialField {
    pub basecolor: Texture<[f32; 3]>,
    pub roughness: Texture<f32>,
    pub metallic: Texture<f32>,
    pub transmission: Texture<f32>,
    pub subsurface: Texture<f32>,
    pub subsurface_radius: Vec3,
}

/// Ambient light around the rig.
#[derive(Debug, Clone, PartialEq)]
pub enum EnvSource {
    /// No ambient light (the `-noenv` kinds, and truth `illum_` renders).
    None,
    /// A procedural sky and ground with a few bright patches, from a seed, so
    /// that no file is needed.
    Procedural { seed: u64 },
    /// An equirectangular HDR map (EXR).
    Map(PathBuf),
}

#[derive(Debug, Clone, PartialEq)]
pub struct EnvSpec {
    pub source: EnvSource,
    /// Multiplies the radiance. Scene generation balances the rig's lights
    /// against a procedural environment of mean radiance 1 before this
    /// factor (see [`rig`](super::rig)).
    pub strength: f32,
    /// Rotation about the world up axis (+Y, see [`rig`](super::rig)), radians.
    pub rotation: f32,
}

/// A point flash.
#[derive(Debug, Clone, PartialEq)]
pub struct PointLight {
    pub name: String,
    pub position: Vec3,
    /// Relative linear RGB.
    pub color: Vec3,
    /// Radiant intensity in W/sr (scene units).
    pub intensity: f32,
}

impl PointLight {
    /// The flash a manifest's `light` describes: `None` for a light of
    /// another kind, or one without a finite, non-negative intensity.
    pub fn from_manifest(light: &Light) -> Option<PointLight> {
        let LightKind::Point { position } = light.kind else {
            return None;
        };
        let intensity = light.intensity.filter(|i| i.is_finite() && *i >= 0.0)?;
        Some(PointLight {
            name: light.name.clone(),
            position: position.as_vec3(),
            color: Vec3::from_array(light.color.map(|c| c as f32)),
            intensity: intensity as f32,
        })
    }
}

/// A pinhole projector; `projector_to_world` in the OpenCV frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Projector {
    pub name: String,
    pub projector_to_world: DMat4,
    pub intrinsics: Intrinsics,
    pub color: Vec3,
    /// Radiant intensity along the axis at full white, W/sr.
    pub intensity: f32,
}

/// The diffuse panel behind the object, a rectangle facing the camera; its
/// emitting (front) side is the one `half_u x half_v` points to.
#[derive(Debug, Clone, PartialEq)]
pub struct Backlight {
    pub name: String,
    pub center: Vec3,
    /// Half extents along the panel's two edges (world vectors).
    pub half_u: Vec3,
    pub half_v: Vec3,
    /// Emitted radiance when on (RGB, already tinted).
    pub radiance: Vec3,
    /// Diffuse albedo when off (about 0.85).
    pub albedo: f32,
}

/// The rig at one position.
#[derive(Debug, Clone, PartialEq)]
pub struct RigPosition {
    pub name: String,
    pub camera_to_world: DMat4,
    pub flashes: Vec<PointLight>,
    pub projector: Projector,
    pub backlight: Backlight,
    /// Exposure of every capture at this position, seconds.
    pub exposure_s: f32,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    pub intrinsics: Intrinsics,
    pub positions: Vec<RigPosition>,
}

/// One complete simulated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    /// Scene kind name (`2mat`, `multimat`, ...), for grouping in evaluation.
    pub kind: String,
    /// Geometry family (`sphere`, `vase`, ..., `mesh` for a user's mesh).
    pub geometry: String,
    pub mesh: Mesh,
    pub material: MaterialField,
    pub environment: EnvSpec,
    pub rig: Rig,
}

impl<T: Copy + Default> Texture<T>
where
    T: TexelMix,
{
    /// Bilinear lookup with wrap-around at UV `uv` (origin bottom left).
    pub fn sample(&self, uv: Vec2) -> T {
        match self {
            Texture::Constant(v) => *v,
            Texture::Map(r) => {
                if r.width == 0 || r.height == 0 {
                    return T::default();
                }
                let (w, h) = (r.width as f32, r.height as f32);
                let u = if uv.x.is_finite() { uv.x } else { 0.0 };
                let v = if uv.y.is_finite() { uv.y } else { 0.0 };
                let x = u.rem_euclid(1.0) * w - 0.5;
                let y = (1.0 - v.rem_euclid(1.0)) * h - 0.5;
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let wrap = |a: f32, n: u32| (a as i64).rem_euclid(n as i64) as u32;
                let (xa, xb) = (wrap(x0, r.width), wrap(x0 + 1.0, r.width));
                let (ya, yb) = (wrap(y0, r.height), wrap(y0 + 1.0, r.height));
                let top = T::mix(*r.get(xa, ya), *r.get(xb, ya), fx);
                let bottom = T::mix(*r.get(xa, yb), *r.get(xb, yb), fx);
                T::mix(top, bottom, fy)
            }
        }
    }
}

/// Linear interpolation of texel values.
pub trait TexelMix {
    fn mix(a: Self, b: Self, t: f32) -> Self;
}

impl TexelMix for f32 {
    fn mix(a: f32, b: f32, t: f32) -> f32 {
        a + (b - a) * t
    }
}

impl TexelMix for [f32; 3] {
    fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
        [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t)
    }
}

impl MaterialField {
    /// One material everywhere.
    pub fn uniform(m: &Material) -> Self {
        MaterialField {
            basecolor: Texture::Constant(m.basecolor.to_array()),
            roughness: Texture::Constant(m.roughness),
            metallic: Texture::Constant(m.metallic),
            transmission: Texture::Constant(m.transmission),
            subsurface: Texture::Constant(m.subsurface),
            subsurface_radius: m.subsurface_radius,
        }
    }

    /// The material at a surface point (its UV; (0, 0) where the mesh has
    /// none), sanitized.
    pub fn at(&self, sp: &SurfacePoint) -> Material {
        let uv = sp.uv.unwrap_or(Vec2::ZERO);
        Material {
            basecolor: Vec3::from_array(self.basecolor.sample(uv)),
            roughness: self.roughness.sample(uv),
            metallic: self.metallic.sample(uv),
            transmission: self.transmission.sample(uv),
            subsurface: self.subsurface.sample(uv),
            subsurface_radius: self.subsurface_radius,
        }
        .sanitized()
    }
}
