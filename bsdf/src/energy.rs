//! Precomputed directional albedo of single-scattering GGX reflection (the
//! input of the Kulla-Conty compensation of the specular lobe) and of the
//! single-scattering rough dielectric for IOR 1.45 from both sides (the
//! renormalization of the glass lobe): together they stand in for Cycles'
//! stochastic "Multiscatter GGX" (see the module doc of [`super`]). Also the
//! hemispherical average of the principled Fresnel blend.
//!
//! The tables are integrated in code on first use (a few tens of
//! milliseconds, once per process) rather than pasted as constants, so they
//! can never drift from the GGX functions they describe. Integration is a
//! deterministic stratified quadrature over visible normals, so the tables
//! are identical on every run and platform.

use super::fresnel::{fresnel_dielectric_cos, specular_ior, PrincipledFresnel};
use super::ggx::{ggx_g1, reflect, refract, sample_vndf};
use crate::material::{IOR, SPECULAR};
use glam::Vec3;
use std::sync::OnceLock;

/// Grid points over cos θ_o in [0, 1].
const MU_STEPS: usize = 32;
/// Grid points over roughness in [0, 1] (alpha = roughness²).
const ROUGHNESS_STEPS: usize = 32;
/// Strata per dimension of the visible-normal quadrature of one entry.
const STRATA: usize = 24;
/// cos θ_o used for the μ = 0 column (the limit is finite and smooth).
const MU_FLOOR: f32 = 1e-3;

/// Albedo tables of GGX reflection with Fresnel = 1.
pub(crate) struct EnergyTables {
    /// E(μ, roughness): directional albedo, rows by roughness.
    albedo: [[f32; MU_STEPS]; ROUGHNESS_STEPS],
    /// E_avg(roughness) = 2 ∫ E(μ) μ dμ.
    albedo_avg: [f32; ROUGHNESS_STEPS],
    /// Cosine-weighted hemispherical average of the principled Fresnel blend
    /// factor for the specular IOR (0.5 specular).
    specular_blend_avg: f32,
    /// Directional albedo of white rough glass (reflection + transmission),
    /// entering (eta = IOR) and leaving (eta = 1 / IOR), rows by roughness.
    glass_albedo: [[[f32; MU_STEPS]; ROUGHNESS_STEPS]; 2],
}

/// The process-wide tables, integrated on first use.
pub(crate) fn tables() -> &'static EnergyTables {
    static TABLES: OnceLock<EnergyTables> = OnceLock::new();
    TABLES.get_or_init(EnergyTables::integrate)
}

impl EnergyTables {
    fn integrate() -> EnergyTables {
        let mut albedo = [[1.0_f32; MU_STEPS]; ROUGHNESS_STEPS];
        // Row 0 is roughness 0: a perfect mirror with F = 1 reflects everything.
        for (j, row) in albedo.iter_mut().enumerate().skip(1) {
            let alpha = grid(j, ROUGHNESS_STEPS).powi(2);
            for (i, e) in row.iter_mut().enumerate() {
                *e = directional_albedo(grid(i, MU_STEPS).max(MU_FLOOR), alpha);
            }
        }
        let mut albedo_avg = [1.0_f32; ROUGHNESS_STEPS];
        for (avg, row) in albedo_avg.iter_mut().zip(albedo.iter()) {
            *avg = cosine_average(|mu| interpolate_row(row, mu));
        }
        let fresnel = PrincipledFresnel::new(Vec3::ZERO, specular_ior(SPECULAR));
        let specular_blend_avg = cosine_average(|mu| fresnel.blend_factor(mu));
        let mut glass_albedo = [[[1.0_f32; MU_STEPS]; ROUGHNESS_STEPS]; 2];
        for (side, eta) in [IOR, 1.0 / IOR].into_iter().enumerate() {
            // Row 0 (smooth) conserves energy exactly: F + (1 - F) = 1.
            for (j, row) in glass_albedo[side].iter_mut().enumerate().skip(1) {
                let alpha = grid(j, ROUGHNESS_STEPS).powi(2);
                for (i, e) in row.iter_mut().enumerate() {
                    *e = dielectric_albedo(grid(i, MU_STEPS).max(MU_FLOOR), alpha, eta);
                }
            }
        }
        EnergyTables {
            albedo,
            albedo_avg,
            specular_blend_avg,
            glass_albedo,
        }
    }

    /// Directional albedo of white single-scattering rough glass with IOR
    /// 1.45, seen from outside (`entering`) or from inside.
    pub fn glass_albedo(&self, mu: f32, roughness: f32, entering: bool) -> f32 {
        let rows = &self.glass_albedo[usize::from(!entering)];
        let (j0, j1, tj) = cell(roughness, ROUGHNESS_STEPS);
        let a = interpolate_row(&rows[j0], mu);
        let b = interpolate_row(&rows[j1], mu);
        a + (b - a) * tj
    }

    /// Directional albedo E(μ) of GGX reflection with F = 1 at `roughness`.
    pub fn albedo(&self, mu: f32, roughness: f32) -> f32 {
        let (j0, j1, tj) = cell(roughness, ROUGHNESS_STEPS);
        let a = interpolate_row(&self.albedo[j0], mu);
        let b = interpolate_row(&self.albedo[j1], mu);
        a + (b - a) * tj
    }

    /// E_avg = 2 ∫ E(μ) μ dμ at `roughness`.
    pub fn albedo_avg(&self, roughness: f32) -> f32 {
        let (j0, j1, tj) = cell(roughness, ROUGHNESS_STEPS);
        let a = self.albedo_avg[j0];
        a + (self.albedo_avg[j1] - a) * tj
    }

    /// Average of the principled Fresnel blend factor (see
    /// [`PrincipledFresnel::average`]).
    pub fn specular_blend_avg(&self) -> f32 {
        self.specular_blend_avg
    }
}

fn grid(i: usize, steps: usize) -> f32 {
    i as f32 / (steps - 1) as f32
}

/// Lower index, upper index and fraction of `x` in [0, 1] on a uniform grid.
fn cell(x: f32, steps: usize) -> (usize, usize, f32) {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let pos = x * (steps - 1) as f32;
    let i0 = (pos.floor() as usize).min(steps - 2);
    (i0, i0 + 1, pos - i0 as f32)
}

fn interpolate_row(row: &[f32; MU_STEPS], mu: f32) -> f32 {
    let (i0, i1, t) = cell(mu, MU_STEPS);
    row[i0] + (row[i1] - row[i0]) * t
}

/// 2 ∫₀¹ f(μ) μ dμ by the midpoint rule.
fn cosine_average(f: impl Fn(f32) -> f32) -> f32 {
    const N: usize = 1024;
    let sum: f64 = (0..N)
        .map(|i| {
            let mu = (i as f32 + 0.5) / N as f32;
            (f(mu) * mu) as f64
        })
        .sum();
    (2.0 * sum / N as f64) as f32
}

/// E(μ) for one alpha: with visible-normal sampling the estimator of
/// ∫ f cos dωi for F = 1 reduces to G1(wi) (separable Smith).
fn directional_albedo(mu: f32, alpha: f32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0_f64;
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u1 = (a as f32 + 0.5) / STRATA as f32;
            let u2 = (b as f32 + 0.5) / STRATA as f32;
            let h = sample_vndf(wo, alpha, u1, u2);
            let wi = reflect(wo, h);
            if wi.z > 0.0 {
                sum += ggx_g1(wi, alpha) as f64;
            }
        }
    }
    ((sum / (STRATA * STRATA) as f64) as f32).clamp(0.0, 1.0)
}

/// Albedo of white rough glass for one alpha and eta: per visible normal,
/// both branches weighted by the microfacet Fresnel, each contributing its
/// masking G1 (the visible-normal estimator of reflection and refraction).
fn dielectric_albedo(mu: f32, alpha: f32, eta: f32) -> f32 {
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0_f64;
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u1 = (a as f32 + 0.5) / STRATA as f32;
            let u2 = (b as f32 + 0.5) / STRATA as f32;
            let h = sample_vndf(wo, alpha, u1, u2);
            let f = fresnel_dielectric_cos(wo.dot(h), eta);
            let wr = reflect(wo, h);
            if wr.z > 0.0 {
                sum += (f * ggx_g1(wr, alpha)) as f64;
            }
            if let Some(wt) = refract(wo, h, eta) {
                if wt.z < 0.0 {
                    sum += ((1.0 - f) * ggx_g1(wt, alpha)) as f64;
                }
            }
        }
    }
    ((sum / (STRATA * STRATA) as f64) as f32).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ggx::ggx_d;
    use std::f32::consts::PI;

    /// Independent estimate of E(μ) by a uniform (θ, φ) grid over the
    /// hemisphere of ∫ D G1 G1 / (4 μ) dωi: no visible-normal sampling.
    fn albedo_by_hemisphere_grid(mu: f32, alpha: f32) -> f32 {
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let (nt, np) = (600, 600);
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
                let h = (wo + wi).normalize();
                let f_cos = ggx_d(h, alpha) * ggx_g1(wo, alpha) * ggx_g1(wi, alpha) / (4.0 * mu);
                let d_omega = theta.sin() * (0.5 * PI / nt as f32) * (2.0 * PI / np as f32);
                sum += (f_cos * d_omega) as f64;
            }
        }
        sum as f32
    }

    #[test]
    fn albedo_table_matches_an_independent_hemisphere_quadrature() {
        let t = tables();
        for (mu, r) in [(0.9_f32, 0.5_f32), (0.5, 0.8), (0.3, 1.0), (0.7, 0.3)] {
            let table = t.albedo(mu, r);
            let reference = albedo_by_hemisphere_grid(mu, r * r);
            assert!(
                (table - reference).abs() < 0.01,
                "mu {mu} r {r}: {table} vs {reference}"
            );
        }
    }

    #[test]
    fn albedo_is_one_for_smooth_and_falls_with_roughness() {
        let t = tables();
        assert!(t.albedo(0.7, 0.0) > 0.999);
        assert!(t.albedo(0.7, 0.05) > 0.99);
        let mut last = 1.0;
        for k in 1..=10 {
            let e = t.albedo_avg(k as f32 / 10.0);
            assert!(
                e <= last + 1e-4,
                "E_avg not falling at roughness {}",
                k as f32 / 10.0
            );
            last = e;
        }
        // Single-scatter GGX (separable Smith) at alpha 1 loses more than
        // half of its energy: E_avg = 0.377.
        assert!(
            (0.35..0.40).contains(&t.albedo_avg(1.0)),
            "{}",
            t.albedo_avg(1.0)
        );
    }

    #[test]
    fn specular_fresnel_average_matches_the_dielectric_average() {
        // Hemispherical average of the exact Fresnel for n = 1.5 is 0.0918
        // (known closed form), and F0 = 0.04, so the blend factor averages
        // (0.0918 - 0.04) / 0.96.
        let expected = (0.0918 - 0.04) / 0.96;
        assert!((tables().specular_blend_avg() - expected).abs() < 0.002);
    }

    #[test]
    fn lookups_tolerate_out_of_range_and_nan_inputs() {
        let t = tables();
        for x in [-1.0_f32, 2.0, f32::NAN, f32::INFINITY] {
            assert!(t.albedo(x, x).is_finite());
            assert!(t.albedo_avg(x).is_finite());
        }
    }
}
