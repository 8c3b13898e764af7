//! The Principled transmission lobe: a rough dielectric (Walter et al. 2007)
//! with GGX and the transmission IOR, reflecting white and transmitting the
//! base colour, split per microfacet by the exact dielectric Fresnel (as
//! Cycles' multiscatter GGX glass does). Local frame, weight-free; `eta` is
//! the relative index across the surface as seen from `wo` (1.45 entering,
//! 1/1.45 leaving).
//!
//! Energy: Cycles 2.9x's multiscatter GGX glass loses no energy for white
//! glass; single scattering loses up to ~65% at roughness 1. The lobe is
//! therefore divided by its white directional albedo E(μo) (tabulated in
//! [`super::energy`], as Cycles 4.x does for its glass), which restores
//! albedo 1 for white glass at every roughness and angle, with the single-
//! scattering shape.
//!
//! Like Cycles, the transmitted radiance is not scaled by 1/eta² (the
//! eta² of the refraction Jacobian stays in f), so looking through a glass
//! slab keeps a light's brightness and a sampled refraction has weight
//! G1(wi) times the tint.

use super::energy::tables;
use super::fresnel::fresnel_dielectric_cos;
use super::ggx::{
    ggx_d, ggx_g1, reflect, refract, refraction_half_vector, refraction_jacobian, sample_vndf,
    vndf_pdf,
};
use glam::Vec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Glass {
    roughness: f32,
    alpha: f32,
    delta: bool,
    tint: Vec3,
}

/// One sampled delta direction of the smooth glass.
pub(crate) struct DeltaGlassSample {
    pub wi: Vec3,
    /// f cos / branch probability, without the mixing weight.
    pub weight: Vec3,
    /// Probability of this branch (Fresnel or 1 - Fresnel).
    pub probability: f32,
}

impl Glass {
    pub fn new(roughness: f32, alpha: f32, delta: bool, tint: Vec3) -> Glass {
        Glass {
            roughness,
            alpha,
            delta,
            tint,
        }
    }

    /// 1 / E(μo) of white glass: the renormalization for multiple scattering.
    /// The floor bounds it where E is smallest (rough, grazing).
    fn energy_scale(&self, wo: Vec3, eta: f32) -> f32 {
        let e = tables().glass_albedo(wo.z, self.roughness, eta > 1.0);
        1.0 / e.max(0.1)
    }

    pub fn is_delta(&self) -> bool {
        self.delta
    }

    /// Lobe-selection weight: the expected colour average at the shading
    /// normal, Fresnel white plus transmitted tint.
    pub fn selection_weight(&self, wo: Vec3, eta: f32) -> f32 {
        let f = fresnel_dielectric_cos(wo.z, eta);
        f + (1.0 - f) * (self.tint.x + self.tint.y + self.tint.z) / 3.0
    }

    /// (f cos θi, density) for `wi` above the shading surface.
    pub fn reflection(&self, wo: Vec3, wi: Vec3, eta: f32) -> (Vec3, f32) {
        if self.delta || wi.z <= 0.0 || wo.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return (Vec3::ZERO, 0.0);
        }
        let f = fresnel_dielectric_cos(wo.dot(h), eta);
        let d = ggx_d(h, self.alpha);
        let g1o = ggx_g1(wo, self.alpha);
        let common = f * d / (4.0 * wo.z);
        let scale = self.energy_scale(wo, eta);
        (
            Vec3::splat(common * g1o * ggx_g1(wi, self.alpha) * scale),
            common * g1o,
        )
    }

    /// (f cos θi, density) for `wi` below the shading surface.
    pub fn transmission(&self, wo: Vec3, wi: Vec3, eta: f32) -> (Vec3, f32) {
        if self.delta || wi.z >= 0.0 || wo.z <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let Some(h) = refraction_half_vector(wo, wi, eta) else {
            return (Vec3::ZERO, 0.0);
        };
        let f = fresnel_dielectric_cos(wo.dot(h), eta);
        let pdf = (1.0 - f) * vndf_pdf(wo, h, self.alpha) * refraction_jacobian(wo, wi, h, eta);
        // f cos = (1 - F) D G1o G1i eta² |wi·h| |wo·h| / (wo.z (wo·h + eta wi·h)²)
        //       = pdf * G1i, by the visible-normal density; then renormalized.
        let scale = self.energy_scale(wo, eta);
        (self.tint * (pdf * ggx_g1(wi, self.alpha) * scale), pdf)
    }

    /// Non-delta sample: reflect with the microfacet's Fresnel probability,
    /// else refract. `u_choice` picks the branch.
    pub fn sample(&self, wo: Vec3, eta: f32, u_choice: f32, u1: f32, u2: f32) -> Option<Vec3> {
        let h = sample_vndf(wo, self.alpha, u1, u2);
        let f = fresnel_dielectric_cos(wo.dot(h), eta);
        // A branch landing on the other branch's side is rejected, so that
        // the density on each side is exactly that branch's pdf.
        if u_choice < f {
            let wi = reflect(wo, h).normalize_or_zero();
            (wi.z > 0.0).then_some(wi)
        } else {
            let wi = refract(wo, h, eta)?;
            (wi.z < 0.0).then_some(wi)
        }
    }

    /// Delta sample of the perfectly smooth interface.
    pub fn sample_delta(&self, wo: Vec3, eta: f32, u_choice: f32) -> Option<DeltaGlassSample> {
        let f = fresnel_dielectric_cos(wo.z, eta);
        if u_choice < f {
            return Some(DeltaGlassSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: Vec3::ONE,
                probability: f,
            });
        }
        let wi = refract(wo, Vec3::Z, eta)?;
        Some(DeltaGlassSample {
            wi,
            weight: self.tint,
            probability: 1.0 - f,
        })
    }
}
