//! What a projector shows each surface point: the projector pixel that
//! lights it and, from that, the sharp (unblurred) pattern value expected
//! there under each checker capture.
//!
//! The expected value is the contract's checkerboard at the integer
//! projector pixel containing the point's projection (`floor` of the
//! continuous coordinates, pixel centres at +0.5), where the projector
//! lights the point ([`crate::lights::LightMaps::lit`]); 0 everywhere else,
//! background included. Subsurface scattering shows as the photo's blur
//! relative to this sharp map.

use crate::geometry::to_f64;
use crate::lights::{LightMaps, LightSource};
use crate::par::par_raster;
use matscan_scan::raster::{RgbRaster, ScalarRaster};
use matscan_scan::{CaptureRole, Pattern, Position, Raster};

/// Projector maps for one projector at one position.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectorMaps {
    pub light: String,
    /// Continuous projector pixel coordinates (column, row) lighting each
    /// surface point; 0 where the projector does not light it.
    pub pixel: Raster<[f32; 2]>,
    /// Per checker capture of this projector, in manifest order: (capture
    /// name, expected sharp pattern value).
    pub patterns: Vec<(String, ScalarRaster)>,
}

/// Projector maps from a projector's light maps and the world position
/// map; `None` when `maps` belongs to a point light.
pub fn projector_maps(
    position: &Position,
    maps: &LightMaps,
    world: &RgbRaster,
) -> Option<ProjectorMaps> {
    if !matches!(maps.source, LightSource::Projector(_)) {
        return None;
    }
    // Exact f64 coordinates decide the checker square; the f32 map is for
    // output only (its rounding could move a point across a square edge).
    let exact = par_raster(world.width, world.height, |x, y| {
        if !*maps.lit.get(x, y) {
            return None;
        }
        maps.source.projector_pixel(to_f64(world.get(x, y)))
    });
    let pixel = exact.map(|q| q.map_or([0.0, 0.0], |q| [q.x as f32, q.y as f32]));
    let role = CaptureRole::Pattern {
        light: maps.light.clone(),
    };
    let patterns = position
        .captures
        .iter()
        .filter(|c| c.role(&position.lights) == role)
        .filter_map(|c| c.pattern.map(|p| (c.name.clone(), p)))
        .map(|(name, pattern)| {
            let values = exact.map(|q| q.map_or(0.0, |q| pattern_value(&pattern, q) as f32));
            (name, values)
        })
        .collect();
    Some(ProjectorMaps {
        light: maps.light.clone(),
        pixel,
        patterns,
    })
}

/// The sharp value of `pattern` at projector pixel coordinates `q`.
pub fn pattern_value(pattern: &Pattern, q: glam::DVec2) -> f64 {
    pattern.value_at(q.x.floor() as i64, q.y.floor() as i64)
}
