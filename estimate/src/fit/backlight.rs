//! Light through the object, measured with the backlight: whether a
//! material lets any of the panel's light through.
//!
//! The backlit photo minus the ambient one, at an object pixel, is the
//! panel's light that reached the camera through the object (refracted by
//! a transmissive material, or carried under the surface by a scattering
//! one), plus the panel's light reflected off the surface where the
//! surface can see the panel. The panel is behind the object as the
//! camera sees it, so a surface facing the camera (`cos_nv` at least
//! [`BacklightOptions::min_cos_nv`]) has it below its horizon: there the
//! difference is light that passed through, and nothing else. The
//! panel's own radiance is read from the same photo right beside the
//! silhouette, so the measurement needs no calibration of the panel
//! (the contract gives it no pose).
//!
//! On the `tune` set the share of the panel's radiance seen through
//! facing pixels is 0.000 (median; 90th percentile at most about 0.02) on
//! every opaque material, 0.04 to 0.16 on materials that scatter inside
//! (subsurface) and 0 to 0.1 on transmissive ones (docs/results.md). The
//! straight path crosses the whole object, so a transmissive front over
//! an opaque back shows nothing at the pixels whose path meets the back.
//! A material's shares answer one question with confidence: does light
//! pass? Where the median passes light, it does, and the material is not
//! a metal (a metal transmits nothing and scatters nothing inside); where
//! nearly every pixel (the 90th percentile) shows none, it passes none,
//! so it has no transmission; in between, part of it passes light, which
//! says nothing certain.
//!
//! How much a material transmits, the share says where the light passes
//! straight: through a material that scatters none inside (the checker's
//! global share below [`super::SCATTERING_SHARE`]) the glass lobe passes
//! `t (1 - F) basecolor` per crossing, and with the diffuse albedo the
//! flashes show, the transmission follows ([`transmission_from`]). On
//! `tune`'s and `heldout`'s transmission-only materials it comes back
//! within 0.03 to 0.15 where the path is clear. How much a scattering
//! material scatters is not read: its share depends on the whole
//! object's shape, not on the chord through it.
//!
//! Boundaries: the reference position's backlit photo, through the
//! scan's inputs; no file I/O.

use crate::pipeline::inputs::SceneInputs;
use matscan_bsdf::fresnel_dielectric_cos;
use matscan_bsdf::material::IOR;
use matscan_calib::photos::{luma, quantile};
use matscan_calib::white_reference::{robust_mean, segment_panel};
use matscan_scan::raster::{MaskRaster, RgbRaster};
use serde::{Deserialize, Serialize};

/// Where the measurement looks and what it trusts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BacklightOptions {
    /// Pixels measured: `cos_nv` at least this. Above about 0.7 the panel
    /// (within some 40 degrees of the view ray's continuation) lies below
    /// the surface's horizon and cannot light it directly.
    pub min_cos_nv: f32,
    /// Pixels within this many pixels of the silhouette are left out (the
    /// panel bleeds into them through the pixel's footprint).
    pub edge_px: u32,
    /// The panel band: panel pixels farther than `gap_px` and at most
    /// `band_px` (Chebyshev distance) from the object's silhouette.
    pub gap_px: u32,
    pub band_px: u32,
    /// Panel segmentation threshold, a fraction of the backlight
    /// difference's 99th percentile luma (as the white reference's).
    pub panel_threshold: f32,
    /// Trimmed share at each end of the panel's robust mean.
    pub trim: f32,
    /// A material passes light when the median share of the panel's
    /// radiance seen through its measured pixels is at least this.
    pub passes: f32,
    /// A material passes no light when the 90th percentile of its shares
    /// is below this.
    pub blocked: f32,
    /// Measured pixels a material needs to be judged.
    pub min_pixels: usize,
}

impl Default for BacklightOptions {
    fn default() -> Self {
        BacklightOptions {
            min_cos_nv: 0.7,
            edge_px: 2,
            gap_px: 2,
            band_px: 10,
            panel_threshold: 0.5,
            trim: 0.1,
            passes: 0.01,
            blocked: 0.02,
            min_pixels: 30,
        }
    }
}

/// What the backlight says of one material.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Passage {
    /// No light passes anywhere: no transmission.
    Blocked,
    /// Light passes at some pixels and not at most: no reading.
    Partly,
    /// Light passes: transmission or subsurface, and not a metal.
    Passes,
}

/// The backlight's reading of one material.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialBacklight {
    /// Median share of the panel's radiance seen through its pixels.
    pub share: f32,
    /// Its 90th percentile.
    #[serde(default)]
    pub high: f32,
    /// Pixels it was read from.
    pub pixels: usize,
    pub passage: Passage,
}

/// The backlight as the reference image sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Backlight {
    /// Per reference pixel, the share of the panel's radiance seen through
    /// it (luma); NaN where not measured (background, edge, not facing).
    pub share: Vec<f32>,
    /// The panel's radiance, in the reference's ambient exposure units.
    pub panel: [f32; 3],
}

impl Backlight {
    /// The share at every pixel of `mask` (`width` pixels a row): where it
    /// was not measured (the edge, grazing views), the share of the nearest
    /// measured pixel of the mask (4-connected steps); 0 where the mask
    /// holds no measured pixel.
    pub fn filled(&self, mask: &[bool], width: usize) -> Vec<f32> {
        let n = mask.len();
        let mut out = vec![0.0f32; n];
        let mut seen = vec![false; n];
        let mut queue = std::collections::VecDeque::new();
        for i in 0..n {
            if let Some(&s) = self.share.get(i).filter(|s| mask[i] && s.is_finite()) {
                out[i] = s;
                seen[i] = true;
                queue.push_back(i);
            }
        }
        while let Some(i) = queue.pop_front() {
            let (x, y) = (i % width.max(1), i / width.max(1));
            let mut next = |j: usize| {
                if j < n && mask[j] && !seen[j] {
                    seen[j] = true;
                    out[j] = out[i];
                    queue.push_back(j);
                }
            };
            if x > 0 {
                next(i - 1);
            }
            if x + 1 < width {
                next(i + 1);
            }
            if y > 0 {
                next(i - width);
            }
            next(i + width);
        }
        out
    }

    /// The transmission of the material whose reference pixels have the
    /// diffuse albedos (luma) `albedo`, `(pixel, albedo)` pairs: the median
    /// of [`transmission_from`] over its measured pixels; `None` where too
    /// few of them were measured.
    pub fn transmission(&self, albedo: &[(usize, f32)], options: &BacklightOptions) -> Option<f32> {
        let mut t: Vec<f32> = albedo
            .iter()
            .filter_map(|&(i, a)| transmission_from(*self.share.get(i)?, a))
            .collect();
        if t.len() < options.min_pixels.max(1) {
            return None;
        }
        quantile(&mut t, 0.5)
    }

    /// The reading of the material made of the reference pixels
    /// `members`; `None` where too few of them were measured.
    pub fn material(
        &self,
        members: &[usize],
        options: &BacklightOptions,
    ) -> Option<MaterialBacklight> {
        let mut shares: Vec<f32> = members
            .iter()
            .filter_map(|&i| self.share.get(i).copied())
            .filter(|s| s.is_finite())
            .collect();
        if shares.len() < options.min_pixels.max(1) {
            return None;
        }
        let pixels = shares.len();
        let share = quantile(&mut shares, 0.5)?;
        let high = quantile(&mut shares, 0.9)?;
        Some(MaterialBacklight {
            share,
            high,
            pixels,
            passage: if share >= options.passes {
                Passage::Passes
            } else if high < options.blocked {
                Passage::Blocked
            } else {
                Passage::Partly
            },
        })
    }
}

/// The transmission of a pixel through which `share` of the panel's
/// light passes, given the luma of its diffuse albedo `albedo` (`(1 - t)
/// basecolor`, what the flashes show). The Principled glass lobe passes
/// `t (1 - F) basecolor` of the light per crossing of a surface, and a
/// clear path crosses two (in and out) near normal incidence, so `share
/// = (1 - F0)^2 (t b)^2`; with `albedo = (1 - t) b` that is `t / (1 - t)
/// = q / albedo`, `q = sqrt(share) / (1 - F0)`. `None` where neither
/// passes nor reflects anything, or a value is not finite.
pub fn transmission_from(share: f32, albedo: f32) -> Option<f32> {
    if !(share.is_finite() && albedo.is_finite()) {
        return None;
    }
    let passed = 1.0 - fresnel_dielectric_cos(1.0, IOR);
    let q = share.max(0.0).sqrt() / passed;
    let albedo = albedo.max(0.0);
    let t = q / (q + albedo);
    t.is_finite().then(|| t.clamp(0.0, 1.0))
}

/// The backlight measurement of `inputs`' reference image, or why the scan
/// cannot give it (no backlit capture at the reference position, no panel
/// visible beside the object).
pub fn measure_backlight(
    inputs: &SceneInputs,
    options: &BacklightOptions,
) -> Result<Backlight, String> {
    let Some((planes, backlit)) = inputs
        .views
        .iter()
        .filter(|v| v.view.position == inputs.reference)
        .find_map(|v| Some((v, v.backlit()?)))
    else {
        return Err(format!(
            "the reference position {} has no backlit capture",
            inputs.reference
        ));
    };
    let (w, h) = (inputs.width, inputs.height);
    let n = w * h;
    if backlit.len() != n || planes.ambient().len() != n || planes.cos_nv().len() != n {
        return Err(format!(
            "position {}: the backlit photo's size differs from the reference image's",
            inputs.reference
        ));
    }
    let diff = RgbRaster {
        width: w as u32,
        height: h as u32,
        data: backlit
            .iter()
            .zip(planes.ambient())
            .map(|(b, a)| std::array::from_fn(|c| b[c] - a[c]))
            .collect(),
    };
    backlight_shares(&diff, &inputs.mask, planes.cos_nv(), options)
        .map_err(|why| format!("position {}: {why}", inputs.reference))
}

/// The shares of the panel's radiance seen through each object pixel of
/// `diff` (backlit minus ambient), or why there are none.
pub fn backlight_shares(
    diff: &RgbRaster,
    object: &MaskRaster,
    cos_nv: &[f32],
    options: &BacklightOptions,
) -> Result<Backlight, String> {
    let n = diff.data.len();
    if object.data.len() != n || cos_nv.len() != n {
        return Err(format!(
            "the backlit photo has {n} pixels, the object mask {} and the view cosines {}",
            object.data.len(),
            cos_nv.len()
        ));
    }
    let Some(panel) = panel_radiance(diff, object, options) else {
        return Err("the backlit photo shows no panel beside the object".to_string());
    };
    let panel_luma = luma(panel);
    let inside = erode(object, options.edge_px);
    let share = (0..n)
        .map(|i| {
            let facing = cos_nv[i] >= options.min_cos_nv;
            let d = diff.data[i];
            if inside.data[i] && facing && d.iter().all(|v| v.is_finite()) {
                (luma(d) / panel_luma).max(0.0)
            } else {
                f32::NAN
            }
        })
        .collect();
    Ok(Backlight { share, panel })
}

/// The panel's radiance: the trimmed mean of the backlight difference over
/// the panel band around the silhouette (the whole panel where the band
/// holds too few pixels).
fn panel_radiance(
    diff: &RgbRaster,
    object: &MaskRaster,
    options: &BacklightOptions,
) -> Option<[f32; 3]> {
    const MIN_PIXELS: usize = 16;
    let panel = segment_panel(diff, options.panel_threshold);
    let near = dilate(object, options.band_px);
    let touching = dilate(object, options.gap_px);
    let band = MaskRaster {
        width: panel.width,
        height: panel.height,
        data: (0..panel.data.len())
            .map(|i| panel.data[i] && near.data[i] && !touching.data[i] && !object.data[i])
            .collect(),
    };
    let (rgb, n) = match robust_mean(diff, &band, options.trim) {
        Some((rgb, n)) if n >= MIN_PIXELS => (rgb, n),
        _ => robust_mean(diff, &panel, options.trim)?,
    };
    (n >= MIN_PIXELS && luma(rgb) > 0.0 && rgb.iter().all(|v| v.is_finite())).then_some(rgb)
}

/// `mask` grown by `r` pixels (Chebyshev distance), separably.
fn dilate(mask: &MaskRaster, r: u32) -> MaskRaster {
    let (w, h) = (mask.width as usize, mask.height as usize);
    let r = r as usize;
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (lo, hi) = (x.saturating_sub(r), (x + r).min(w.saturating_sub(1)));
            rows[y * w + x] = (lo..=hi).any(|xx| mask.data[y * w + xx]);
        }
    }
    let mut out = vec![false; w * h];
    for y in 0..h {
        let (lo, hi) = (y.saturating_sub(r), (y + r).min(h.saturating_sub(1)));
        for x in 0..w {
            out[y * w + x] = (lo..=hi).any(|yy| rows[yy * w + x]);
        }
    }
    MaskRaster {
        width: mask.width,
        height: mask.height,
        data: out,
    }
}

/// `mask` shrunk by `r` pixels: what stays when the outside grows by `r`
/// (the image border counts as inside).
fn erode(mask: &MaskRaster, r: u32) -> MaskRaster {
    let outside = MaskRaster {
        width: mask.width,
        height: mask.height,
        data: mask.data.iter().map(|&m| !m).collect(),
    };
    let grown = dilate(&outside, r);
    MaskRaster {
        width: mask.width,
        height: mask.height,
        data: grown.data.iter().map(|&g| !g).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(w: u32, h: u32, on: impl Fn(usize, usize) -> bool) -> MaskRaster {
        MaskRaster {
            width: w,
            height: h,
            data: (0..(w * h) as usize)
                .map(|i| on(i % w as usize, i / w as usize))
                .collect(),
        }
    }

    #[test]
    fn dilation_grows_by_the_radius_and_no_further() {
        let m = mask(7, 7, |x, y| x == 3 && y == 3);
        let d = dilate(&m, 2);
        assert_eq!(d.data.iter().filter(|&&v| v).count(), 25);
        assert!(d.data[7 + 1] && !d.data[0]);
    }

    #[test]
    fn erosion_keeps_the_pixels_farther_than_the_radius_from_the_outside() {
        let m = mask(9, 9, |x, y| (1..8).contains(&x) && (1..8).contains(&y));
        let e = erode(&m, 2);
        // 7x7 square shrunk by 2 on each side: 3x3.
        assert_eq!(e.data.iter().filter(|&&v| v).count(), 9);
        assert!(e.data[4 * 9 + 4] && !e.data[2 * 9 + 2]);
    }

    /// A 40 x 40 backlit-minus-ambient photo: a disc of radius 12 in the
    /// middle whose pixels pass `through` of the panel's light, on a panel
    /// of radiance `panel` (a clipped camera reads the clip level).
    fn photo(through: f32, panel: [f32; 3]) -> (RgbRaster, MaskRaster, Vec<f32>) {
        let object = mask(40, 40, |x, y| {
            let (dx, dy) = (x as f32 - 19.5, y as f32 - 19.5);
            dx * dx + dy * dy < 144.0
        });
        let data = object
            .data
            .iter()
            .map(|&o| if o { panel.map(|p| p * through) } else { panel })
            .collect();
        let diff = RgbRaster {
            width: 40,
            height: 40,
            data,
        };
        (diff, object, vec![1.0; 1600])
    }

    #[test]
    fn shares_are_the_panel_light_seen_through_facing_pixels_inside_the_edge() {
        let options = BacklightOptions::default();
        let (diff, object, mut cos) = photo(0.25, [2.0, 2.0, 1.8]);
        cos[20 * 40 + 20] = 0.3; // grazing: the panel may light it
        let b = backlight_shares(&diff, &object, &cos, &options).expect("a panel");
        assert_eq!(b.panel, [2.0, 2.0, 1.8]);
        assert!((b.share[20 * 40 + 19] - 0.25).abs() < 1e-6);
        assert!(b.share[20 * 40 + 20].is_nan());
        // The edge (within 2 px of the silhouette) and the panel are not
        // measured.
        assert!(b.share[20 * 40 + 9].is_nan() && b.share[0].is_nan());
        assert!(b.share[20 * 40 + 11].is_finite());
        let all: Vec<usize> = (0..1600).collect();
        let reading = b.material(&all, &options).expect("read");
        assert_eq!(reading.passage, Passage::Passes);
    }

    #[test]
    fn an_opaque_object_passes_none_even_before_a_saturated_panel() {
        // A clipped panel reads darker than it is, which raises every share
        // in proportion: zero stays zero.
        let options = BacklightOptions::default();
        for panel in [[0.8; 3], [1.0, 1.0, 1.0]] {
            let (diff, object, cos) = photo(0.0, panel);
            let b = backlight_shares(&diff, &object, &cos, &options).expect("a panel");
            let all: Vec<usize> = (0..1600).collect();
            let reading = b.material(&all, &options).expect("read");
            assert_eq!(reading.passage, Passage::Blocked);
            assert!(b.share.iter().all(|s| s.is_nan() || *s == 0.0));
        }
    }

    #[test]
    fn a_fully_transmissive_region_and_bad_pixels_stay_finite() {
        let options = BacklightOptions::default();
        let (mut diff, object, cos) = photo(1.0, [1.5; 3]);
        diff.data[20 * 40 + 20] = [f32::NAN, 1.0, f32::INFINITY];
        diff.data[20 * 40 + 21] = [-3.0; 3];
        let b = backlight_shares(&diff, &object, &cos, &options).expect("a panel");
        assert!(b.share[20 * 40 + 20].is_nan());
        assert_eq!(b.share[20 * 40 + 21], 0.0);
        assert!(b
            .share
            .iter()
            .all(|s| s.is_nan() || (0.0..=1.0 + 1e-6).contains(s)));
        let all: Vec<usize> = (0..1600).collect();
        let reading = b.material(&all, &options).expect("read");
        assert_eq!(reading.passage, Passage::Passes);
        assert!((reading.share - 1.0).abs() < 1e-6);
    }

    #[test]
    fn without_a_panel_behind_the_object_the_reason_is_given() {
        let options = BacklightOptions::default();
        // The backlight off (or not behind the object): nothing lit.
        let (diff, object, cos) = photo(0.0, [0.0; 3]);
        let why = backlight_shares(&diff, &object, &cos, &options).err();
        assert_eq!(
            why.as_deref(),
            Some("the backlit photo shows no panel beside the object")
        );
        // Sizes that do not match are named.
        let why = backlight_shares(&diff, &object, &cos[..10], &options).err();
        assert!(why.is_some_and(|w| w.contains("1600 pixels") && w.contains("cosines 10")));
    }

    #[test]
    fn unmeasured_pixels_take_the_nearest_measured_share() {
        // A row of 5 in a 5 x 2 image: measured at 1 (0.1) and 3 (0.3).
        let mut share = vec![f32::NAN; 10];
        share[1] = 0.1;
        share[3] = 0.3;
        share[5] = 0.9; // outside the mask
        let mask: Vec<bool> = (0..10).map(|i| i < 5).collect();
        let b = backlight(share);
        assert_eq!(
            b.filled(&mask, 5),
            vec![0.1, 0.1, 0.1, 0.3, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0]
        );
        let none = backlight(vec![f32::NAN; 10]);
        assert!(none.filled(&mask, 5).iter().all(|&s| s == 0.0));
    }

    #[test]
    fn transmission_comes_back_from_the_share_through_two_crossings() {
        let passed = 1.0 - fresnel_dielectric_cos(1.0, IOR);
        for (t, b) in [(0.6f32, 0.5f32), (0.2, 0.9), (0.95, 0.3)] {
            let share = (passed * t * b).powi(2);
            let got = transmission_from(share, (1.0 - t) * b).expect("finite");
            assert!((got - t).abs() < 1e-5, "{t} {b}: {got}");
        }
        // Nothing through: 0; nothing through and nothing reflected (black):
        // unknown; a bad value: unknown; an albedo of zero with light
        // through: all of it.
        assert_eq!(transmission_from(0.0, 0.4), Some(0.0));
        assert_eq!(transmission_from(0.0, 0.0), None);
        assert_eq!(transmission_from(f32::NAN, 0.4), None);
        assert_eq!(transmission_from(0.1, 0.0), Some(1.0));
        assert_eq!(transmission_from(-0.1, 0.4), Some(0.0));
        // Per material, the median over the measured pixels.
        let b = backlight(vec![
            (passed * 0.3).powi(2),
            f32::NAN,
            (passed * 0.3).powi(2),
            0.5,
        ]);
        let options = BacklightOptions {
            min_pixels: 2,
            ..Default::default()
        };
        let t = b.transmission(&[(0, 0.3), (1, 0.3), (2, 0.3)], &options);
        assert!(t.is_some_and(|t| (t - 0.5).abs() < 1e-5), "{t:?}");
        assert_eq!(b.transmission(&[(0, 0.3), (1, 0.3)], &options), None);
    }

    fn backlight(share: Vec<f32>) -> Backlight {
        Backlight {
            share,
            panel: [1.0; 3],
        }
    }

    #[test]
    fn a_material_passes_light_when_its_median_share_reaches_the_threshold() {
        let options = BacklightOptions {
            min_pixels: 3,
            ..Default::default()
        };
        let mut share = vec![0.0; 20];
        share[19] = 0.4;
        share.extend([f32::NAN, 0.05, 0.08, 0.03]);
        share.extend([0.0, 0.0, 0.0, 0.0, 0.003, 0.03, 0.2]);
        let b = backlight(share);
        // One bright pixel in twenty (a rim) does not make an opaque
        // material pass; NaN pixels are not counted.
        let opaque: Vec<usize> = (0..21).collect();
        let opaque = b.material(&opaque, &options).expect("20 measured");
        assert_eq!(opaque.passage, Passage::Blocked);
        assert_eq!(opaque.pixels, 20);
        assert_eq!((opaque.share, opaque.high), (0.0, 0.0));
        let through = b.material(&[21, 22, 23], &options).expect("3 measured");
        assert_eq!(through.passage, Passage::Passes);
        assert!((through.share - 0.05).abs() < 1e-6, "{through:?}");
        // Light through two pixels in seven: the material is not read
        // either way (a transmissive front over an opaque back).
        let part: Vec<usize> = (24..31).collect();
        let part = b.material(&part, &options).expect("7 measured");
        assert_eq!(part.passage, Passage::Partly, "{part:?}");
        assert!((part.high - 0.03).abs() < 1e-6, "{part:?}");
        // Too few measured pixels: no reading.
        assert_eq!(b.material(&[20, 21], &options), None);
    }
}
