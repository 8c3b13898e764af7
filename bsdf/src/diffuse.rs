//! Burley ("Disney") diffuse with retro-reflection, exactly as Cycles 2.9x's
//! `bsdf_principled_diffuse` evaluates it, plus cosine-weighted sampling.
//! Local frame (z = shading normal), colourless: the caller applies weights.
//!
//! f = (1/π) Fd(wo) Fd(wi), Fd(w) = 1 + (Fd90 - 1)(1 - cos θ)^5,
//! Fd90 = 0.5 + 2 roughness cos²θ_d, with cos²θ_d = (wi·h)² = (1 + wo·wi) / 2.
//! Symmetric in wo and wi, so the lobe is reciprocal; it is not energy
//! conserving: rough surfaces gain energy at grazing view (retro-reflection),
//! smooth ones lose some (see the module doc of [`super`] for figures).

use super::fresnel::schlick_weight;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// f(wo, wi) cos θi of the Burley lobe for local unit directions with
/// wo.z > 0; zero for wi below the shading surface.
pub fn burley_cos(wo: Vec3, wi: Vec3, roughness: f32) -> f32 {
    if wi.z <= 0.0 {
        return 0.0;
    }
    let cos_o = wo.z.max(0.0);
    let cos_i = wi.z;
    // cos²θ_d without normalizing wo + wi, which may nearly cancel.
    let cos_d2 = (0.5 * (1.0 + wo.dot(wi))).clamp(0.0, 1.0);
    let fd90 = 0.5 + 2.0 * cos_d2 * roughness;
    let fl = schlick_weight(cos_i);
    let fv = schlick_weight(cos_o);
    let fd = (1.0 + (fd90 - 1.0) * fl) * (1.0 + (fd90 - 1.0) * fv);
    FRAC_1_PI * cos_i * fd
}

/// Cosine-weighted direction in the upper local hemisphere.
pub fn sample_cosine(u1: f32, u2: f32) -> Vec3 {
    let r = u1.clamp(0.0, 1.0).sqrt();
    let phi = 2.0 * PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt())
}

/// Density of [`sample_cosine`] for a local direction.
pub fn cosine_pdf(w: Vec3) -> f32 {
    w.z.max(0.0) * FRAC_1_PI
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ burley_cos dωi by a (θ, φ) grid.
    fn albedo(wo: Vec3, roughness: f32) -> f32 {
        let (nt, np) = (400, 400);
        let mut sum = 0.0_f64;
        for it in 0..nt {
            let theta = (it as f32 + 0.5) / nt as f32 * 0.5 * PI;
            for ip in 0..np {
                let phi = (ip as f32 + 0.5) / np as f32 * 2.0 * PI;
                let wi = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let d_omega = theta.sin() * (0.5 * PI / nt as f32) * (2.0 * PI / np as f32);
                sum += (burley_cos(wo, wi, roughness) * d_omega) as f64;
            }
        }
        sum as f32
    }

    #[test]
    fn normal_incidence_albedo_matches_the_closed_form() {
        // At wo = n: Fd(wo) = 1 and Fd90 = 0.5 + r (1 + cos θi), so
        // E = 1 + 2 ∫ μ (1-μ)^5 (r (1 + μ) - 1/2) dμ = 1 - 1/42 + r * 5/84.
        for r in [0.0_f32, 0.5, 1.0] {
            let expected = 1.0 - 1.0 / 42.0 + r * 5.0 / 84.0;
            let got = albedo(Vec3::Z, r);
            assert!((got - expected).abs() < 2e-3, "r {r}: {got} vs {expected}");
        }
    }

    #[test]
    fn rough_burley_gains_energy_at_grazing_view() {
        let grazing = Vec3::new(0.995_f32.sqrt(), 0.0, 0.005_f32.sqrt());
        let rough = albedo(grazing, 1.0);
        let smooth = albedo(grazing, 0.0);
        assert!(rough > 1.3, "{rough}");
        // Fd(wo) = 1 - (1 - 0.0707)^5 / 2 = 0.652 darkens the smooth lobe.
        assert!((0.6..0.68).contains(&smooth), "{smooth}");
    }

    #[test]
    fn burley_is_symmetric() {
        let a = Vec3::new(0.3, 0.4, 0.866).normalize();
        let b = Vec3::new(-0.7, 0.1, 0.3).normalize();
        let fa = burley_cos(a, b, 0.7) / b.z;
        let fb = burley_cos(b, a, 0.7) / a.z;
        assert!((fa - fb).abs() < 1e-6);
    }
}
