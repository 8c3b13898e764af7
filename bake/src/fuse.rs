//! Fusion: every texel's surface point is projected into every position
//! that has maps, tested for visibility, and the map values found there
//! are averaged with weights.
//!
//! A position sees a texel when the surface faces its camera (geometric
//! and shading normal), the point projects inside the image onto a valid
//! (masked) pixel, and a ray from the point to the camera centre is not
//! blocked by the mesh. Its weight is the product of
//! - the view angle: `cos θ · smoothstep(0, GRAZING_COS, cos θ)` between
//!   the shading normal and the view direction (the foreshortened pixel
//!   footprint, fading to 0 toward grazing);
//! - the silhouette distance: `clamp((d - 0.5) / SILHOUETTE_RAMP_PX, 0,
//!   1)` with `d` the distance transform of the valid mask (edge pixels
//!   mix object and background, so they count little, not nothing);
//! - illumination: 1 where some posed light reaches the pixel,
//!   [`FuseOptions::unlit_weight`] where none does (the networks have
//!   only ambient light to go on there);
//! - per parameter, its confidence map (1 where absent), floored at
//!   [`MIN_CONFIDENCE`] so that a texel every view knows only from the
//!   prior still gets that prior rather than a hole.
//!
//! Coverage is "some position has a positive weight", whatever the
//! parameter. Map values are read bilinearly over valid pixels only.

use crate::atlas::Atlas;
use crate::sampling::Taps;
use crate::views::PositionView;
use glam::Vec2;
use matscan_scan::bvh::RayCaster;
use rayon::prelude::*;

/// Cosine below which the view-angle weight fades to 0 (about 73°).
pub const GRAZING_COS: f32 = 0.3;
/// Pixels over which the silhouette weight rises from 0 to 1.
pub const SILHOUETTE_RAMP_PX: f32 = 2.0;
/// Smallest confidence a view's value keeps.
pub const MIN_CONFIDENCE: f32 = 0.02;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FuseOptions {
    /// Weight factor for a texel no posed light reaches in that position.
    pub unlit_weight: f32,
}

impl Default for FuseOptions {
    fn default() -> Self {
        Self { unlit_weight: 0.1 }
    }
}

/// Weighted sums per parameter slot: `sum` interleaved by channel
/// (`channels[slot]` per texel), `weight` one per texel.
pub(crate) struct Fused {
    pub sums: Vec<Vec<f32>>,
    pub weights: Vec<Vec<f32>>,
    pub coverage: Vec<bool>,
}

/// One texel row's sums, weights (per slot) and coverage.
type FusedRow = (Vec<Vec<f32>>, Vec<Vec<f32>>, Vec<bool>);

/// Fuses `views` into the atlas's texels for slots of `channels`.
pub(crate) fn fuse(
    atlas: &Atlas,
    caster: &RayCaster,
    uvs: &[Vec2],
    views: &[PositionView],
    channels: &[usize],
    options: &FuseOptions,
) -> Fused {
    let (w, h) = (atlas.width() as usize, atlas.height() as usize);
    let slots = channels.len();
    let unlit = options.unlit_weight.clamp(0.0, 1.0);
    let rows: Vec<FusedRow> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut sums: Vec<Vec<f32>> = channels.iter().map(|&c| vec![0.0; w * c]).collect();
            let mut weights: Vec<Vec<f32>> = vec![vec![0.0; w]; slots];
            let mut coverage = vec![false; w];
            let mut value = [0.0f32; 3];
            for x in 0..w {
                let Some(sp) = atlas.surface(&caster.mesh, uvs, x as u32, y as u32) else {
                    continue;
                };
                for view in views {
                    let to_cam = view.center - sp.position;
                    let Some(dir) = to_cam.try_normalize() else {
                        continue;
                    };
                    let cos = sp.shading_normal.dot(dir);
                    if cos <= 0.0 || sp.geometric_normal.dot(dir) <= 0.0 {
                        continue;
                    }
                    let Some(px) = view.camera.project(sp.position.as_dvec3()) else {
                        continue;
                    };
                    if !(px.x >= 0.0
                        && px.y >= 0.0
                        && px.x < view.width as f64
                        && px.y < view.height as f64)
                    {
                        continue;
                    }
                    let pixel = px.y as usize * view.width + px.x as usize;
                    if !view.valid[pixel] {
                        continue;
                    }
                    let sil = ((view.silhouette[pixel] - 0.5) / SILHOUETTE_RAMP_PX).clamp(0.0, 1.0);
                    let angle = cos * smoothstep(0.0, GRAZING_COS, cos);
                    let taps = Taps::at(px.x, px.y, view.width, view.height);
                    let lit = taps.scalar(&view.lit);
                    let weight = angle * sil * (unlit + (1.0 - unlit) * lit);
                    if weight <= 0.0 || !weight.is_finite() {
                        continue;
                    }
                    let origin = caster.offset(sp.position, sp.geometric_normal);
                    if !caster.visible(origin, view.center) {
                        continue;
                    }
                    coverage[x] = true;
                    for (slot, map) in view.maps.iter().enumerate() {
                        let Some(map) = map else { continue };
                        if !taps.masked(&map.values, &view.valid, &mut value) {
                            continue;
                        }
                        let conf = map
                            .confidence
                            .as_ref()
                            .map_or(1.0, |c| taps.scalar(c))
                            .max(MIN_CONFIDENCE);
                        let wt = weight * conf;
                        let c = channels[slot];
                        for ch in 0..c {
                            sums[slot][x * c + ch] += wt * value[ch];
                        }
                        weights[slot][x] += wt;
                    }
                }
            }
            (sums, weights, coverage)
        })
        .collect();
    let mut fused = Fused {
        sums: channels
            .iter()
            .map(|&c| Vec::with_capacity(w * h * c))
            .collect(),
        weights: vec![Vec::with_capacity(w * h); slots],
        coverage: Vec::with_capacity(w * h),
    };
    for (sums, weights, coverage) in rows {
        for slot in 0..slots {
            fused.sums[slot].extend_from_slice(&sums[slot]);
            fused.weights[slot].extend_from_slice(&weights[slot]);
        }
        fused.coverage.extend_from_slice(&coverage);
    }
    fused
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
