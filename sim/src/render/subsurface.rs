//! The subsurface random walk: light that entered the object through the
//! subsurface lobe scatters inside a homogeneous medium until it reaches
//! the surface again.
//!
//! Free flights are exponential with a per-channel extinction `sigma_t`.
//! One channel is picked per flight with probability proportional to the
//! current RGB throughput (the "hero" channel), and the flight is weighted
//! by the one-sample MIS (balance heuristic) density over all three
//! channels, `sum_k p_k sigma_k exp(-sigma_k t)` for a scattering event and
//! `sum_k p_k exp(-sigma_k d)` for reaching the surface at distance d, so
//! every channel stays unbiased however different their mean free paths.
//! Scattering is isotropic with single-scattering albedo `albedo`. The walk
//! is capped at [`MAX_STEPS`] events (a path that long is treated as
//! absorbed: a slight darkening only for very dense, very white media) and
//! Russian roulette ends low-throughput walks. Leaving the object's
//! bounding box (an open mesh) ends the walk as absorbed.
//!
//! Boundaries: the walk only; the exit vertex's scattering belongs to the
//! BSDF (`super::shading`), its lighting to the integrator.

use super::sampling::{uniform_sphere, PixelRng};
use super::world::World;
use glam::Vec3;
use matscan_bsdf::SubsurfaceMedium;
use matscan_scan::{Ray, SurfacePoint};

/// Most scattering events of one walk.
pub const MAX_STEPS: u32 = 256;

/// Where a walk leaves the object.
#[derive(Debug, Clone, Copy)]
pub struct WalkExit {
    pub surface: SurfacePoint,
    /// Direction of travel when the walk reached the surface.
    pub dir: Vec3,
    /// Throughput of the walk (multiplies the path's).
    pub weight: Vec3,
}

/// Walks from `start` (just inside the surface) in direction `dir`.
pub fn walk(
    world: &World,
    medium: &SubsurfaceMedium,
    start: Vec3,
    dir: Vec3,
    rng: &mut PixelRng,
) -> Option<WalkExit> {
    let sigma = medium.sigma_t.max(Vec3::splat(1e-8)).min(Vec3::splat(1e12));
    let albedo = medium.albedo.clamp(Vec3::ZERO, Vec3::ONE);
    let (lo, hi) = world.object.bounds?;
    let pad = (hi - lo).max_element() * 1e-3 + world.epsilon(hi);
    let (lo, hi) = (lo - Vec3::splat(pad), hi + Vec3::splat(pad));
    let mut weight = Vec3::ONE;
    let mut pos = start;
    let mut d = dir;
    for step in 0..MAX_STEPS {
        let sum = weight.x + weight.y + weight.z;
        let probs = if sum > 0.0 && sum.is_finite() {
            weight / sum
        } else {
            return None;
        };
        let u = rng.next_f32();
        let c = if u < probs.x {
            0
        } else if u < probs.x + probs.y {
            1
        } else {
            2
        };
        let t = -(1.0 - rng.next_f32()).ln() / sigma[c];
        if !t.is_finite() {
            return None;
        }
        if let Some((th, sp)) = world.intersect_object(&Ray::segment(pos, d, 0.0, t)) {
            let tr = (-sigma * th).exp();
            let pdf = probs.dot(tr);
            if pdf.is_nan() || pdf <= 0.0 {
                return None;
            }
            weight *= tr / pdf;
            return weight.is_finite().then_some(WalkExit {
                surface: sp,
                dir: d,
                weight,
            });
        }
        let tr = (-sigma * t).exp();
        let pdf = probs.dot(sigma * tr);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        weight *= albedo * sigma * tr / pdf;
        if !(weight.is_finite() && weight.max_element() > 0.0) {
            return None;
        }
        pos += d * t;
        if pos.cmplt(lo).any() || pos.cmpgt(hi).any() {
            return None;
        }
        d = uniform_sphere(rng.next2());
        if step >= 8 {
            let q = weight.max_element().min(0.99);
            if rng.next_f32() >= q {
                return None;
            }
            weight /= q;
        }
    }
    None
}
