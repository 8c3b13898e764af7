//! The Principled specular reflection lobe: GGX microfacet reflection with
//! the principled Fresnel (dielectric F0 = 0.04 tinted toward the base colour
//! by metallic) and Kulla-Conty energy compensation for the light lost by
//! single scattering. Local frame, weight-free: the caller scales by the
//! Principled mixing weight.

use super::diffuse::{cosine_pdf, sample_cosine};
use super::energy::tables;
use super::fresnel::{specular_ior, PrincipledFresnel};
use super::ggx::{ggx_d, ggx_g1, reflect, sample_vndf};
use crate::material::SPECULAR;
use glam::Vec3;
use std::f32::consts::PI;

/// Floor of the lobe-selection weight, so that a lobe whose normal-incidence
/// Fresnel is zero (black metal) can still be sampled where it reflects.
const MIN_SELECTION: f32 = 0.02;
/// Below this 1 - E_avg the multiple-scattering lobe is negligible and its
/// normalization would divide by nearly zero.
const MIN_LOST_ENERGY: f32 = 1e-4;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Specular {
    roughness: f32,
    alpha: f32,
    delta: bool,
    fresnel: PrincipledFresnel,
    /// Kulla-Conty colour scale F_ms / (π (1 - E_avg)); None when negligible.
    multi: Option<Vec3>,
}

impl Specular {
    /// `cspec0`: reflectance colour at normal incidence.
    pub fn new(roughness: f32, alpha: f32, delta: bool, cspec0: Vec3) -> Specular {
        let fresnel = PrincipledFresnel::new(cspec0, specular_ior(SPECULAR));
        let t = tables();
        let e_avg = t.albedo_avg(roughness);
        let multi = (!delta && 1.0 - e_avg > MIN_LOST_ENERGY).then(|| {
            let f_avg = fresnel.average(t.specular_blend_avg());
            let f_ms = f_avg * f_avg * e_avg / (Vec3::ONE - f_avg * (1.0 - e_avg));
            f_ms / (PI * (1.0 - e_avg))
        });
        Specular {
            roughness,
            alpha,
            delta,
            fresnel,
            multi,
        }
    }

    pub fn is_delta(&self) -> bool {
        self.delta
    }

    /// Lobe-selection weight seen from `wo` (Cycles: mean Fresnel colour at
    /// the shading normal).
    pub fn selection_weight(&self, wo: Vec3) -> f32 {
        let f = self.fresnel.eval(wo.z);
        ((f.x + f.y + f.z) / 3.0).max(MIN_SELECTION)
    }

    /// f cos θi for local directions above the shading surface; zero for a
    /// delta lobe (it has no density).
    pub fn value(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.delta || wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let single = self.fresnel.eval(wi.dot(h))
            * (ggx_d(h, self.alpha) * ggx_g1(wo, self.alpha) * ggx_g1(wi, self.alpha)
                / (4.0 * wo.z));
        let multi = match self.multi {
            Some(scale) => {
                let t = tables();
                let lost_o = 1.0 - t.albedo(wo.z, self.roughness);
                let lost_i = 1.0 - t.albedo(wi.z, self.roughness);
                scale * (lost_o * lost_i * wi.z)
            }
            None => Vec3::ZERO,
        };
        single + multi
    }

    /// Probability of sampling the multiple-scattering part by cosine
    /// instead of visible normals: the share of energy it carries for a
    /// white lobe, 1 - E(μo).
    fn cosine_share(&self, wo: Vec3) -> f32 {
        match self.multi {
            Some(_) => (1.0 - tables().albedo(wo.z, self.roughness)).clamp(0.0, 1.0),
            None => 0.0,
        }
    }

    /// Density of [`Self::sample`]: visible normals mixed with a cosine
    /// share for the multiple-scattering lobe.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.delta || wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize_or_zero();
        if h == Vec3::ZERO {
            return 0.0;
        }
        let q = self.cosine_share(wo);
        let vndf = ggx_g1(wo, self.alpha) * ggx_d(h, self.alpha) / (4.0 * wo.z);
        (1.0 - q) * vndf + q * cosine_pdf(wi)
    }

    /// A direction from a sampled visible normal, or with the cosine share a
    /// cosine direction (`u_choice` decides); None when it falls below the
    /// shading surface. Not for delta lobes.
    pub fn sample(&self, wo: Vec3, u_choice: f32, u1: f32, u2: f32) -> Option<Vec3> {
        if u_choice < self.cosine_share(wo) {
            return Some(sample_cosine(u1, u2));
        }
        let h = sample_vndf(wo, self.alpha, u1, u2);
        let wi = reflect(wo, h).normalize_or_zero();
        (wi.z > 0.0).then_some(wi)
    }

    /// Weight f cos / probability of the delta mirror direction: the Fresnel
    /// colour at normal-to-wo incidence.
    pub fn delta_weight(&self, wo: Vec3) -> Vec3 {
        self.fresnel.eval(wo.z)
    }
}
