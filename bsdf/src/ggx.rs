//! Isotropic GGX (Trowbridge-Reitz) microfacet distribution in the local
//! shading frame (z = shading normal): the distribution D, Smith's separable
//! masking G1 (as Cycles' `bsdf_microfacet_ggx` uses), visible-normal
//! sampling, and the reflection / refraction Jacobians. Knows nothing of
//! Fresnel or of lobe weights.
//!
//! Precision: D and G1 are written with the tangential components
//! (x² + y²) instead of 1 - cos², so that alpha down to the delta threshold
//! (3e-4) keeps full f32 precision near the peak where 1 - cos² cancels.

use glam::Vec3;
use std::f32::consts::PI;

/// GGX normal distribution D(h) for a unit microfacet normal `h` in the local
/// frame. Zero for microfacets facing below the surface.
pub fn ggx_d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let tangential = h.x * h.x + h.y * h.y;
    let denom = tangential + h.z * h.z * a2;
    if denom <= 0.0 {
        return 0.0;
    }
    a2 / (PI * denom * denom)
}

/// Smith masking G1 of GGX for a unit direction `w` in the local frame,
/// sign-agnostic in w.z (the refraction side uses |cos| as Cycles does).
pub fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    let z2 = w.z * w.z;
    if z2 <= 0.0 {
        return 0.0;
    }
    let tangential = w.x * w.x + w.y * w.y;
    let tan2_scaled = alpha * alpha * tangential / z2;
    2.0 / (1.0 + (1.0 + tan2_scaled).sqrt())
}

/// Density of the visible normal `h` seen from `wo` (Heitz 2018):
/// G1(wo) max(0, wo·h) D(h) / wo.z.
pub fn vndf_pdf(wo: Vec3, h: Vec3, alpha: f32) -> f32 {
    let cos_oh = wo.dot(h);
    if wo.z <= 0.0 || cos_oh <= 0.0 {
        return 0.0;
    }
    ggx_g1(wo, alpha) * cos_oh * ggx_d(h, alpha) / wo.z
}

/// Samples a visible microfacet normal for `wo` (wo.z > 0) from u in [0,1)²,
/// Heitz 2018 "Sampling the GGX Distribution of Visible Normals". Same
/// distribution as Cycles 2.9x's stretched sampling.
pub fn sample_vndf(wo: Vec3, alpha: f32, u1: f32, u2: f32) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize_or(Vec3::Z);
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u1.clamp(0.0, 1.0).sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let mut p2 = r * phi.sin();
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize_or(Vec3::Z)
}

/// Mirror reflection of `wo` about the unit normal `h`.
pub fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

/// Refraction of `wo` through the unit normal `h` (wo·h > 0) into the side
/// with relative index `eta` (far / near); None under total internal
/// reflection.
pub fn refract(wo: Vec3, h: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(h);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + (cos_i / eta - cos_t) * h).normalize_or_zero())
}

/// Microfacet normal of a refraction pair (wo above, wi below, `eta` far /
/// near), oriented into the upper hemisphere; None for pairs no microfacet
/// can refract (both on one side of it).
pub fn refraction_half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<Vec3> {
    let mut h = -(wo + eta * wi);
    if h.z < 0.0 {
        h = -h;
    }
    let h = h.normalize_or_zero();
    if h == Vec3::ZERO || wo.dot(h) <= 0.0 || wi.dot(h) >= 0.0 {
        return None;
    }
    Some(h)
}

/// |dh/dwi| for refraction: eta² |wi·h| / (wo·h + eta wi·h)².
pub fn refraction_jacobian(wo: Vec3, wi: Vec3, h: Vec3, eta: f32) -> f32 {
    let denom = wo.dot(h) + eta * wi.dot(h);
    let d2 = denom * denom;
    if d2 <= 0.0 {
        return 0.0;
    }
    eta * eta * wi.dot(h).abs() / d2
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_pcg::Pcg32;

    fn uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
        let z = u1;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u2;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn projected_distribution_integrates_to_one() {
        // ∫ D(h) h.z dω = 1 by stratified quadrature in (cos θ², φ).
        for alpha in [0.05_f32, 0.2, 0.5, 1.0] {
            let n = 200_000;
            let mut sum = 0.0_f64;
            for i in 0..n {
                // Substitute t = cos θ: dω = dt dφ; D is φ-independent.
                let t = (i as f32 + 0.5) / n as f32;
                let h = Vec3::new((1.0 - t * t).sqrt(), 0.0, t);
                sum += (ggx_d(h, alpha) * t) as f64 * 2.0 * PI as f64 / n as f64;
            }
            assert!((sum - 1.0).abs() < 0.01, "alpha {alpha}: {sum}");
        }
    }

    #[test]
    fn visible_normals_integrate_to_one_and_sampler_matches_density() {
        let mut rng = Pcg32::new(7, 11);
        for alpha in [0.1_f32, 0.4, 1.0] {
            for cos_o in [0.9_f32, 0.3] {
                let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                // Uniform-hemisphere MC of the density: must be 1.
                let n = 200_000;
                let mut total = 0.0_f64;
                // Fraction of the density in a test cone around +x tilt,
                // by the density and by the sampler.
                let cone_axis = Vec3::new(0.5, 0.0, 1.0).normalize();
                let mut cone_density = 0.0_f64;
                for _ in 0..n {
                    let h = uniform_hemisphere(rng.gen(), rng.gen());
                    let p = vndf_pdf(wo, h, alpha) as f64 * 2.0 * PI as f64;
                    total += p;
                    if h.dot(cone_axis) > 0.95 {
                        cone_density += p;
                    }
                }
                total /= n as f64;
                cone_density /= n as f64;
                let mut cone_samples = 0usize;
                for _ in 0..n {
                    let h = sample_vndf(wo, alpha, rng.gen(), rng.gen());
                    if h.dot(cone_axis) > 0.95 {
                        cone_samples += 1;
                    }
                }
                let cone_sampled = cone_samples as f64 / n as f64;
                assert!(
                    (total - 1.0).abs() < 0.03,
                    "alpha {alpha} cos {cos_o}: {total}"
                );
                assert!(
                    (cone_density - cone_sampled).abs() < 0.01,
                    "alpha {alpha} cos {cos_o}: {cone_density} vs {cone_sampled}"
                );
            }
        }
    }

    #[test]
    fn masking_is_one_at_normal_incidence_and_zero_at_grazing() {
        assert!((ggx_g1(Vec3::Z, 0.7) - 1.0).abs() < 1e-6);
        assert_eq!(ggx_g1(Vec3::X, 0.7), 0.0);
        assert!(ggx_g1(Vec3::new(0.6, 0.0, -0.8), 0.5) == ggx_g1(Vec3::new(0.6, 0.0, 0.8), 0.5));
    }

    #[test]
    fn distribution_stays_finite_and_precise_near_the_delta_threshold() {
        let alpha = 3.2e-4_f32;
        let peak = ggx_d(Vec3::Z, alpha);
        assert!((peak - 1.0 / (PI * alpha * alpha)).abs() / peak < 1e-5);
        // Half a width off the peak, where 1 - cos² would cancel in f32.
        let h = Vec3::new(alpha * 0.5, 0.0, 1.0).normalize();
        let expected = peak / (1.0_f32 + 0.25).powi(2);
        assert!((ggx_d(h, alpha) - expected).abs() / expected < 1e-3);
    }

    #[test]
    fn refraction_half_vector_recovers_the_sampled_normal() {
        let h = Vec3::new(0.2, -0.1, 1.0).normalize();
        let wo = Vec3::new(-0.5, 0.3, 0.8).normalize();
        for eta in [1.45_f32, 1.0 / 1.45] {
            if let Some(wi) = refract(wo, h, eta) {
                assert!(wi.z < 0.0);
                let back = refraction_half_vector(wo, wi, eta).unwrap();
                assert!((back - h).length() < 1e-5, "{back} vs {h}");
            }
        }
    }
}
