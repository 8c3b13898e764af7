//! Light response: the mean colour of a white diffuse reference under each
//! lit capture (thesis 3.1.5, "Light Response"), in linear RGB and YCbCr.
//!
//! Reference pixels come from the position's white-reference mask when the
//! scan has one. Otherwise the backlight panel is segmented as the thesis
//! does: threshold `backlit - ambient` (luma above `panel_threshold` times
//! its 99th percentile, so the threshold follows the panel's brightness),
//! then, per lit capture, keep only the panel pixels at least as bright as
//! the panel's (trimmed) mean luma under that capture: the second threshold that drops the
//! shadow the object casts on the panel.
//!
//! Robustness: non-finite pixels are dropped, and the mean is a trimmed
//! mean: pixels are ranked by luma and the darkest and brightest `trim`
//! fraction (10% each by default) are left out before averaging, so a few
//! saturated, hot or dead pixels do not move it; colour channels stay
//! coupled (whole pixels are dropped, not channel values).
//!
//! Units: those of each capture's photo (exposure not divided out), like
//! the thesis's means; `rgb_minus_ambient` is the light's own contribution
//! (ambient rescaled to the capture's exposure and subtracted).

use crate::error::CalibError;
use crate::photos::{check_size, difference, load, luma, quantile, PhotoSource};
use matscan_scan::raster::{MaskRaster, RgbRaster};
use matscan_scan::{CaptureRole, Intrinsics, Position};
use serde::Serialize;

/// Parameters of the segmentation and the robust mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhiteReferenceOptions {
    /// Panel pixels: `backlit - ambient` luma above this fraction of its
    /// 99th percentile.
    pub panel_threshold: f32,
    /// Fraction of pixels dropped at each end (by luma) of the mean.
    pub trim: f32,
    /// Fewer reference pixels than this is an error.
    pub min_pixels: usize,
}

impl Default for WhiteReferenceOptions {
    fn default() -> Self {
        Self {
            panel_threshold: 0.5,
            trim: 0.1,
            min_pixels: 16,
        }
    }
}

/// Where the reference pixels came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceSource {
    Mask,
    BacklightPanel,
}

/// The white reference's response under one lit capture.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LightResponse {
    pub capture: String,
    pub light: String,
    /// Trimmed mean linear RGB of the reference under the capture.
    pub rgb: [f32; 3],
    /// `rgb` as BT.601 full-range YCbCr (see [`ycbcr`]).
    pub ycbcr: [f32; 3],
    /// Trimmed mean of `capture - ambient`: the light alone.
    pub rgb_minus_ambient: [f32; 3],
    /// Reference pixels averaged (before trimming).
    pub pixels: usize,
}

/// The light responses of one position.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WhiteReference {
    pub position: String,
    pub source: ReferenceSource,
    pub responses: Vec<LightResponse>,
}

impl WhiteReference {
    pub fn response(&self, capture: &str) -> Option<&LightResponse> {
        self.responses.iter().find(|r| r.capture == capture)
    }
}

/// BT.601 full-range YCbCr of linear RGB, the JPEG/JFIF form with the
/// chroma offset of 0.5 for values in 0..1: `Y = 0.299 R + 0.587 G +
/// 0.114 B`, `Cb = 0.5 + (B - Y) / 1.772`, `Cr = 0.5 + (R - Y) / 1.402`.
pub fn ycbcr(c: [f32; 3]) -> [f32; 3] {
    let y = luma(c);
    [y, 0.5 + (c[2] - y) / 1.772, 0.5 + (c[0] - y) / 1.402]
}

/// The backlight panel: pixels where `backlit - ambient` (in the backlit
/// photo's units) has luma above `threshold` times its 99th percentile.
pub fn segment_panel(diff: &RgbRaster, threshold: f32) -> MaskRaster {
    let lumas = diff.map(|&c| luma(c));
    let mut values = lumas.data.clone();
    let high = quantile(&mut values, 0.99).unwrap_or(0.0);
    if high <= 0.0 {
        return lumas.map(|_| false);
    }
    lumas.map(|&y| y.is_finite() && y > threshold * high)
}

/// Drops from `panel` the pixels darker than the panel's mean luma under
/// `lit` (the object's shadow on the panel), as the thesis's second
/// threshold; the mean is trimmed by `trim` like the response itself, so a
/// few saturated pixels cannot lift the threshold above the lit panel.
pub fn drop_shadow(panel: &MaskRaster, lit: &RgbRaster, trim: f32) -> MaskRaster {
    let Some((mean, _)) = robust_mean(lit, panel, trim) else {
        return panel.clone();
    };
    let threshold = luma(mean);
    let mut out = panel.clone();
    for (m, c) in out.data.iter_mut().zip(&lit.data) {
        *m = *m && luma(*c) >= threshold;
    }
    out
}

/// Trimmed mean colour of `image` over `mask` (see the module doc): pixels
/// ranked by luma, `trim` of them dropped at each end. Returns the mean and
/// the number of finite masked pixels; `None` when there are none.
pub fn robust_mean(image: &RgbRaster, mask: &MaskRaster, trim: f32) -> Option<([f32; 3], usize)> {
    let mut px: Vec<[f32; 3]> = image
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(c, &m)| m && c.iter().all(|v| v.is_finite()))
        .map(|(c, _)| *c)
        .collect();
    let n = px.len();
    if n == 0 {
        return None;
    }
    px.sort_by(|a, b| luma(*a).total_cmp(&luma(*b)));
    let cut = ((n as f64) * f64::from(trim.clamp(0.0, 0.49))).floor() as usize;
    let kept = &px[cut..n - cut];
    let mut sum = [0.0f64; 3];
    for c in kept {
        for k in 0..3 {
            sum[k] += f64::from(c[k]);
        }
    }
    let m = kept.len() as f64;
    Some((sum.map(|s| (s / m) as f32), n))
}

/// The light responses of every lit capture of `position`.
pub fn white_reference(
    camera: &Intrinsics,
    position: &Position,
    source: &dyn PhotoSource,
    options: &WhiteReferenceOptions,
) -> Result<WhiteReference, CalibError> {
    let ambient_capture = position.ambient().ok_or_else(|| CalibError::NoAmbient {
        position: position.name.clone(),
    })?;
    let ambient = load(source, camera, position, ambient_capture)?;
    let (base_mask, reference_source) = match source.white_reference_mask(position)? {
        Some(mask) => {
            check_size(
                camera,
                position,
                "white-reference mask",
                mask.width,
                mask.height,
            )?;
            (mask, ReferenceSource::Mask)
        }
        None => {
            let backlit_capture = position
                .captures
                .iter()
                .find(|c| c.role(&position.lights) == CaptureRole::Backlit)
                .ok_or_else(|| CalibError::NoWhiteReference {
                    position: position.name.clone(),
                })?;
            let backlit = load(source, camera, position, backlit_capture)?;
            let diff = difference(
                &backlit,
                backlit_capture.exposure_s,
                &ambient,
                ambient_capture.exposure_s,
            );
            (
                segment_panel(&diff, options.panel_threshold),
                ReferenceSource::BacklightPanel,
            )
        }
    };
    let mut responses = Vec::new();
    for capture in &position.captures {
        let CaptureRole::Lit { light } = capture.role(&position.lights) else {
            continue;
        };
        let lit = load(source, camera, position, capture)?;
        let mask = match reference_source {
            ReferenceSource::Mask => base_mask.clone(),
            ReferenceSource::BacklightPanel => drop_shadow(&base_mask, &lit, options.trim),
        };
        let too_few = |found| CalibError::TooFewReferencePixels {
            position: position.name.clone(),
            capture: capture.name.clone(),
            found,
            needed: options.min_pixels,
        };
        let (rgb, pixels) = robust_mean(&lit, &mask, options.trim).ok_or_else(|| too_few(0))?;
        if pixels < options.min_pixels {
            return Err(too_few(pixels));
        }
        let diff = difference(
            &lit,
            capture.exposure_s,
            &ambient,
            ambient_capture.exposure_s,
        );
        let (rgb_minus_ambient, _) =
            robust_mean(&diff, &mask, options.trim).ok_or_else(|| too_few(0))?;
        responses.push(LightResponse {
            capture: capture.name.clone(),
            light,
            rgb,
            ycbcr: ycbcr(rgb),
            rgb_minus_ambient,
            pixels,
        });
    }
    Ok(WhiteReference {
        position: position.name.clone(),
        source: reference_source,
        responses,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photos::MemoryScan;
    use crate::synthetic::{intrinsics, thesis_rig};
    use glam::DMat4;
    use matscan_scan::Raster;

    const N: u32 = 32;

    /// Ambient 0.05 grey; backlit adds 0.8 on the panel (x >= 8); flash0
    /// lights the panel at (0.6, 0.5, 0.4) except a shadow (x in 8..14).
    fn scene() -> (Position, MemoryScan) {
        let pos = thesis_rig("p0", DMat4::IDENTITY);
        let mut scan = MemoryScan::default();
        let ambient = Raster::filled(N, N, [0.05f32; 3]);
        let backlit = Raster::from_fn(N, N, |x, _| if x >= 8 { [0.85; 3] } else { [0.05; 3] });
        let flash = Raster::from_fn(N, N, |x, _| match x {
            0..8 => [0.3, 0.3, 0.3],
            8..14 => [0.07, 0.07, 0.07],
            _ => [0.65, 0.55, 0.45],
        });
        for c in &pos.captures {
            let photo = match c.name.as_str() {
                "backlit" => backlit.clone(),
                "ambient" => ambient.clone(),
                _ => flash.clone(),
            };
            scan.insert_photo("p0", &c.name, photo);
        }
        (pos, scan)
    }

    #[test]
    fn panel_response_drops_the_shadow_and_survives_outlier_pixels() {
        let (pos, mut scan) = scene();
        // A few saturated and dead pixels on the lit panel.
        let photo = scan
            .photos
            .get_mut(&("p0".into(), "flash0".into()))
            .unwrap();
        for (x, y, v) in [(20, 3, 1e4f32), (25, 9, 1e4), (30, 30, 0.0), (16, 16, 5e3)] {
            *photo.get_mut(x, y) = [v; 3];
        }
        let wr = white_reference(&intrinsics(N, 40.0), &pos, &scan, &Default::default()).unwrap();
        assert_eq!(wr.source, ReferenceSource::BacklightPanel);
        assert_eq!(wr.responses.len(), 3, "flash0, flash1, projector");
        let r = wr.response("flash0").unwrap();
        for (got, want) in r.rgb.iter().zip([0.65, 0.55, 0.45]) {
            assert!((got - want).abs() < 1e-5, "{:?}", r.rgb);
        }
        for (got, want) in r.rgb_minus_ambient.iter().zip([0.6, 0.5, 0.4]) {
            assert!((got - want).abs() < 1e-5, "{:?}", r.rgb_minus_ambient);
        }
        // The lit panel less the dead pixel, which the shadow threshold drops;
        // the three saturated ones are kept and trimmed from the mean.
        assert_eq!(r.pixels, (N as usize - 14) * N as usize - 1);
        assert_eq!(r.light, "flash0");
    }

    #[test]
    fn given_mask_is_used_without_segmentation() {
        let (mut pos, mut scan) = scene();
        pos.white_reference_mask = Some("views/p0/white.png".into());
        scan.white_reference_masks
            .insert("p0".into(), Raster::from_fn(N, N, |x, y| x < 4 && y < 8));
        let wr = white_reference(&intrinsics(N, 40.0), &pos, &scan, &Default::default()).unwrap();
        assert_eq!(wr.source, ReferenceSource::Mask);
        let r = wr.response("flash1").unwrap();
        assert!((r.rgb[0] - 0.3).abs() < 1e-6 && r.pixels == 32);
        assert!((r.ycbcr[0] - 0.3).abs() < 1e-6);
        assert!((r.ycbcr[1] - 0.5).abs() < 1e-6 && (r.ycbcr[2] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn too_few_reference_pixels_names_position_and_capture() {
        let (mut pos, mut scan) = scene();
        pos.white_reference_mask = Some("views/p0/white.png".into());
        scan.white_reference_masks
            .insert("p0".into(), Raster::from_fn(N, N, |x, y| x < 2 && y < 2));
        let err =
            white_reference(&intrinsics(N, 40.0), &pos, &scan, &Default::default()).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("`p0`") && msg.contains("`flash0`") && msg.contains("only 4"),
            "{msg}"
        );
    }

    #[test]
    fn ycbcr_follows_bt601_full_range() {
        let [y, cb, cr] = ycbcr([1.0, 0.0, 0.0]);
        assert!((y - 0.299).abs() < 1e-6);
        assert!((cb - (0.5 - 0.299 / 1.772)).abs() < 1e-6);
        assert!((cr - (0.5 + 0.701 / 1.402)).abs() < 1e-6);
        assert_eq!(ycbcr([0.0, 0.0, 1.0])[1], 1.0);
    }

    #[test]
    fn robust_mean_trims_by_luma_and_skips_non_finite() {
        let mut img = Raster::filled(10, 10, [0.5f32, 0.4, 0.3]);
        *img.get_mut(0, 0) = [f32::NAN, 0.0, 0.0];
        *img.get_mut(1, 0) = [100.0; 3];
        let mask = Raster::filled(10, 10, true);
        let (mean, n) = robust_mean(&img, &mask, 0.1).unwrap();
        assert_eq!(n, 99);
        assert_eq!(mean, [0.5, 0.4, 0.3]);
        assert!(robust_mean(&img, &Raster::filled(10, 10, false), 0.1).is_none());
    }
}
