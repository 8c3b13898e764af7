//! Bad light (thesis 3.1.6): a position where the environment drowns the
//! rig's lights. The thesis compares every lit capture with the ambient one
//! and drops the position when the maximum difference is below 0.1; the
//! estimator leaves such a position out and reports why.
//!
//! The difference is per pixel the largest channel of `lit - ambient`
//! (ambient rescaled to the lit capture's exposure), in the lit photo's
//! units, as the thesis's renders were. Its "maximum" is taken over the
//! finite pixels after leaving out the brightest 0.1% of them, and at least
//! the 8 brightest, so a few hot pixels of a real camera cannot make a
//! drowned light look visible; on noise-free renders lit by a light
//! covering more than that, the two agree.
//!
//! A position is flagged when *any* of its lit captures stays below the
//! threshold. The thesis's words are "we check if the maximum difference of
//! any of them is below a threshold of 0.1"; the reading "any one capture's
//! maximum" is also the one that fits its purpose: the networks take every
//! lit capture as input, and a capture drowned by the environment feeds
//! them an input that carries nothing, whatever the other lights show. This
//! is the project's one implementation of the rule: the simulator applies
//! [`CaptureLight::measure`] to its exact light-only renders to flag
//! drowned positions in `truth/scene.toml`.

use crate::error::CalibError;
use crate::photos::{difference, load, PhotoSource};
use matscan_scan::raster::RgbRaster;
use matscan_scan::{CaptureRole, Intrinsics, Position};
use serde::Serialize;

/// The thesis's threshold on the maximum `lit - ambient` difference.
pub const THESIS_THRESHOLD: f32 = 0.1;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BadLightOptions {
    pub threshold: f32,
    /// Fraction of the brightest per-pixel differences left out of the
    /// maximum.
    pub ignore_fraction: f64,
    /// Left out of the maximum at least this many brightest pixels.
    pub ignore_at_least: usize,
}

impl Default for BadLightOptions {
    fn default() -> Self {
        Self {
            threshold: THESIS_THRESHOLD,
            ignore_fraction: 0.001,
            ignore_at_least: 8,
        }
    }
}

/// How strongly one lit capture differs from ambient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaptureLight {
    pub capture: String,
    pub light: String,
    /// The robust maximum of `lit - ambient` (see the module doc).
    pub max_difference: f32,
    /// `max_difference < threshold`.
    pub too_dim: bool,
}

impl CaptureLight {
    /// Judges one lit capture from its `lit - ambient` image (exposure
    /// compensated, in the lit photo's units).
    pub fn measure(
        capture: &str,
        light: &str,
        difference: &RgbRaster,
        options: &BadLightOptions,
    ) -> Self {
        let mut per_pixel: Vec<f32> = difference
            .data
            .iter()
            .map(|c| c[0].max(c[1]).max(c[2]))
            .collect();
        let max_difference = robust_max(&mut per_pixel, options).unwrap_or(0.0);
        CaptureLight {
            capture: capture.to_string(),
            light: light.to_string(),
            max_difference,
            too_dim: max_difference < options.threshold,
        }
    }
}

/// The bad-light verdict for one position.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BadLight {
    pub position: String,
    pub threshold: f32,
    pub captures: Vec<CaptureLight>,
}

impl BadLight {
    /// True when estimation should leave this position out.
    pub fn is_bad(&self) -> bool {
        self.captures.iter().any(|c| c.too_dim)
    }

    /// Why the position is left out, for the user; `None` when it is not.
    pub fn reason(&self) -> Option<String> {
        let dim: Vec<String> = self
            .captures
            .iter()
            .filter(|c| c.too_dim)
            .map(|c| {
                format!(
                    "`{}` (light `{}`) differs from ambient by at most {:.4}",
                    c.capture, c.light, c.max_difference
                )
            })
            .collect();
        (!dim.is_empty()).then(|| {
            format!(
                "position `{}`: bad light, the environment drowns the rig: {} (threshold {})",
                self.position,
                dim.join("; "),
                self.threshold
            )
        })
    }
}

/// The largest finite value once the brightest few are left out; `None`
/// without finite values.
fn robust_max(values: &mut Vec<f32>, options: &BadLightOptions) -> Option<f32> {
    values.retain(|v| v.is_finite());
    let n = values.len();
    if n == 0 {
        return None;
    }
    let ignore = ((n as f64 * options.ignore_fraction).ceil() as usize)
        .max(options.ignore_at_least)
        .min(n - 1);
    let (_, v, _) = values.select_nth_unstable_by(n - 1 - ignore, f32::total_cmp);
    Some(*v)
}

/// Compares every lit capture of `position` with its ambient capture.
pub fn bad_light(
    camera: &Intrinsics,
    position: &Position,
    source: &dyn PhotoSource,
    options: &BadLightOptions,
) -> Result<BadLight, CalibError> {
    let ambient_capture = position.ambient().ok_or_else(|| CalibError::NoAmbient {
        position: position.name.clone(),
    })?;
    let ambient = load(source, camera, position, ambient_capture)?;
    let mut captures = Vec::new();
    for capture in &position.captures {
        let CaptureRole::Lit { light } = capture.role(&position.lights) else {
            continue;
        };
        let lit = load(source, camera, position, capture)?;
        let diff = difference(
            &lit,
            capture.exposure_s,
            &ambient,
            ambient_capture.exposure_s,
        );
        captures.push(CaptureLight::measure(&capture.name, &light, &diff, options));
    }
    Ok(BadLight {
        position: position.name.clone(),
        threshold: options.threshold,
        captures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photos::MemoryScan;
    use crate::synthetic::{intrinsics, thesis_rig};
    use glam::DMat4;
    use matscan_scan::Raster;

    fn rig(flash1_gain: f32) -> (Position, MemoryScan) {
        let pos = thesis_rig("p3", DMat4::IDENTITY);
        let mut scan = MemoryScan::default();
        let ambient = Raster::from_fn(16, 16, |x, _| [0.5 + 0.01 * x as f32; 3]);
        for c in &pos.captures {
            let gain = match c.name.as_str() {
                "ambient" => 0.0,
                "flash1" => flash1_gain,
                _ => 0.3,
            };
            let photo = ambient.map(|p| p.map(|v| v + gain));
            scan.insert_photo("p3", &c.name, photo);
        }
        (pos, scan)
    }

    #[test]
    fn capture_equal_to_ambient_flags_the_position() {
        let (pos, scan) = rig(0.0);
        let bl = bad_light(&intrinsics(16, 40.0), &pos, &scan, &Default::default()).unwrap();
        assert!(bl.is_bad());
        let dim: Vec<_> = bl
            .captures
            .iter()
            .filter(|c| c.too_dim)
            .map(|c| &c.capture)
            .collect();
        assert_eq!(dim, ["flash1"]);
        let reason = bl.reason().unwrap();
        assert!(
            reason.contains("`p3`") && reason.contains("`flash1`"),
            "{reason}"
        );
    }

    #[test]
    fn visible_lights_pass_and_the_threshold_is_the_thesis_one() {
        let (pos, scan) = rig(0.11);
        let bl = bad_light(&intrinsics(16, 40.0), &pos, &scan, &Default::default()).unwrap();
        assert!(!bl.is_bad(), "{:?}", bl.captures);
        assert!(bl.reason().is_none());
        let (pos, scan) = rig(0.09);
        assert!(
            bad_light(&intrinsics(16, 40.0), &pos, &scan, &Default::default())
                .unwrap()
                .is_bad()
        );
        assert_eq!(THESIS_THRESHOLD, 0.1);
    }

    #[test]
    fn a_few_hot_pixels_do_not_make_a_drowned_light_visible() {
        let (pos, mut scan) = rig(0.0);
        let photo = scan
            .photos
            .get_mut(&("p3".into(), "flash1".into()))
            .unwrap();
        *photo.get_mut(3, 3) = [9.0; 3];
        let bl = bad_light(&intrinsics(16, 40.0), &pos, &scan, &Default::default()).unwrap();
        assert!(bl.is_bad());
    }

    #[test]
    fn exposure_differences_are_compensated() {
        let (mut pos, mut scan) = rig(0.0);
        // flash1 taken at twice the exposure: its photo is twice as bright
        // yet carries no light of its own.
        pos.captures
            .iter_mut()
            .find(|c| c.name == "flash1")
            .unwrap()
            .exposure_s = 0.04;
        let photo = scan
            .photos
            .get_mut(&("p3".into(), "flash1".into()))
            .unwrap();
        photo.data.iter_mut().for_each(|p| *p = p.map(|v| v * 2.0));
        let bl = bad_light(&intrinsics(16, 40.0), &pos, &scan, &Default::default()).unwrap();
        let f1 = bl.captures.iter().find(|c| c.capture == "flash1").unwrap();
        assert!(f1.max_difference.abs() < 1e-5 && f1.too_dim);
    }
}
