//! The forward model of one pixel: what the lit-minus-ambient photo of one
//! view should read for given BSDF parameters.
//!
//! `predicted_c = π · light_c · f_r,c(wo, wi) · cos(n, wi)`, where `light`
//! is the radiance a white Lambertian surface would send back if the light
//! arrived along its normal (photo units, exposure included): `exposure ·
//! I · colour · pattern / (π d²)` from calibration. A white diffuse surface
//! then predicts `light · cos(n, wi)`, the `illum_<capture>` truth's direct
//! part. The BSDF is the simulator's Cycles-2.9x principled BSDF
//! ([`matscan_bsdf::Bsdf`]), evaluated in a local frame
//! built from the three calibration cosines (N·V, N·L and the azimuth
//! cosine V·L of thesis eq. 3.4): an isotropic BSDF needs nothing else.
//!
//! Parameters and their space: the solver works on [`X`] = (basecolor r,
//! g, b, ln roughness, metallic), each inside a box. Roughness is fitted in
//! log space because a near-mirror lobe's width is `roughness²`: in linear
//! roughness the residual changes by orders of magnitude over 0.001, in log
//! space the steps are relative. Roughness stays at or above
//! [`ROUGHNESS_MIN`], just above Cycles' delta threshold (0.0178), where the
//! specular lobe would vanish from `eval` and the model would jump.
//!
//! What the model leaves out (and the solver's robust loss absorbs):
//! interreflections, the environment's change between captures, and
//! subsurface transport. Subsurface is evaluated as Burley diffuse (the
//! random walk is not local); transmission is held at the network's value.

use glam::Vec3;
use matscan_bsdf::material::{Material, DEFAULT_SUBSURFACE_RADIUS};
use matscan_bsdf::{Bsdf, DELTA_ALPHA};
use matscan_calib::photos::luma;
use std::f64::consts::PI;

/// Fitted parameters per pixel.
pub const N: usize = 5;
/// Index of ln roughness in [`X`].
pub const ROUGHNESS: usize = 3;
/// Index of metallic in [`X`].
pub const METALLIC: usize = 4;
/// Lowest roughness the model represents (see the module doc).
pub const ROUGHNESS_MIN: f32 = 0.02;
const _: () = assert!(ROUGHNESS_MIN * ROUGHNESS_MIN > DELTA_ALPHA);

/// A parameter vector in solver space.
pub type X = [f64; N];

/// The fitted parameters in their natural units, each in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Linear RGB.
    pub basecolor: [f32; 3],
    /// Principled roughness (GGX alpha = roughness²).
    pub roughness: f32,
    /// Metallic.
    pub metallic: f32,
}

impl Params {
    /// Solver space; out-of-range or non-finite values are clamped into the
    /// box first.
    pub fn to_x(&self) -> X {
        let unit = |v: f32| f64::from(finite_or(v, 0.5).clamp(0.0, 1.0));
        let r = finite_or(self.roughness, 0.5).clamp(ROUGHNESS_MIN, 1.0);
        [
            unit(self.basecolor[0]),
            unit(self.basecolor[1]),
            unit(self.basecolor[2]),
            f64::from(r).ln(),
            unit(self.metallic),
        ]
    }

    /// Natural units of a solver vector (clamped into the box).
    pub fn from_x(x: &X) -> Params {
        let x = clamp_to_box(x);
        Params {
            basecolor: [x[0] as f32, x[1] as f32, x[2] as f32],
            roughness: (x[ROUGHNESS].exp() as f32).clamp(ROUGHNESS_MIN, 1.0),
            metallic: x[METALLIC] as f32,
        }
    }
}

/// Lower corner of the box in solver space.
pub fn lower() -> X {
    [0.0, 0.0, 0.0, f64::from(ROUGHNESS_MIN).ln(), 0.0]
}

/// Upper corner of the box in solver space.
pub fn upper() -> X {
    [1.0, 1.0, 1.0, 0.0, 1.0]
}

/// `x` clamped into the box; non-finite entries go to the box's middle.
pub fn clamp_to_box(x: &X) -> X {
    let (lo, hi) = (lower(), upper());
    std::array::from_fn(|i| {
        if x[i].is_finite() {
            x[i].clamp(lo[i], hi[i])
        } else {
            0.5 * (lo[i] + hi[i])
        }
    })
}

/// What the pixel keeps from the networks during the fit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fixed {
    /// Transmission in [0, 1], as the network estimated it.
    pub transmission: f32,
}

/// One view of one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Toward the camera, local frame (normal = +Z).
    pub wo: Vec3,
    /// Toward the light, local frame.
    pub wi: Vec3,
    /// White-Lambertian radiance at normal incidence, RGB, photo units.
    pub light: [f32; 3],
    /// Lit minus ambient, RGB, photo units.
    pub observed: [f32; 3],
    /// Trust in [0, 1] (see `loss`); 0 drops the observation.
    pub weight: f32,
}

impl Observation {
    /// The observation `bsdf` itself would produce (full trust): what
    /// synthetic tests of a fit feed it.
    pub fn rendered(bsdf: &Bsdf, wo: Vec3, wi: Vec3, light: [f32; 3]) -> Observation {
        let mut o = Observation {
            wo,
            wi,
            light,
            observed: [0.0; 3],
            weight: 1.0,
        };
        o.observed = predict(bsdf, &o).map(|v| v as f32);
        o
    }
}

/// Local-frame directions from the calibration cosines: `wo` in the XZ
/// plane, `wi` at the azimuth whose cosine is `cos_vl`. Non-finite cosines
/// count as 0; cosines are clamped to [-1, 1].
pub fn directions(cos_nv: f32, cos_nl: f32, cos_vl: f32) -> (Vec3, Vec3) {
    let c = |v: f32| finite_or(v, 0.0).clamp(-1.0, 1.0);
    let (nv, nl, vl) = (c(cos_nv), c(cos_nl), c(cos_vl));
    let sin_v = (1.0 - nv * nv).max(0.0).sqrt();
    let sin_l = (1.0 - nl * nl).max(0.0).sqrt();
    let sin_phi = (1.0 - vl * vl).max(0.0).sqrt();
    let wo = Vec3::new(sin_v, 0.0, nv);
    let wi = Vec3::new(sin_l * vl, sin_l * sin_phi, nl);
    (wo, wi)
}

/// The principled BSDF of `x` (with `fixed`) at a point of normal +Z.
pub fn bsdf(x: &X, fixed: &Fixed) -> Bsdf {
    let p = Params::from_x(x);
    let material = Material {
        basecolor: Vec3::from_array(p.basecolor),
        roughness: p.roughness,
        metallic: p.metallic,
        transmission: finite_or(fixed.transmission, 0.0).clamp(0.0, 1.0),
        subsurface: 0.0,
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    };
    Bsdf::new(&material, Vec3::Z, Vec3::Z)
}

/// The predicted lit-minus-ambient value of `o` under `bsdf`; finite.
pub fn predict(bsdf: &Bsdf, o: &Observation) -> [f64; 3] {
    let v = bsdf.eval(o.wo, o.wi).value;
    let v = [v.x, v.y, v.z];
    std::array::from_fn(|c| {
        let p = PI * f64::from(o.light[c]) * f64::from(v[c]);
        if p.is_finite() {
            p
        } else {
            0.0
        }
    })
}

/// The white Lambertian-equivalent response `π f cos` of the
/// `illum_<capture>` truth's white diffuse material for `o`'s directions
/// (luma of RGB, all equal): what turns an illumination estimate into
/// [`Observation::light`].
pub fn white_response(wo: Vec3, wi: Vec3) -> f32 {
    let white = Bsdf::new(&Material::WHITE_DIFFUSE, Vec3::Z, Vec3::Z);
    let v = white.eval(wo, wi).value;
    let r = std::f32::consts::PI * luma(v.to_array());
    finite_or(r, 0.0)
}

fn finite_or(v: f32, fallback: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        fallback
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_reproduce_the_three_cosines() {
        let (wo, wi) = directions(0.6, 0.8, -0.3);
        assert!((wo.z - 0.6).abs() < 1e-6 && (wi.z - 0.8).abs() < 1e-6);
        assert!((wo.length() - 1.0).abs() < 1e-6 && (wi.length() - 1.0).abs() < 1e-6);
        let project = |v: Vec3| Vec3::new(v.x, v.y, 0.0).normalize();
        assert!((project(wo).dot(project(wi)) + 0.3).abs() < 1e-5);
    }

    #[test]
    fn white_diffuse_under_unit_light_predicts_about_the_cosine() {
        let x = Params {
            basecolor: [1.0; 3],
            roughness: 1.0,
            metallic: 0.0,
        }
        .to_x();
        let (wo, wi) = directions(1.0, 0.5, 0.0);
        let o = Observation {
            wo,
            wi,
            light: [1.0; 3],
            observed: [0.0; 3],
            weight: 1.0,
        };
        let p = predict(&bsdf(&x, &Fixed::default()), &o);
        // Burley at roughness 1 plus a 4% specular: near cos = 0.5.
        assert!(p[0] > 0.45 && p[0] < 0.65, "{p:?}");
        assert!((p[0] as f32 - white_response(wo, wi)).abs() < 0.01);
    }

    #[test]
    fn roughness_round_trips_through_log_space_and_stays_above_the_delta_limit() {
        let p = Params {
            basecolor: [0.2, 0.4, 0.6],
            roughness: 0.3,
            metallic: 0.7,
        };
        let back = Params::from_x(&p.to_x());
        assert!((back.roughness - 0.3).abs() < 1e-6);
        let tiny = Params {
            roughness: 1e-4,
            ..p
        };
        assert_eq!(Params::from_x(&tiny.to_x()).roughness, ROUGHNESS_MIN);
        let nan = Params::from_x(&[f64::NAN; N]);
        assert!(nan.roughness.is_finite() && nan.metallic == 0.5);
    }
}
