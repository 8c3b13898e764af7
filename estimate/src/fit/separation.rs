//! Direct and global light apart, from the projector's uniform field and
//! a checkerboard (Nayar et al. 2006, "Fast separation of direct and
//! global components of a scene using high frequency illumination").
//!
//! Under a checkerboard of levels `high` and `low`, a surface point gets
//! the direct light of the square it lies in and, to first order, the
//! global light (interreflections off the rig and the object, light
//! scattered inside it) of the pattern's mean `(high + low) / 2`. With the
//! uniform capture's total `T = D + G` (at full white), a point in a high
//! square shows `high·D + mean·G`, a point in a low square `low·D + mean·G`,
//! so each gives `G` in closed form. The rig has no complement pattern, so
//! the uniform capture stands in for it.
//!
//! Only points well inside a square count (the photo blurs an edge over a
//! pixel or two, and a warp another); the global light is smooth, so the
//! points between are filled from their neighbours. The coarsest checker
//! is used: its squares cover the most pixels, and the pattern only needs
//! to be fine against the global light's spread, which interreflections
//! off the rig are.
//!
//! The fit subtracts from every lit view the global light that view's
//! light puts there: global light scales with the power the light sends
//! to the scene, taken per pixel as the ratio of the calibrated light
//! (`I · colour / d²`) to the projector's.

use crate::pipeline::inputs::scaled_photo;
use crate::refine::RefineError;
use matscan_calib::ScanCalibration;
use matscan_scan::raster::RgbRaster;
use matscan_scan::{Bundle, LightKind, Pattern};

/// Pixels of margin to a checker edge, in the position's own image.
pub const EDGE_MARGIN: usize = 2;
/// Radius of the window that fills pixels near an edge from the measured
/// ones around them.
pub const FILL_RADIUS: usize = 4;

/// The global light of one position at full projector white, in its own
/// camera image and ambient exposure units.
#[derive(Clone, Debug, PartialEq)]
pub struct GlobalLight {
    /// The projector it was measured with.
    pub projector: String,
    /// In the position's camera image; NaN where neither the pixel nor
    /// any within [`FILL_RADIUS`] could be measured.
    pub rgb: RgbRaster,
    /// The share of the object's pixels measured directly (not filled).
    pub measured: f32,
}

/// The global light of `position`, or `None` with the reason where the
/// scan cannot give it (no projector, no uniform or checker capture, no
/// calibrated projector pattern).
pub fn global_light(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    position: &str,
) -> Result<Result<GlobalLight, String>, RefineError> {
    let pos = bundle.position(position)?;
    let Some(projector) = pos
        .lights
        .iter()
        .find(|l| matches!(l.kind, LightKind::Projector { .. }))
    else {
        return Ok(Err(format!("position {position}: no projector")));
    };
    let Some(ambient) = pos.ambient() else {
        return Ok(Err(format!("position {position}: no ambient capture")));
    };
    let Some((uniform, level)) = pos
        .lit_captures()
        .filter(|(_, light)| *light == projector.name)
        .find_map(|(c, _)| Some((c, c.uniform_level().filter(|&l| l > 0.0)?)))
    else {
        return Ok(Err(format!(
            "position {position}: no uniform capture of `{}`",
            projector.name
        )));
    };
    let checker = pos
        .pattern_captures()
        .filter(|c| c.lights.contains(&projector.name))
        .filter_map(|c| match c.pattern {
            Some(Pattern::Checker {
                period_px,
                low,
                high,
                ..
            }) if period_px.is_finite() && high.is_finite() && low.is_finite() && high > low => {
                Some((c, period_px, low, high))
            }
            _ => None,
        })
        .max_by(|a, b| a.1.total_cmp(&b.1));
    let Some((checker, _, low, high)) = checker else {
        return Ok(Err(format!(
            "position {position}: no checker capture of `{}`",
            projector.name
        )));
    };
    let Some(maps) = calibration.position(position) else {
        return Err(RefineError::MissingMaps(position.to_string()));
    };
    let sharp = maps
        .maps
        .projector(&projector.name)
        .and_then(|p| p.patterns.iter().find(|(name, _)| *name == checker.name))
        .map(|(_, values)| values);
    let (Some(sharp), Some(lit)) = (sharp, maps.maps.light(&projector.name).map(|l| &l.lit)) else {
        return Err(RefineError::MissingMaps(format!(
            "{position}/{}",
            checker.name
        )));
    };
    let exposure = ambient.exposure_s;
    let a = scaled_photo(bundle, position, &ambient.name, exposure)?;
    let u = scaled_photo(bundle, position, &uniform.name, exposure)?;
    let c = scaled_photo(bundle, position, &checker.name, exposure)?;
    let mask = &maps.maps.geometry.mask;
    let (w, h) = (mask.width as usize, mask.height as usize);
    let n = w * h;
    if [
        a.data.len(),
        u.data.len(),
        c.data.len(),
        sharp.data.len(),
        lit.data.len(),
    ]
    .iter()
    .any(|&len| len != n)
    {
        return Ok(Err(format!(
            "position {position}: the projector's photos and maps differ in size"
        )));
    }
    let object = |i: usize| mask.data[i] && lit.data[i];
    let separated = Separation {
        level: level as f32,
        low: low as f32,
        high: high as f32,
    };
    let measured: Vec<Option<[f32; 3]>> = (0..n)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let inside = window(x, y, w, h, EDGE_MARGIN)
                .all(|j| object(j) && sharp.data[j] == sharp.data[i]);
            if !inside {
                return None;
            }
            let lit_square =
                (sharp.data[i] - separated.high).abs() < (sharp.data[i] - separated.low).abs();
            separated.global(a.data[i], u.data[i], c.data[i], lit_square)
        })
        .collect();
    let objects = (0..n).filter(|&i| object(i)).count().max(1);
    let direct = (0..n).filter(|&i| measured[i].is_some()).count();
    let rgb = (0..n)
        .map(|i| {
            if !mask.data[i] {
                return [f32::NAN; 3];
            }
            if let Some(g) = measured[i] {
                return g;
            }
            let (x, y) = (i % w, i / w);
            let mut sum = [0.0f64; 3];
            let mut count = 0usize;
            for g in window(x, y, w, h, FILL_RADIUS).filter_map(|j| measured[j]) {
                for k in 0..3 {
                    sum[k] += f64::from(g[k]);
                }
                count += 1;
            }
            if count == 0 {
                return [f32::NAN; 3];
            }
            sum.map(|s| (s / count as f64) as f32)
        })
        .collect();
    Ok(Ok(GlobalLight {
        projector: projector.name.clone(),
        rgb: RgbRaster {
            width: mask.width,
            height: mask.height,
            data: rgb,
        },
        measured: direct as f32 / objects as f32,
    }))
}

/// The pixels of the `(2 radius + 1)²` window around `(x, y)` inside a
/// `w × h` image.
fn window(x: usize, y: usize, w: usize, h: usize, radius: usize) -> impl Iterator<Item = usize> {
    let (x0, x1) = (x.saturating_sub(radius), (x + radius).min(w - 1));
    let (y0, y1) = (y.saturating_sub(radius), (y + radius).min(h - 1));
    (y0..=y1).flat_map(move |yy| (x0..=x1).map(move |xx| yy * w + xx))
}

/// The levels of one uniform and one checker capture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Separation {
    /// The uniform capture's level.
    pub level: f32,
    pub low: f32,
    pub high: f32,
}

impl Separation {
    /// The global light at full white of a point with ambient `a`, uniform
    /// photo `u` and checker photo `c`, in a high square or not; `None`
    /// where a value is not finite. Clamped to `[0, total]`: noise can
    /// push either form past what is physical.
    pub fn global(&self, a: [f32; 3], u: [f32; 3], c: [f32; 3], high: bool) -> Option<[f32; 3]> {
        let mean = 0.5 * (self.high + self.low);
        let mut g = [0.0f32; 3];
        for k in 0..3 {
            let total = (u[k] - a[k]) / self.level;
            let checker = c[k] - a[k];
            let value = if high {
                (self.high * total - checker) / (self.high - mean)
            } else {
                (checker - self.low * total) / (mean - self.low)
            };
            if !value.is_finite() || !total.is_finite() {
                return None;
            }
            g[k] = value.clamp(0.0, total.max(0.0));
        }
        Some(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separation_returns_the_global_light_of_a_synthetic_point_in_either_square() {
        let s = Separation {
            level: 0.5,
            low: 0.1,
            high: 0.9,
        };
        let (direct, global, ambient) = (0.6f32, 0.3f32, 0.05f32);
        let mean = 0.5 * (s.high + s.low);
        let u = [ambient + s.level * (direct + global); 3];
        let c_high = [ambient + s.high * direct + mean * global; 3];
        let c_low = [ambient + s.low * direct + mean * global; 3];
        for (c, high) in [(c_high, true), (c_low, false)] {
            let g = s.global([ambient; 3], u, c, high).unwrap();
            for k in 0..3 {
                assert!((g[k] - global).abs() < 1e-5, "{g:?}");
            }
        }
    }

    #[test]
    fn separation_of_noise_stays_between_zero_and_the_total_and_nan_gives_none() {
        let s = Separation {
            level: 1.0,
            low: 0.0,
            high: 1.0,
        };
        // A high square brighter than the uniform field: global below 0.
        let g = s.global([0.0; 3], [1.0; 3], [1.3; 3], true).unwrap();
        assert_eq!(g, [0.0; 3]);
        // A dark square brighter than the uniform field: global above it.
        let g = s.global([0.0; 3], [1.0; 3], [0.8; 3], false).unwrap();
        assert_eq!(g, [1.0; 3]);
        assert_eq!(s.global([0.0; 3], [f32::NAN; 3], [0.5; 3], true), None);
    }
}
