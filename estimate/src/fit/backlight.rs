//! Transmission measured from the backlight: how much of the panel's own
//! radiance reaches the camera through each object pixel.
//!
//! The backlit photo minus the ambient one at a pixel is the panel's light
//! that crossed the object on its way to the camera. The panel's radiance
//! is read from the same photo right beside the silhouette (a band of
//! panel pixels a few pixels out, trimmed mean), so no calibration of the
//! panel is needed. The Principled BSDF's glass lobe passes, per crossing
//! of a surface, `t (1 - F) basecolor` of the light (`t` the effective
//! transmission, `F` the dielectric Fresnel reflectance), so over the `k`
//! surfaces the straight camera ray crosses
//! ([`matscan_calib::geometry::surface_crossings`]) the ratio is
//! `Π (1 - F_j) (t basecolor)^k`. Inverting it per channel gives the
//! per-crossing transmittance `q = t basecolor`, the product this module
//! returns: with the diffuse albedo `(1 - t) basecolor` the flashes show,
//! `t = Σq / Σ(q + albedo)` (see [`transmission_of`]).
//!
//! What it leaves out, and why: pixels seen at grazing angles (rim light
//! of the panel falls on them whatever they are made of, and their ray
//! through the object is the least straight), pixels whose panel light is
//! below the photo's noise (nothing transmitted, or too little to tell),
//! and the background. Subsurface scattering also carries panel light
//! through thin parts; its share is what a caller that pins transmission
//! per material must judge against (see `pipeline::run`).
//!
//! Boundaries: the reference position's backlit photo only (other
//! positions' would need their own crossings); no file I/O beyond the
//! scan's mesh.

use crate::pipeline::inputs::SceneInputs;
use crate::refine::RefineError;
use matscan_bsdf::fresnel_dielectric_cos;
use matscan_bsdf::material::IOR;
use matscan_calib::geometry::surface_crossings;
use matscan_calib::photos::luma;
use matscan_calib::white_reference::{robust_mean, segment_panel};
use matscan_scan::bvh::RayCaster;
use matscan_scan::raster::{MaskRaster, RgbRaster};
use matscan_scan::Bundle;

/// Where the measurement looks and what it trusts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BacklightOptions {
    /// Pixels with a smaller `cos_nv` are left out (rim light, bent rays).
    pub min_cos_nv: f32,
    /// The panel band: panel pixels farther than `gap_px` and at most
    /// `band_px` (Chebyshev distance) from the object's silhouette.
    pub gap_px: u32,
    pub band_px: u32,
    /// Panel segmentation threshold, a fraction of the backlight
    /// difference's 99th percentile luma (as the white reference's).
    pub panel_threshold: f32,
    /// Trimmed share at each end of the panel's robust mean.
    pub trim: f32,
    /// A pixel is measured only where its backlight difference's luma is
    /// above this fraction of the panel's (below it the photo cannot tell
    /// a little transmission from none).
    pub noise_floor: f32,
}

impl Default for BacklightOptions {
    fn default() -> Self {
        BacklightOptions {
            min_cos_nv: 0.5,
            gap_px: 2,
            band_px: 10,
            panel_threshold: 0.5,
            trim: 0.1,
            noise_floor: 2e-3,
        }
    }
}

/// The backlight as the reference image sees it.
#[derive(Clone, Debug)]
pub struct BacklightMeasure {
    /// The panel's radiance, in the reference's ambient exposure units.
    pub panel: [f32; 3],
    /// Panel pixels it was read from.
    pub panel_pixels: usize,
    /// Per reference pixel, the surfaces the camera ray crosses.
    pub crossings: Vec<u8>,
    /// Per reference pixel, `t · basecolor` per channel (see the module
    /// doc); `None` where the pixel is not measured (background, grazing,
    /// below the noise floor).
    pub transmittance: Vec<Option<[f32; 3]>>,
    /// Object pixels facing the camera well enough to be measured, those
    /// below the noise floor included (they measured "nothing passes").
    pub facing: usize,
}

/// The backlight measurement of `inputs`' reference image, or `None` with
/// the reason when the scan cannot give it (no backlit capture at the
/// reference position, no panel visible beside the object).
pub fn measure_backlight(
    bundle: &Bundle,
    inputs: &SceneInputs,
    options: &BacklightOptions,
) -> Result<Result<BacklightMeasure, String>, RefineError> {
    let Some(planes) = inputs
        .views
        .iter()
        .find(|v| v.view.position == inputs.reference && v.backlit().is_some())
    else {
        return Ok(Err(format!(
            "the reference position {} has no backlit capture",
            inputs.reference
        )));
    };
    let Some(backlit) = planes.backlit() else {
        return Ok(Err("no backlit capture".to_string()));
    };
    let (w, h) = (inputs.width, inputs.height);
    let diff: Vec<[f32; 3]> = backlit
        .iter()
        .zip(planes.ambient())
        .map(|(b, a)| [0, 1, 2].map(|c| b[c] - a[c]))
        .collect();
    let diff = RgbRaster {
        width: w as u32,
        height: h as u32,
        data: diff,
    };
    let mask = &inputs.mask;
    let Some((panel, panel_pixels)) = panel_radiance(&diff, mask, options) else {
        return Ok(Err(
            "the backlit photo shows no panel beside the object".to_string()
        ));
    };
    let caster = RayCaster::new(bundle.read_mesh()?);
    let camera = bundle.camera(&inputs.reference)?;
    let crossings = surface_crossings(&caster, &camera);
    let crossings = if crossings.data.len() == w * h {
        crossings.data
    } else {
        return Ok(Err(format!(
            "the camera of {} is {}x{}, its photos {w}x{h}",
            inputs.reference, crossings.width, crossings.height
        )));
    };
    let f_normal = fresnel_dielectric_cos(1.0, IOR);
    let floor = options.noise_floor * luma(panel);
    let mut facing = 0;
    let transmittance = (0..w * h)
        .map(|i| {
            let cos = planes.cos_nv()[i];
            let k = crossings[i];
            if !mask.data[i] || !(cos >= options.min_cos_nv) || k == 0 {
                return None;
            }
            facing += 1;
            let d = diff.data[i];
            if !(luma(d) > floor) {
                return None;
            }
            let passed = (1.0 - fresnel_dielectric_cos(cos, IOR))
                * (1.0 - f_normal).powi(i32::from(k) - 1);
            let q = [0, 1, 2].map(|c| {
                let ratio = (d[c].max(0.0) / panel[c]) / passed;
                ratio.powf(1.0 / f32::from(k)).clamp(0.0, 1.0)
            });
            q.iter().all(|v| v.is_finite()).then_some(q)
        })
        .collect();
    Ok(Ok(BacklightMeasure {
        panel,
        panel_pixels,
        crossings,
        transmittance,
        facing,
    }))
}

/// The effective transmission of a region whose per-crossing
/// transmittance sums to `q` and whose diffuse albedo (what the flashes
/// show, `(1 - t) basecolor`) sums to `albedo`, per channel: `Σq / Σ(q +
/// albedo)`, in [0, 1]; `None` when both are zero.
pub fn transmission_of(q: [f64; 3], albedo: [f64; 3]) -> Option<f32> {
    let through: f64 = q.iter().map(|v| v.max(0.0)).sum();
    let all: f64 = through + albedo.iter().map(|v| v.max(0.0)).sum::<f64>();
    (all > 0.0 && all.is_finite()).then(|| (through / all).clamp(0.0, 1.0) as f32)
}

/// The panel's radiance (trimmed mean of the backlight difference over the
/// panel band around the silhouette; the whole panel where the band holds
/// too few pixels) and the pixels it was read from.
fn panel_radiance(
    diff: &RgbRaster,
    object: &MaskRaster,
    options: &BacklightOptions,
) -> Option<([f32; 3], usize)> {
    const MIN_PIXELS: usize = 16;
    let panel = segment_panel(diff, options.panel_threshold);
    let near = dilate(object, options.band_px);
    let touching = dilate(object, options.gap_px);
    let band = MaskRaster {
        width: panel.width,
        height: panel.height,
        data: (0..panel.data.len())
            .map(|i| panel.data[i] && near.data[i] && !touching.data[i])
            .collect(),
    };
    let (rgb, n) = match robust_mean(diff, &band, options.trim) {
        Some((rgb, n)) if n >= MIN_PIXELS => (rgb, n),
        _ => robust_mean(diff, &panel, options.trim)?,
    };
    (n >= MIN_PIXELS && rgb.iter().all(|v| *v > 0.0 && v.is_finite())).then_some((rgb, n))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transmission_is_the_share_of_light_that_passes() {
        // basecolor 0.8, t = 0.25: q = 0.2, albedo 0.6.
        let t = transmission_of([0.2; 3], [0.6; 3]);
        assert!(t.is_some_and(|t| (t - 0.25).abs() < 1e-6), "{t:?}");
        assert_eq!(transmission_of([0.0; 3], [0.0; 3]), None);
        assert_eq!(transmission_of([0.3; 3], [0.0; 3]), Some(1.0));
        assert_eq!(transmission_of([f64::NAN; 3], [0.5; 3]), Some(0.0));
    }

    #[test]
    fn dilation_grows_by_the_radius_and_no_further() {
        let mut data = vec![false; 49];
        data[3 * 7 + 3] = true;
        let m = MaskRaster {
            width: 7,
            height: 7,
            data,
        };
        let d = dilate(&m, 2);
        assert_eq!(d.data.iter().filter(|&&v| v).count(), 25);
        assert!(d.data[7 + 1] && !d.data[0]);
    }
}
