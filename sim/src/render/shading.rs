//! The scattering function at a path vertex, behind one interface for the
//! integrator: the Principled BSDF of the object (`matscan_bsdf`), the
//! Lambertian reflectors (the backlight panel, and the white diffuse of the
//! `illum_` truth renders), and the exit of a subsurface random walk.
//!
//! "White diffuse" is an ideal Lambertian of albedo 1 (no Fresnel
//! specular), so an `illum_` pixel is exactly irradiance / pi: the local
//! illumination target the thesis renders with Blender's diffuse white.
//!
//! Directions `wo` and `wi` point away from the surface; `eval` returns
//! `f * |cos(wi)|` and the solid-angle density of `sample` producing `wi`.

use super::sampling::{cosine_hemisphere, Frame};
use glam::Vec3;
use matscan_bsdf::material::Material;
use matscan_bsdf::{Bsdf, BsdfEval, BsdfSample, LobeKind, SubsurfaceExit, SubsurfaceMedium};
use matscan_scan::SurfacePoint;
use std::f32::consts::FRAC_1_PI;

/// `f * |cos|` and the sampling density of a direction pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Eval {
    pub value: Vec3,
    pub pdf: f32,
}

impl Eval {
    pub const ZERO: Eval = Eval {
        value: Vec3::ZERO,
        pdf: 0.0,
    };
}

/// What kind of event a sampled direction is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lobe {
    Reflection,
    /// Through the surface, continuing on the other side.
    Transmission,
    /// Into the object, where a subsurface random walk takes over.
    SubsurfaceEntry,
}

#[derive(Debug, Clone, Copy)]
pub struct Sampled {
    pub wi: Vec3,
    /// `f * |cos| / pdf` (for a delta lobe, the lobe's weight).
    pub weight: Vec3,
    pub pdf: f32,
    pub lobe: Lobe,
    /// A mirror or perfectly smooth refraction: light sampling cannot reach
    /// it, so emitters hit next take full weight.
    pub delta: bool,
}

/// A two-sided Lambertian reflector: it reflects on the side of `wo`
/// (decided by the geometric normal), shading with the shading normal.
#[derive(Debug, Clone, Copy)]
pub struct Lambert {
    albedo: Vec3,
    ns: Vec3,
    ng: Vec3,
}

impl Lambert {
    pub fn new(albedo: Vec3, ns: Vec3, ng: Vec3) -> Self {
        Lambert {
            albedo: albedo.clamp(Vec3::ZERO, Vec3::ONE),
            ns,
            ng,
        }
    }

    /// Shading normal turned to the side of `wo`.
    fn oriented(&self, wo: Vec3) -> (Vec3, Vec3) {
        if wo.dot(self.ng) >= 0.0 {
            (self.ns, self.ng)
        } else {
            (-self.ns, -self.ng)
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Eval {
        let (ns, ng) = self.oriented(wo);
        let cos = wi.dot(ns);
        if wi.dot(ng) <= 0.0 || cos <= 0.0 {
            return Eval::ZERO;
        }
        Eval {
            value: self.albedo * (cos * FRAC_1_PI),
            pdf: cos * FRAC_1_PI,
        }
    }

    pub fn sample(&self, wo: Vec3, u: [f32; 3]) -> Option<Sampled> {
        let (ns, ng) = self.oriented(wo);
        let wi = Frame::from_normal(ns).to_world(cosine_hemisphere([u[0], u[1]]));
        let cos = wi.dot(ns);
        if wi.dot(ng) <= 0.0 || cos <= 1e-7 {
            return None;
        }
        Some(Sampled {
            wi,
            weight: self.albedo,
            pdf: cos * FRAC_1_PI,
            lobe: Lobe::Reflection,
            delta: false,
        })
    }
}

/// The scattering function at one vertex.
#[derive(Debug, Clone)]
pub enum Shader {
    Lambert(Lambert),
    Principled(Bsdf),
    /// Where a subsurface walk leaves the object (colourless: the walk's
    /// throughput carries the colour).
    SubsurfaceExit(SubsurfaceExit),
}

impl Shader {
    /// The object's Principled BSDF at a surface point.
    pub fn principled(m: &Material, sp: &SurfacePoint) -> Shader {
        Shader::Principled(Bsdf::new(m, sp.shading_normal, sp.geometric_normal))
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Eval {
        match self {
            Shader::Lambert(l) => l.eval(wo, wi),
            Shader::Principled(b) => from_bsdf_eval(b.eval(wo, wi)),
            Shader::SubsurfaceExit(x) => from_bsdf_eval(x.eval(wi)),
        }
    }

    pub fn sample(&self, wo: Vec3, u: [f32; 3]) -> Option<Sampled> {
        match self {
            Shader::Lambert(l) => l.sample(wo, u),
            Shader::Principled(b) => b.sample(wo, u).map(from_bsdf_sample),
            Shader::SubsurfaceExit(x) => x.sample([u[1], u[2]]).map(from_bsdf_sample),
        }
    }

    /// The random-walk medium, when this is a subsurface material.
    pub fn subsurface_medium(&self) -> Option<SubsurfaceMedium> {
        match self {
            Shader::Principled(b) => b.subsurface_medium(),
            _ => None,
        }
    }
}

fn from_bsdf_eval(e: BsdfEval) -> Eval {
    Eval {
        value: e.value,
        pdf: e.pdf,
    }
}

fn from_bsdf_sample(s: BsdfSample) -> Sampled {
    Sampled {
        wi: s.wi,
        weight: s.weight,
        pdf: s.pdf,
        lobe: match s.kind {
            LobeKind::Reflection => Lobe::Reflection,
            LobeKind::Transmission => Lobe::Transmission,
            LobeKind::SubsurfaceEntry => Lobe::SubsurfaceEntry,
        },
        delta: s.specular_delta,
    }
}
