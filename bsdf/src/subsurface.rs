//! Subsurface scattering as Cycles 2.9x's random-walk BSSRDF sets it up: the
//! medium coefficients of the walk, and the lobe through which light leaves
//! the surface after the walk. The walk itself belongs to the integrator.
//!
//! Medium (Cycles `subsurface_random_walk_remap`, after Chiang, Kutz and
//! Burley 2016, "Practical and Controllable Subsurface Scattering"): for a
//! desired multiple-scattering albedo A (the mixed subsurface base colour)
//! and scattering distance d (= subsurface × subsurface radius) per channel,
//!
//! - single-scattering albedo α = 1 - exp(A (-5.09406 + A (2.61188 - 4.31805 A))),
//! - s = 1.9 - A + 3.5 (A - 0.8)²,
//! - extinction σt = 1 / max(d s, 1e-16), scattering σs = α σt;
//!
//! with an isotropic phase function (Cycles 2.9x walks with anisotropy 0) and
//! no refraction at the boundary. So the mean free path is d·s, not d: the
//! fit picks s so that the radius controls the visible blur, and α so that a
//! semi-infinite slab returns about A.
//!
//! Exit: Cycles 2.9x replaces the closures at the exit point by one principled
//! (Burley) diffuse with the entry's roughness and with the view direction
//! set to the exit normal (`sd->I = sd->N`), so only the light side keeps its
//! Fresnel factor: f cos = (1/π) cos θi (1 + (Fd90 - 1)(1 - cos θi)^5),
//! Fd90 = 0.5 + roughness (1 + cos θi). No Fresnel transmission weight at
//! entry or exit (2.9x has none).

use super::diffuse::{burley_cos, cosine_pdf, sample_cosine};
use super::frame::{ShadingFrame, SurfaceNormals};
use super::lobe::{BsdfEval, BsdfSample, LobeKind};
use glam::Vec3;

/// Cycles' `BSSRDF_MIN_RADIUS`: channels with a smaller scattering distance
/// fall back to the plain Burley diffuse.
pub const BSSRDF_MIN_RADIUS: f32 = 1e-8;

/// Single-scattering albedo α for the desired multiple-scattering albedo A.
pub fn single_scattering_albedo(a: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    (1.0 - (a * (-5.09406 + a * (2.61188 - a * 4.31805))).exp()).clamp(0.0, 1.0)
}

/// Extinction σt for multiple-scattering albedo A and scattering distance d.
pub fn extinction(a: f32, d: f32) -> f32 {
    let a = a.clamp(0.0, 1.0);
    let s = 1.9 - a + 3.5 * (a - 0.8) * (a - 0.8);
    1.0 / (d * s).max(1e-16)
}

/// Homogeneous medium of a subsurface random walk, per RGB channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubsurfaceMedium {
    /// Extinction coefficient per scene unit.
    pub sigma_t: Vec3,
    /// Single-scattering albedo σs / σt in [0, 1].
    pub albedo: Vec3,
    /// Roughness of the Burley exit lobe (the material's roughness).
    pub exit_roughness: f32,
}

impl SubsurfaceMedium {
    /// Cycles' remap from the multiple-scattering albedo and scattering
    /// distance (both per channel).
    pub fn from_albedo_and_radius(
        multiple_scattering_albedo: Vec3,
        radius: Vec3,
        exit_roughness: f32,
    ) -> SubsurfaceMedium {
        let a = multiple_scattering_albedo.to_array();
        let d = radius.to_array();
        SubsurfaceMedium {
            sigma_t: Vec3::from_array(std::array::from_fn(|c| extinction(a[c], d[c]))),
            albedo: Vec3::from_array(std::array::from_fn(|c| single_scattering_albedo(a[c]))),
            exit_roughness: exit_roughness.clamp(0.0, 1.0),
        }
    }

    /// Scattering coefficient σs = albedo σt.
    pub fn sigma_s(&self) -> Vec3 {
        self.albedo * self.sigma_t
    }

    /// The exit lobe at the point where the walk leaves the surface; `n` and
    /// `ng` are that point's shading and geometric normals, facing out of
    /// the object.
    pub fn exit(&self, n: Vec3, ng: Vec3) -> SubsurfaceExit {
        SubsurfaceExit::new(self.exit_roughness, n, ng)
    }
}

/// Burley diffuse seen from the normal: the lobe light leaves by after a walk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubsurfaceExit {
    roughness: f32,
    frame: Option<ShadingFrame>,
}

impl SubsurfaceExit {
    pub fn new(roughness: f32, n: Vec3, ng: Vec3) -> SubsurfaceExit {
        let normals = SurfaceNormals::new(n, ng);
        SubsurfaceExit {
            roughness: roughness.clamp(0.0, 1.0),
            frame: normals.frame(normals.shading()),
        }
    }

    /// f cos θi (colourless: the walk's throughput carries the colour) and
    /// the cosine density of [`Self::sample`].
    pub fn eval(&self, wi: Vec3) -> BsdfEval {
        let Some(frame) = self.frame else {
            return BsdfEval::ZERO;
        };
        let wi = wi.normalize_or_zero();
        let cos_g = frame.geometric_cos(wi);
        if cos_g.is_nan() || cos_g <= 0.0 {
            return BsdfEval::ZERO;
        }
        let local = frame.to_local(wi);
        if local.z.is_nan() || local.z <= 0.0 {
            return BsdfEval::ZERO;
        }
        BsdfEval {
            value: Vec3::splat(burley_cos(Vec3::Z, local, self.roughness)),
            pdf: cosine_pdf(local),
        }
    }

    /// A cosine-distributed exit direction from u in [0,1)²; None when it
    /// falls below the geometric surface.
    pub fn sample(&self, u: [f32; 2]) -> Option<BsdfSample> {
        let frame = self.frame?;
        let local = sample_cosine(clamp_unit(u[0]), clamp_unit(u[1]));
        let wi = frame.to_world(local).normalize_or_zero();
        let e = self.eval(wi);
        if e.pdf.is_nan() || e.pdf <= 0.0 {
            return None;
        }
        let weight = e.value / e.pdf;
        weight.is_finite().then_some(BsdfSample {
            wi,
            weight,
            pdf: e.pdf,
            kind: LobeKind::Reflection,
            specular_delta: false,
        })
    }
}

/// A random number forced into [0, 1) (NaN to 0).
pub(crate) fn clamp_unit(u: f32) -> f32 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, 1.0 - f32::EPSILON / 2.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;
    use rand_pcg::Pcg32;

    #[test]
    fn remap_matches_cycles_constants() {
        assert_eq!(single_scattering_albedo(0.0), 0.0);
        let expected = 1.0 - (-5.09406_f32 + 2.61188 - 4.31805).exp();
        assert!((single_scattering_albedo(1.0) - expected).abs() < 1e-6);
        // s(1) = 1.9 - 1 + 3.5 * 0.04 = 1.04; s(0.8) = 1.1.
        assert!((extinction(1.0, 2.0) - 1.0 / 2.08).abs() < 1e-6);
        assert!((extinction(0.8, 1.0) - 1.0 / 1.1).abs() < 1e-6);
        assert!(extinction(0.5, 0.0).is_finite());
    }

    /// Multiple-scattering albedo of an index-matched half-space z < 0 with
    /// cosine-distributed entry, isotropic scattering and single-scattering
    /// albedo α, by an analogue random walk.
    fn half_space_albedo(alpha: f32, walks: usize, rng: &mut Pcg32) -> f32 {
        let mut escaped = 0usize;
        for _ in 0..walks {
            let mut z = 0.0_f32;
            let mut dir_z = -(1.0 - rng.gen::<f32>()).sqrt(); // cosine into -z
            loop {
                let t = -(1.0 - rng.gen::<f32>()).ln(); // sigma_t = 1
                z += t * dir_z;
                if z >= 0.0 {
                    escaped += 1;
                    break;
                }
                if rng.gen::<f32>() >= alpha {
                    break;
                }
                dir_z = 2.0 * rng.gen::<f32>() - 1.0; // isotropic
            }
        }
        escaped as f32 / walks as f32
    }

    #[test]
    fn remapped_medium_returns_about_the_desired_albedo() {
        // Pins how close Cycles' fit is for the walk the integrator runs
        // (index matched, isotropic, cosine entry): within a percent up to
        // A = 0.8; near-white media return ~5% less (0.90 for A = 0.95).
        let mut rng = Pcg32::new(3, 5);
        for (a, tolerance) in [(0.2_f32, 0.015), (0.5, 0.015), (0.8, 0.015), (0.95, 0.07)] {
            let got = half_space_albedo(single_scattering_albedo(a), 20_000, &mut rng);
            assert!((got - a).abs() < tolerance, "A {a}: walk returns {got}");
        }
    }

    #[test]
    fn exit_lobe_albedo_matches_closed_form_and_sampling_is_consistent() {
        // ∫ f cos = 1 - 1/42 + r * 5/84 (the Burley lobe seen from the normal).
        let mut rng = Pcg32::new(9, 1);
        for r in [0.0_f32, 1.0] {
            let exit = SubsurfaceExit::new(r, Vec3::Y, Vec3::Y);
            let n = 40_000;
            let mut sum = 0.0;
            for _ in 0..n {
                let s = exit.sample([rng.gen(), rng.gen()]).unwrap();
                let e = exit.eval(s.wi);
                assert!((e.pdf - s.pdf).abs() <= 1e-4 * s.pdf);
                sum += s.weight.x;
            }
            let expected = 1.0 - 1.0 / 42.0 + r * 5.0 / 84.0;
            assert!(
                (sum / n as f32 - expected).abs() < 0.01,
                "r {r}: {}",
                sum / n as f32
            );
        }
    }

    #[test]
    fn exit_lobe_is_zero_below_the_surface() {
        let exit = SubsurfaceExit::new(0.5, Vec3::Z, Vec3::Z);
        assert_eq!(exit.eval(-Vec3::Z), BsdfEval::ZERO);
        assert_eq!(exit.eval(Vec3::X), BsdfEval::ZERO);
        assert!(exit.eval(Vec3::Z).value.x > 0.0);
    }
}
