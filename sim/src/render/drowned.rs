//! Positions where the environment drowns the rig's lights (thesis section
//! 3.1.6), judged by calib's rule ([`matscan_calib::bad_light`]): a
//! position is drowned when any of its lit captures differs from the
//! ambient one by less than the thesis's 0.1 (robust maximum over the
//! image). The renderer hands that rule each capture's rig-light term on
//! its own (`lit - ambient` without the ambient noise), so the difference
//! is exact up to the light's own noise. Also reported, for inspection: the
//! rig-light to ambient ratio of mean luminance over the object.

use super::environment::luminance;
use glam::Vec3;
use matscan_calib::bad_light::{BadLight, BadLightOptions, CaptureLight};
use matscan_scan::raster::{MaskRaster, RgbRaster};

/// One lit capture's light-only image, with the names calib reports.
pub struct LitImage<'a> {
    pub capture: &'a str,
    pub light: &'a str,
    pub light_only: &'a RgbRaster,
}

/// How strongly the rig's lights show against the environment at one
/// position.
#[derive(Debug, Clone, PartialEq)]
pub struct DrownAssessment {
    /// Calib's verdict, per lit capture.
    pub verdict: BadLight,
    /// Mean luminance of the rig light over mean ambient luminance on the
    /// object, best lit capture; `None` without ambient light.
    pub light_to_ambient: Option<f32>,
}

impl DrownAssessment {
    pub fn drowned(&self) -> bool {
        self.verdict.is_bad()
    }
}

/// Assesses position `position` from its lit captures' light-only images
/// and its ambient image; `mask` selects the object for the ratio (all
/// pixels when it is empty).
pub fn assess(
    position: &str,
    lit: &[LitImage<'_>],
    ambient: &RgbRaster,
    mask: &MaskRaster,
) -> DrownAssessment {
    // The thesis's threshold (`THESIS_THRESHOLD`), as `scene.toml` states.
    let options = BadLightOptions::default();
    let captures = lit
        .iter()
        .map(|l| CaptureLight::measure(l.capture, l.light, l.light_only, &options))
        .collect();
    let use_all = !mask.data.iter().any(|&m| m);
    let on_object = |i: usize| use_all || mask.data.get(i).copied().unwrap_or(false);
    let object_luminance = |img: &RgbRaster| -> f64 {
        img.data
            .iter()
            .enumerate()
            .filter(|(i, _)| on_object(*i))
            .map(|(_, p)| luminance(Vec3::from_array(*p)) as f64)
            .sum()
    };
    let ambient_lum = object_luminance(ambient);
    let light_to_ambient = if ambient_lum > 0.0 {
        lit.iter()
            .map(|l| (object_luminance(l.light_only) / ambient_lum) as f32)
            .reduce(f32::max)
    } else {
        None
    };
    DrownAssessment {
        verdict: BadLight {
            position: position.to_string(),
            threshold: options.threshold,
            captures,
        },
        light_to_ambient,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(v: f32) -> RgbRaster {
        RgbRaster::filled(10, 10, [v; 3])
    }

    fn lit<'a>(images: &'a [(&'a str, RgbRaster)]) -> Vec<LitImage<'a>> {
        images
            .iter()
            .map(|(name, img)| LitImage {
                capture: name,
                light: name,
                light_only: img,
            })
            .collect()
    }

    #[test]
    fn one_drowned_light_drowns_the_position_as_calib_rules() {
        let mask = MaskRaster::filled(10, 10, true);
        let a = assess("p0", &lit(&[("flash0", flat(0.05))]), &flat(2.0), &mask);
        assert!(a.drowned());
        assert!((a.light_to_ambient.unwrap() - 0.025).abs() < 1e-6);
        // A bright second light does not rescue the dim first one: its
        // input still carries nothing.
        let images = [("flash0", flat(0.05)), ("flash1", flat(0.4))];
        let b = assess("p0", &lit(&images), &flat(2.0), &mask);
        assert!(b.drowned());
        let reason = b.verdict.reason().unwrap_or_default();
        assert!(
            reason.contains("`flash0`") && !reason.contains("`flash1`"),
            "{reason}"
        );
        let images = [("flash0", flat(0.2)), ("flash1", flat(0.4))];
        assert!(!assess("p0", &lit(&images), &flat(2.0), &mask).drowned());
    }

    #[test]
    fn a_few_fireflies_do_not_count_as_the_maximum() {
        let mut light = RgbRaster::filled(100, 100, [0.01; 3]);
        *light.get_mut(3, 3) = [50.0; 3];
        let mask = MaskRaster::filled(100, 100, false);
        let images = [("flash0", light)];
        let a = assess(
            "p0",
            &lit(&images),
            &RgbRaster::filled(100, 100, [1.0; 3]),
            &mask,
        );
        assert!(a.drowned(), "{a:?}");
    }

    #[test]
    fn no_ambient_light_has_no_ratio() {
        let mask = MaskRaster::filled(10, 10, true);
        let a = assess("p0", &lit(&[("flash0", flat(0.3))]), &flat(0.0), &mask);
        assert_eq!(a.light_to_ambient, None);
        assert!(!a.drowned());
    }
}
