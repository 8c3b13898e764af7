//! Material values at one surface point: the Principled BSDF inputs.

use glam::Vec3;

/// Specular 0.5 as the thesis fixed it: dielectric F0 = 0.08 * 0.5 = 0.04.
pub const SPECULAR: f32 = 0.5;
/// Index of refraction of dielectrics and of transmission, as the thesis set.
pub const IOR: f32 = 1.45;
/// Default subsurface radius in scene units (the thesis's (1, 1, 1)).
pub const DEFAULT_SUBSURFACE_RADIUS: Vec3 = Vec3::ONE;

/// Principled BSDF inputs at one point, as authored (not yet effective: the
/// BSDF applies the precedence metallic > transmission > subsurface, thesis
/// eqs. 3.5 and 3.6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Linear RGB in [0, 1].
    pub basecolor: Vec3,
    pub roughness: f32,
    pub metallic: f32,
    pub transmission: f32,
    pub subsurface: f32,
    /// Per-channel radius; mean free path = subsurface * radius.
    pub subsurface_radius: Vec3,
}

impl Material {
    /// White diffuse: the material of the `illum_<capture>` truth renders.
    pub const WHITE_DIFFUSE: Material = Material {
        basecolor: Vec3::ONE,
        roughness: 1.0,
        metallic: 0.0,
        transmission: 0.0,
        subsurface: 0.0,
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    };

    /// Effective transmission, thesis eq. 3.5: transmission * (1 - metallic).
    pub fn effective_transmission(&self) -> f32 {
        self.transmission.clamp(0.0, 1.0) * (1.0 - self.metallic.clamp(0.0, 1.0))
    }

    /// Effective subsurface, thesis eq. 3.6:
    /// subsurface * (1 - metallic) * (1 - transmission).
    pub fn effective_subsurface(&self) -> f32 {
        self.subsurface.clamp(0.0, 1.0)
            * (1.0 - self.metallic.clamp(0.0, 1.0))
            * (1.0 - self.transmission.clamp(0.0, 1.0))
    }

    /// Every input clamped to its valid range and made finite, so that no
    /// caller can feed the BSDF a NaN.
    pub fn sanitized(&self) -> Material {
        let c = |x: f32| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                0.0
            }
        };
        Material {
            basecolor: Vec3::new(
                c(self.basecolor.x),
                c(self.basecolor.y),
                c(self.basecolor.z),
            ),
            roughness: c(self.roughness),
            metallic: c(self.metallic),
            transmission: c(self.transmission),
            subsurface: c(self.subsurface),
            subsurface_radius: self.subsurface_radius.max(Vec3::splat(1e-6)),
        }
    }
}
