//! Positions where the environment drowns the rig's lights (thesis section
//! 3.1.6): the thesis compares each lit capture with the ambient one and
//! ignores a position when no lit capture differs from it by more than 0.1
//! anywhere in the (exposure-scaled) image.
//!
//! The renderer has each capture's rig-light term on its own (`lit -
//! ambient` without the ambient noise), so the difference is exact up to
//! the light's own noise. The "maximum" is taken as the 99.9th percentile
//! of the per-pixel largest channel, so a handful of Monte Carlo fireflies
//! cannot rescue a drowned position. Also reported, for inspection: the
//! rig-light to ambient ratio of mean luminance over the object.

use super::environment::luminance;
use glam::Vec3;
use matscan_scan::raster::{MaskRaster, RgbRaster};

/// Quantile standing in for the image maximum.
const ROBUST_MAX_QUANTILE: f64 = 0.999;

/// How strongly the rig's lights show against the environment at one
/// position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrownAssessment {
    /// Largest (robust) difference lit - ambient over the image, over all
    /// lit captures; exposure-scaled.
    pub max_difference: f32,
    /// Mean luminance of the rig light over mean ambient luminance on the
    /// object, best lit capture; `None` without ambient light.
    pub light_to_ambient: Option<f32>,
    /// `max_difference <= threshold`.
    pub drowned: bool,
}

/// Assesses a position from its lit captures' light-only images and its
/// ambient image; `mask` selects the object (all pixels when it is empty).
pub fn assess(
    light_only: &[&RgbRaster],
    ambient: &RgbRaster,
    mask: &MaskRaster,
    threshold: f32,
) -> DrownAssessment {
    let use_all = !mask.data.iter().any(|&m| m);
    let on_object = |i: usize| use_all || mask.data.get(i).copied().unwrap_or(false);
    let ambient_lum: f64 = ambient
        .data
        .iter()
        .enumerate()
        .filter(|(i, _)| on_object(*i))
        .map(|(_, p)| luminance(Vec3::from_array(*p)) as f64)
        .sum();
    let mut max_difference = 0.0f32;
    let mut best_ratio: Option<f32> = None;
    for img in light_only {
        let mut per_pixel: Vec<f32> = img
            .data
            .iter()
            .map(|p| p[0].max(p[1]).max(p[2]))
            .filter(|v| v.is_finite())
            .collect();
        if per_pixel.is_empty() {
            continue;
        }
        let k = ((per_pixel.len() - 1) as f64 * ROBUST_MAX_QUANTILE).round() as usize;
        let (_, q, _) = per_pixel.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        max_difference = max_difference.max(*q);
        let light_lum: f64 = img
            .data
            .iter()
            .enumerate()
            .filter(|(i, _)| on_object(*i))
            .map(|(_, p)| luminance(Vec3::from_array(*p)) as f64)
            .sum();
        if ambient_lum > 0.0 {
            let r = (light_lum / ambient_lum) as f32;
            best_ratio = Some(best_ratio.map_or(r, |b| b.max(r)));
        }
    }
    DrownAssessment {
        max_difference,
        light_to_ambient: best_ratio,
        drowned: max_difference <= threshold,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f32) -> RgbRaster {
        RgbRaster::filled(10, 10, [v; 3])
    }

    #[test]
    fn weak_lights_under_bright_ambient_are_drowned() {
        let mask = MaskRaster::filled(10, 10, true);
        let a = assess(&[&flat(0.05)], &flat(2.0), &mask, 0.1);
        assert!(a.drowned);
        assert!((a.light_to_ambient.unwrap() - 0.025).abs() < 1e-6);
        let b = assess(&[&flat(0.05), &flat(0.4)], &flat(2.0), &mask, 0.1);
        assert!(!b.drowned);
        assert!((b.max_difference - 0.4).abs() < 1e-6);
    }

    #[test]
    fn a_few_fireflies_do_not_count_as_the_maximum() {
        let mut light = RgbRaster::filled(100, 100, [0.01; 3]);
        *light.get_mut(3, 3) = [50.0; 3];
        let mask = MaskRaster::filled(100, 100, false);
        let a = assess(
            &[&light],
            &RgbRaster::filled(100, 100, [1.0; 3]),
            &mask,
            0.1,
        );
        assert!(a.drowned, "{a:?}");
    }

    #[test]
    fn no_ambient_light_has_no_ratio() {
        let mask = MaskRaster::filled(10, 10, true);
        let a = assess(&[&flat(0.3)], &flat(0.0), &mask, 0.1);
        assert_eq!(a.light_to_ambient, None);
        assert!(!a.drowned);
    }
}
