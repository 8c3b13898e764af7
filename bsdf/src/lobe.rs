//! Results the BSDF hands to the integrator: an evaluation and a sample.

use glam::Vec3;

/// Value and density of one direction pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfEval {
    /// f(wo, wi) |cos(n, wi)|, RGB, with the lobe weights applied.
    pub value: Vec3,
    /// Solid-angle density with which [`super::Bsdf::sample`] produces `wi`
    /// through a non-delta lobe (selection probability included). Integrates
    /// to less than one when delta or subsurface-entry lobes take a share.
    pub pdf: f32,
}

impl BsdfEval {
    pub const ZERO: BsdfEval = BsdfEval {
        value: Vec3::ZERO,
        pdf: 0.0,
    };
}

/// What a sampled direction does at the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LobeKind {
    /// `wi` leaves on the side of `wo` (above the geometric surface facing wo).
    Reflection,
    /// `wi` refracts through the surface (glass lobe).
    Transmission,
    /// `wi` points into the object: the integrator starts a subsurface random
    /// walk with [`super::Bsdf::subsurface_medium`].
    SubsurfaceEntry,
}

/// One sampled direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Unit world direction, away from the surface point.
    pub wi: Vec3,
    /// f cos / pdf, selection probability included: multiply the path
    /// throughput by it. For [`LobeKind::SubsurfaceEntry`] it is the walk's
    /// starting throughput, without the colour (the walk supplies it).
    pub weight: Vec3,
    /// For non-delta Reflection / Transmission samples, the same density as
    /// `eval(wo, wi).pdf` (for MIS). For delta samples, the discrete
    /// probability of having picked this delta direction. For subsurface
    /// entries, the selection probability times the cosine density of the
    /// entry direction (informational; entries take no part in MIS).
    pub pdf: f32,
    pub kind: LobeKind,
    /// True when `wi` came from a delta (perfectly smooth) lobe: light
    /// sampling cannot reach it, so no MIS with lights applies.
    pub specular_delta: bool,
}
