//! Builds each network's input tensors from a scan's photos and
//! calibration, exactly in the channel order of [`Param::inputs`].
//!
//! Every view is brought into the reference position's camera image: its
//! photos and per-pixel maps (cosines, depth) are warped there through the
//! calibration's correspondences, and its mapped mask is the reference
//! object mask where the correspondence is valid.
//!
//! Encoding (the trainer must use the same, see [`centre`]):
//! - photos are first scaled to the ambient capture's exposure (photos are
//!   radiance times exposure), so every capture of a position compares;
//! - a value `v` meant to lie in `[0, 1]` (luma, offset chroma, square-root
//!   differences, parameter maps, normalised depth) enters as
//!   `2 clamp(v, 0, 1) - 1`; cosines enter as they are, clamped to [-1, 1];
//!   the mapped mask enters as 0 or 1 (0 in holes, as `spec` says);
//! - depth is normalised per view over its mapped mask, far = 1, and is 1
//!   outside it;
//! - the square-root difference is `sqrt(max(lit - ambient, 0))` (luma for
//!   the gray networks, per RGB then YCbCr for the colour ones);
//! - a view whose position has no backlit capture sees no backlight: its
//!   backlight difference is 0;
//! - without a white reference (see `calib`) the constant layers are 0 for
//!   ambient and 1 for the light, and [`SceneInputs::warnings`] says so.
//!
//! Out of scope: which networks run and what they are fed (see `plan`,
//! `pipeline`).

use crate::net::spec::InputChannel;
use crate::net::spec::NetworkSpec;
use crate::pipeline::views::{View, ViewSet};
use burn::tensor::{Device, Tensor, TensorData};
use matscan_calib::photos::{clip_levels, luma};
use matscan_calib::white_reference::ycbcr;
use matscan_calib::{CalibError, ScanCalibration};
use matscan_scan::capture_list::NeededCapture;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::Param;
use matscan_scan::{Bundle, ScanError};
use std::collections::HashMap;

/// `2 clamp(v, 0, 1) - 1`; non-finite values become 0 first.
pub fn centre(v: f32) -> f32 {
    let v = if v.is_finite() { v } else { 0.0 };
    2.0 * v.clamp(0.0, 1.0) - 1.0
}

/// The inverse of [`centre`], clamped to `[0, 1]`; non-finite values give 0.
pub fn uncentre(c: f32) -> f32 {
    if c.is_finite() {
        ((c + 1.0) * 0.5).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Linear RGB of BT.601 full-range YCbCr with chroma offset 0.5 (the
/// inverse of `calib`'s `ycbcr`), clamped to `[0, 1]`.
pub fn rgb_of_ycbcr([y, cb, cr]: [f32; 3]) -> [f32; 3] {
    let (cb, cr) = (cb - 0.5, cr - 0.5);
    let r = y + 1.402 * cr;
    let g = y - 0.344_136 * cb - 0.714_136 * cr;
    let b = y + 1.772 * cb;
    [r, g, b].map(|v| {
        if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }
    })
}

/// Assembling the inputs failed.
#[derive(Debug, thiserror::Error)]
pub enum InputsError {
    /// A photo or manifest entry could not be read.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// Warping into the reference position failed.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// Calibration has no maps for a position or light the view needs.
    #[error("calibration has no {what} for view {view}")]
    MissingMaps {
        /// The view.
        view: String,
        /// What is missing.
        what: String,
    },
    /// The position has no ambient capture.
    #[error("position `{0}` has no ambient capture (lights = [])")]
    NoAmbient(String),
    /// A network needs an input the caller did not provide.
    #[error("the {kind} network needs {channel:?}, which was not provided")]
    MissingDependency {
        /// The network.
        kind: Param,
        /// The channel.
        channel: InputChannel,
    },
}

/// One view's pixels in the reference image, already in ambient units.
#[derive(Clone, Debug)]
pub struct ViewPlanes {
    /// The view.
    pub view: View,
    /// Mapped mask: 1 where the view sees the reference's object.
    pub mask: Vec<f32>,
    ambient: Vec<[f32; 3]>,
    lit: Vec<[f32; 3]>,
    backlit: Option<Vec<[f32; 3]>>,
    checker: Option<Vec<[f32; 3]>>,
    cos_nl: Vec<f32>,
    cos_nv: Vec<f32>,
    cos_vl: Vec<f32>,
    /// Normalised depth in [0, 1], far = 1.
    depth: Vec<f32>,
    white_ambient: [f32; 3],
    white_lit: [f32; 3],
    ambient_exposure: f64,
    lit_exposure: f64,
    /// Per channel, the lit photo's clipping level in ambient exposure
    /// units (infinite where it shows none: see
    /// [`matscan_calib::photos::clip_levels`]).
    lit_clip: [f32; 3],
}

impl ViewPlanes {
    /// Whether `kind`'s network fuses this view: every view, except that
    /// the networks that need a backlit or checker capture
    /// ([`Param::needs`]) take only the views whose position has one.
    pub fn serves(&self, kind: Param) -> bool {
        match kind.needs() {
            Some(NeededCapture::Backlit) => self.has_backlit(),
            Some(NeededCapture::Checker) => self.has_checker(),
            None => true,
        }
    }

    /// Whether the view's position has a backlit capture.
    pub fn has_backlit(&self) -> bool {
        self.backlit.is_some()
    }

    /// The position's backlit capture, in the reference image, ambient
    /// exposure units; `None` where the position has none.
    pub fn backlit(&self) -> Option<&[[f32; 3]]> {
        self.backlit.as_deref()
    }

    /// Whether the view's position has a checker capture.
    pub fn has_checker(&self) -> bool {
        self.checker.is_some()
    }

    /// The lit capture, in the reference image, ambient exposure units.
    pub fn lit(&self) -> &[[f32; 3]] {
        &self.lit
    }

    /// The ambient capture, in the reference image.
    pub fn ambient(&self) -> &[[f32; 3]] {
        &self.ambient
    }

    /// N·L of the view's light (warped into the reference image).
    pub fn cos_nl(&self) -> &[f32] {
        &self.cos_nl
    }

    /// N·V of the view's camera.
    pub fn cos_nv(&self) -> &[f32] {
        &self.cos_nv
    }

    /// Eq. 3.4's azimuth cosine between view and light.
    pub fn cos_vl(&self) -> &[f32] {
        &self.cos_vl
    }

    /// The white reference's response to the light alone (lit minus
    /// ambient), ambient exposure units; `[1; 3]` without a reference.
    pub fn white_light(&self) -> [f32; 3] {
        [0, 1, 2].map(|c| self.white_lit[c] - self.white_ambient[c])
    }

    /// Exposure of the position's ambient capture (the planes' units), s.
    pub fn ambient_exposure(&self) -> f64 {
        self.ambient_exposure
    }

    /// Exposure of the view's lit capture, s.
    pub fn lit_exposure(&self) -> f64 {
        self.lit_exposure
    }

    /// Per channel, the value at which the lit photo clipped, in ambient
    /// exposure units; infinite where it did not.
    pub fn lit_clip(&self) -> [f32; 3] {
        self.lit_clip
    }
}

/// Photos already read, each scaled to its position's ambient exposure and
/// still in its own camera image: views of one position share its ambient,
/// backlit and checker photos, and assemblies with different references
/// (the pipeline's every-position mode) share all of them, so each photo
/// is read and decoded once. Holds every photo it read until dropped.
#[derive(Debug, Default)]
pub struct Photos {
    read: HashMap<(String, String), RgbRaster>,
}

impl Photos {
    /// The photo of `capture` at `position`, scaled to the ambient exposure.
    fn get(
        &mut self,
        bundle: &Bundle,
        position: &str,
        capture: &str,
        ambient_exposure: f64,
    ) -> Result<&RgbRaster, InputsError> {
        let key = (position.to_string(), capture.to_string());
        if !self.read.contains_key(&key) {
            let image = photo(bundle, position, capture, ambient_exposure)?;
            self.read.insert(key.clone(), image);
        }
        Ok(&self.read[&key])
    }
}

/// Maps other networks provide, each in `[0, 1]` per reference pixel
/// (already effective: see `pipeline`), and roughness's per-view
/// illumination (network units, one per view of the set).
#[derive(Clone, Copy, Debug, Default)]
pub struct Dependencies<'a> {
    /// Metallic.
    pub metallic: Option<&'a [f32]>,
    /// T (1 - M), equation 3.5.
    pub transmission_final: Option<&'a [f32]>,
    /// S (1 - M) (1 - T), equation 3.6.
    pub subsurface_final: Option<&'a [f32]>,
    /// Roughness.
    pub roughness: Option<&'a [f32]>,
    /// Per view (indexed like [`SceneInputs::views`]), in network units.
    pub illumination: Option<&'a [Vec<f32>]>,
}

/// Every view's planes in the reference image.
#[derive(Clone, Debug)]
pub struct SceneInputs {
    /// The reference position.
    pub reference: String,
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The reference's object mask.
    pub mask: MaskRaster,
    /// One entry per view, in view-set order.
    pub views: Vec<ViewPlanes>,
    /// Things the user should know (a missing white reference, ...).
    pub warnings: Vec<String>,
}

impl SceneInputs {
    /// Reads and warps every view of `set`.
    pub fn assemble(
        bundle: &Bundle,
        calibration: &ScanCalibration,
        set: &ViewSet,
    ) -> Result<SceneInputs, InputsError> {
        Self::assemble_with(bundle, calibration, set, &mut Photos::default())
    }

    /// [`assemble`](Self::assemble), taking photos from `photos` (and
    /// adding those it reads): for assembling the same views with several
    /// references.
    pub fn assemble_with(
        bundle: &Bundle,
        calibration: &ScanCalibration,
        set: &ViewSet,
        photos: &mut Photos,
    ) -> Result<SceneInputs, InputsError> {
        let reference = calibration
            .position(&set.reference)
            .ok_or_else(|| missing(&set.reference, "maps"))?;
        let mask = reference.maps.geometry.mask.clone();
        let (width, height) = (mask.width as usize, mask.height as usize);
        let mut warnings = Vec::new();
        let mut views = Vec::with_capacity(set.views.len());
        for view in &set.views {
            views.push(view_planes(
                bundle,
                calibration,
                set,
                view,
                photos,
                &mut warnings,
            )?);
        }
        Ok(SceneInputs {
            reference: set.reference.clone(),
            width,
            height,
            mask,
            views,
            warnings,
        })
    }

    /// Pixels per plane.
    pub fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// The input tensors of `kind`, one `[1, channels, height, width]` per
    /// view in `which` (indices into [`views`](Self::views)).
    pub fn tensors(
        &self,
        kind: Param,
        which: &[usize],
        deps: &Dependencies<'_>,
        device: &Device,
    ) -> Result<Vec<Tensor<4>>, InputsError> {
        let n = self.pixels();
        which
            .iter()
            .map(|&index| {
                let planes = &self.views[index];
                let mut data = Vec::with_capacity(kind.inputs().len() * n);
                for &channel in kind.inputs() {
                    fill(&mut data, channel, kind, planes, index, deps, n)?;
                }
                let shape = [1, kind.inputs().len(), self.height, self.width];
                Ok(Tensor::<4>::from_data(TensorData::new(data, shape), device))
            })
            .collect()
    }
}

fn missing(view: &str, what: &str) -> InputsError {
    InputsError::MissingMaps {
        view: view.to_string(),
        what: what.to_string(),
    }
}

fn dependency<T: ?Sized>(
    value: Option<&T>,
    kind: Param,
    channel: InputChannel,
) -> Result<&T, InputsError> {
    value.ok_or(InputsError::MissingDependency { kind, channel })
}

fn fill(
    out: &mut Vec<f32>,
    channel: InputChannel,
    kind: Param,
    p: &ViewPlanes,
    index: usize,
    deps: &Dependencies<'_>,
    n: usize,
) -> Result<(), InputsError> {
    use InputChannel as I;
    let sqrt_diff = |a: &[f32; 3], b: &[f32; 3]| -> [f32; 3] {
        [0, 1, 2].map(|c| (a[c] - b[c]).max(0.0).sqrt())
    };
    let luma_diff = |a: &[f32; 3], b: &[f32; 3]| (luma(*a) - luma(*b)).max(0.0).sqrt();
    let constant = |out: &mut Vec<f32>, v: f32| out.extend(std::iter::repeat_n(centre(v), n));
    match channel {
        I::MappedMask => out.extend_from_slice(&p.mask),
        I::AmbientY => out.extend(p.ambient.iter().map(|c| centre(ycbcr(*c)[0]))),
        I::AmbientCb => out.extend(p.ambient.iter().map(|c| centre(ycbcr(*c)[1]))),
        I::AmbientCr => out.extend(p.ambient.iter().map(|c| centre(ycbcr(*c)[2]))),
        I::LitSqrtDiffLuma => out.extend(
            p.lit
                .iter()
                .zip(&p.ambient)
                .map(|(l, a)| centre(luma_diff(l, a))),
        ),
        I::LitSqrtDiffY | I::LitSqrtDiffCb | I::LitSqrtDiffCr => {
            let c = match channel {
                I::LitSqrtDiffY => 0,
                I::LitSqrtDiffCb => 1,
                _ => 2,
            };
            out.extend(
                p.lit
                    .iter()
                    .zip(&p.ambient)
                    .map(|(l, a)| centre(ycbcr(sqrt_diff(l, a))[c])),
            )
        }
        I::BacklightSqrtDiffLuma => match &p.backlit {
            Some(back) => out.extend(
                back.iter()
                    .zip(&p.ambient)
                    .map(|(b, a)| centre(luma_diff(b, a))),
            ),
            None => constant(out, 0.0),
        },
        I::CheckerLuma => match &p.checker {
            Some(checker) => out.extend(checker.iter().map(|c| centre(luma(*c)))),
            None => constant(out, 0.0),
        },
        I::CosNormalLight => out.extend(p.cos_nl.iter().map(|&c| cosine(c))),
        I::CosNormalView => out.extend(p.cos_nv.iter().map(|&c| cosine(c))),
        I::CosViewLight => out.extend(p.cos_vl.iter().map(|&c| cosine(c))),
        I::WhiteAmbientLuma => constant(out, luma(p.white_ambient)),
        I::WhiteLitDiffLuma => constant(out, luma(p.white_lit) - luma(p.white_ambient)),
        I::WhiteAmbientY => constant(out, ycbcr(p.white_ambient)[0]),
        I::WhiteAmbientCb => constant(out, ycbcr(p.white_ambient)[1]),
        I::WhiteAmbientCr => constant(out, ycbcr(p.white_ambient)[2]),
        I::WhiteLitY => constant(out, ycbcr(p.white_lit)[0]),
        I::WhiteLitCb => constant(out, ycbcr(p.white_lit)[1]),
        I::WhiteLitCr => constant(out, ycbcr(p.white_lit)[2]),
        I::Depth => out.extend(p.depth.iter().map(|&d| centre(d))),
        I::Metallic => out.extend(
            dependency(deps.metallic, kind, channel)?
                .iter()
                .map(|&v| centre(v)),
        ),
        I::TransmissionFinal => out.extend(
            dependency(deps.transmission_final, kind, channel)?
                .iter()
                .map(|&v| centre(v)),
        ),
        I::SubsurfaceFinal => out.extend(
            dependency(deps.subsurface_final, kind, channel)?
                .iter()
                .map(|&v| centre(v)),
        ),
        I::Roughness => out.extend(
            dependency(deps.roughness, kind, channel)?
                .iter()
                .map(|&v| centre(v)),
        ),
        I::Illumination | I::IlluminationInverted => {
            let all = dependency(deps.illumination, kind, channel)?;
            let view = all
                .get(index)
                .ok_or(InputsError::MissingDependency { kind, channel })?;
            let sign = if channel == I::Illumination {
                1.0
            } else {
                -1.0
            };
            out.extend(view.iter().map(|&v| sign * cosine(v)));
        }
    }
    Ok(())
}

fn cosine(c: f32) -> f32 {
    if c.is_finite() {
        c.clamp(-1.0, 1.0)
    } else {
        0.0
    }
}

/// The photo of `capture` at `position`, scaled to the ambient exposure.
fn photo(
    bundle: &Bundle,
    position: &str,
    capture: &str,
    ambient_exposure: f64,
) -> Result<RgbRaster, InputsError> {
    Ok(scaled_photo(bundle, position, capture, ambient_exposure)?)
}

/// The photo of `capture` at `position` read and scaled to
/// `ambient_exposure`, in its own camera image.
pub(crate) fn scaled_photo(
    bundle: &Bundle,
    position: &str,
    capture: &str,
    ambient_exposure: f64,
) -> Result<RgbRaster, ScanError> {
    let exposure = bundle.capture(position, capture)?.exposure_s;
    let k = exposure_scale(ambient_exposure, exposure);
    let mut image = bundle.read_photo(position, capture)?;
    for px in &mut image.data {
        *px = px.map(|v| v * k);
    }
    Ok(image)
}

/// What photos taken at `capture` seconds are multiplied by to read in
/// `ambient` exposure units; 1 when either is unusable.
pub(crate) fn exposure_scale(ambient: f64, capture: f64) -> f32 {
    if capture > 0.0 && ambient.is_finite() && capture.is_finite() {
        (ambient / capture) as f32
    } else {
        1.0
    }
}

fn view_planes(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    set: &ViewSet,
    view: &View,
    photos: &mut Photos,
    warnings: &mut Vec<String>,
) -> Result<ViewPlanes, InputsError> {
    let name = view.to_string();
    let position = bundle.position(&view.position)?;
    let ambient_capture = position
        .ambient()
        .ok_or_else(|| InputsError::NoAmbient(view.position.clone()))?;
    let ambient_exposure = ambient_capture.exposure_s;
    let calib = calibration
        .position(&view.position)
        .ok_or_else(|| missing(&name, "maps"))?;
    let light = calib
        .maps
        .light(&view.light)
        .ok_or_else(|| missing(&name, &format!("light maps of `{}`", view.light)))?;
    let reference = calibration
        .position(&set.reference)
        .ok_or_else(|| missing(&name, "reference maps"))?;
    let ref_mask = &reference.maps.geometry.mask;
    // The reference sees itself directly; other positions through a warp.
    let warp = if view.position == set.reference {
        None
    } else {
        Some(
            calibration
                .correspondence(&set.reference, &view.position)
                .ok_or_else(|| missing(&name, "correspondence with the reference"))?,
        )
    };
    let mut rgb = |capture: &str| -> Result<Vec<[f32; 3]>, InputsError> {
        let image = photos.get(bundle, &view.position, capture, ambient_exposure)?;
        Ok(match warp {
            Some(c) => c.warp_rgb(image, capture)?.data,
            None => image.data.clone(),
        })
    };
    let scalar = |map: &ScalarRaster, label: &str| -> Result<Vec<f32>, InputsError> {
        Ok(match warp {
            Some(c) => c.warp_scalar(map, label)?.data,
            None => map.data.clone(),
        })
    };
    let mask: Vec<f32> = ref_mask
        .data
        .iter()
        .enumerate()
        .map(|(i, &m)| {
            let valid = warp.is_none_or(|c| c.valid.data[i]);
            if m && valid {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let ambient = rgb(&ambient_capture.name)?;
    let lit = rgb(&view.capture)?;
    let backlit = position.backlit().map(|c| rgb(&c.name)).transpose()?;
    let checker = position
        .pattern_captures()
        .next()
        .map(|c| rgb(&c.name))
        .transpose()?;
    let geometry = &calib.maps.geometry;
    // Read in the photo's own image: a warp would blur the pile-up.
    let lit_clip = clip_levels(
        photos.get(bundle, &view.position, &view.capture, ambient_exposure)?,
        Some(&geometry.mask),
    )
    .map(|level| level.unwrap_or(f32::INFINITY));
    let cos_nl = scalar(&light.cos_nl, "cos_nl")?;
    let cos_vl = scalar(&light.cos_vl, "cos_vl")?;
    let cos_nv = scalar(&geometry.cos_nv, "cos_nv")?;
    let depth = normalised_depth(&scalar(&geometry.depth, "depth")?, &mask);
    let lit_exposure = bundle.capture(&view.position, &view.capture)?.exposure_s;
    let (white_ambient, white_lit) = match &calib.light_response {
        Ok(white) => match white.response(&view.capture) {
            Some(r) => {
                let k = exposure_scale(ambient_exposure, lit_exposure);
                let lit = r.rgb.map(|v| v * k);
                let ambient = [0, 1, 2].map(|c| (r.rgb[c] - r.rgb_minus_ambient[c]) * k);
                (ambient, lit)
            }
            None => {
                warnings.push(format!(
                    "view {name}: the white reference has no response to this capture; \
                     using 0 (ambient) and 1 (lit)"
                ));
                ([0.0; 3], [1.0; 3])
            }
        },
        Err(e) => {
            warnings.push(format!(
                "view {name}: no white reference ({e}); using 0 (ambient) and 1 (lit)"
            ));
            ([0.0; 3], [1.0; 3])
        }
    };
    Ok(ViewPlanes {
        view: view.clone(),
        mask,
        ambient,
        lit,
        backlit,
        checker,
        cos_nl,
        cos_nv,
        cos_vl,
        depth,
        white_ambient,
        white_lit,
        ambient_exposure,
        lit_exposure,
        lit_clip,
    })
}

/// Depth scaled to [0, 1] over the mask (far = 1); 1 outside it, 0.5
/// where the masked depth is constant.
fn normalised_depth(depth: &[f32], mask: &[f32]) -> Vec<f32> {
    let inside = || {
        depth
            .iter()
            .zip(mask)
            .filter(|(d, m)| **m > 0.5 && d.is_finite())
            .map(|(d, _)| *d)
    };
    let lo = inside().fold(f32::INFINITY, f32::min);
    let hi = inside().fold(f32::NEG_INFINITY, f32::max);
    depth
        .iter()
        .zip(mask)
        .map(|(&d, &m)| {
            if m <= 0.5 || !d.is_finite() {
                1.0
            } else if hi > lo {
                ((d - lo) / (hi - lo)).clamp(0.0, 1.0)
            } else {
                0.5
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centring_maps_the_unit_interval_onto_plus_minus_one() {
        assert_eq!(centre(0.0), -1.0);
        assert_eq!(centre(1.0), 1.0);
        assert_eq!(centre(0.25), -0.5);
        assert_eq!(centre(7.0), 1.0);
        assert_eq!(centre(f32::NAN), -1.0);
        assert_eq!(uncentre(-0.5), 0.25);
        assert_eq!(uncentre(f32::INFINITY), 0.0);
    }

    #[test]
    fn ycbcr_round_trips_through_rgb() {
        for rgb in [
            [0.2, 0.5, 0.9],
            [1.0, 1.0, 1.0],
            [0.0, 0.0, 0.0],
            [0.7, 0.1, 0.3],
        ] {
            let back = rgb_of_ycbcr(ycbcr(rgb));
            for c in 0..3 {
                assert!((back[c] - rgb[c]).abs() < 1e-5, "{rgb:?} -> {back:?}");
            }
        }
    }

    #[test]
    fn depth_is_normalised_over_the_mask_with_far_bright() {
        let d = normalised_depth(&[2.0, 4.0, 3.0, 100.0], &[1.0, 1.0, 1.0, 0.0]);
        assert_eq!(d, vec![0.0, 1.0, 0.5, 1.0]);
        let flat = normalised_depth(&[2.0, 2.0], &[1.0, 1.0]);
        assert_eq!(flat, vec![0.5, 0.5]);
    }
}
