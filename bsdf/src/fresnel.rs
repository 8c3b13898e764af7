//! Fresnel terms of the Principled BSDF as Cycles 2.9x computes them: the
//! exact unpolarized dielectric Fresnel, Schlick's weight used by the Burley
//! diffuse, and the principled "Disney Fresnel" colour blend of the specular
//! lobe. Pure functions of cosines; no geometry.

use glam::Vec3;

/// Unpolarized Fresnel reflectance of a dielectric interface for the cosine
/// `cosi` between the incident direction and the (micro)normal; `eta` is the
/// ratio of the index on the far side to the index on the incident side.
/// Returns 1 under total internal reflection. Cycles' `fresnel_dielectric_cos`:
/// it avoids computing the refracted direction, so it is cheap and has no
/// branch that can produce a NaN for |cosi| <= 1.
pub fn fresnel_dielectric_cos(cosi: f32, eta: f32) -> f32 {
    let c = cosi.abs().min(1.0);
    let g2 = eta * eta - 1.0 + c * c;
    if g2 <= 0.0 {
        return 1.0;
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    (0.5 * a * a * (1.0 + b * b)).clamp(0.0, 1.0)
}

/// Schlick's weight (1 - cos)^5, clamped so that cosines slightly outside
/// [0, 1] from rounding cannot push it out of [0, 1].
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The index of refraction Cycles derives from the Principled `specular`
/// input for the reflection lobe: `2 / (1 - sqrt(0.08 * specular)) - 1`
/// (1.5 for specular 0.5, i.e. F0 = 0.04). Distinct from the transmission IOR.
pub fn specular_ior(specular: f32) -> f32 {
    let s = (0.08 * specular.max(0.0)).sqrt().min(0.999);
    2.0 / (1.0 - s) - 1.0
}

/// Cycles' principled specular Fresnel (`interpolate_fresnel_color`): the
/// dielectric Fresnel of `ior`, renormalized to [0, 1] above its normal
/// incidence value, blends from `cspec0` (the tinted F0) to white. For a
/// dielectric (`cspec0` = F0) it is exactly the dielectric Fresnel; for a
/// metal it is a Schlick-like curve starting at the base colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrincipledFresnel {
    cspec0: Vec3,
    ior: f32,
    f0: f32,
}

impl PrincipledFresnel {
    /// `cspec0` is clamped to [0, 1] as Cycles' `saturate3` does.
    pub fn new(cspec0: Vec3, ior: f32) -> PrincipledFresnel {
        PrincipledFresnel {
            cspec0: cspec0.clamp(Vec3::ZERO, Vec3::ONE),
            ior,
            f0: fresnel_dielectric_cos(1.0, ior),
        }
    }

    /// Reflectance colour for the cosine between a direction and the
    /// microfacet normal.
    pub fn eval(&self, cos_h: f32) -> Vec3 {
        let fh = self.blend_factor(cos_h);
        self.cspec0 * (1.0 - fh) + Vec3::splat(fh)
    }

    /// How far the dielectric Fresnel has moved from F0 toward 1.
    pub fn blend_factor(&self, cos_h: f32) -> f32 {
        ((fresnel_dielectric_cos(cos_h, self.ior) - self.f0) / (1.0 - self.f0)).clamp(0.0, 1.0)
    }

    /// Hemispherical cosine-weighted average of [`Self::eval`], given the
    /// average of the renormalized blend factor.
    pub fn average(&self, blend_factor_avg: f32) -> Vec3 {
        self.cspec0 * (1.0 - blend_factor_avg) + Vec3::splat(blend_factor_avg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_fresnel_matches_normal_incidence_formula() {
        for eta in [1.1_f32, 1.45, 1.5, 2.4] {
            let expected = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fresnel_dielectric_cos(1.0, eta) - expected).abs() < 1e-6);
            // Inside looking out at normal incidence reflects the same.
            assert!((fresnel_dielectric_cos(1.0, 1.0 / eta) - expected).abs() < 1e-6);
        }
    }

    #[test]
    fn dielectric_fresnel_is_total_beyond_the_critical_angle_and_one_at_grazing() {
        let eta = 1.0 / 1.45_f32;
        let critical = (1.0 - eta * eta).sqrt(); // cosine of the critical angle
        assert_eq!(fresnel_dielectric_cos(critical * 0.99, eta), 1.0);
        assert!(fresnel_dielectric_cos(critical * 1.01, eta) < 1.0);
        assert!((fresnel_dielectric_cos(0.0, 1.45) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn specular_half_gives_ior_one_and_a_half_and_f0_four_percent() {
        let ior = specular_ior(0.5);
        assert!((ior - 1.5).abs() < 1e-5);
        assert!((fresnel_dielectric_cos(1.0, ior) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn principled_fresnel_starts_at_cspec0_and_ends_white() {
        let f = PrincipledFresnel::new(Vec3::new(0.9, 0.5, 0.1), 1.5);
        assert!((f.eval(1.0) - Vec3::new(0.9, 0.5, 0.1)).abs().max_element() < 1e-6);
        assert!((f.eval(0.0) - Vec3::ONE).abs().max_element() < 1e-5);
        let dielectric = PrincipledFresnel::new(Vec3::splat(0.04), 1.5);
        for c in [0.05_f32, 0.3, 0.7, 1.0] {
            let exact = fresnel_dielectric_cos(c, 1.5);
            assert!((dielectric.eval(c).x - exact).abs() < 1e-5);
        }
    }

    #[test]
    fn schlick_weight_stays_in_unit_interval_for_out_of_range_cosines() {
        assert_eq!(schlick_weight(1.2), 0.0);
        assert_eq!(schlick_weight(-0.5), 1.0);
        assert!((schlick_weight(0.5) - 0.03125).abs() < 1e-7);
    }
}
