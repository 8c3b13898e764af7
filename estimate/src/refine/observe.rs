//! A scan's views as per-pixel [`Observation`]s: the lit-minus-ambient
//! photo, the local directions from the calibration cosines, the trust of
//! `loss::view_weight`, and the light arriving at the pixel, from one of
//! two sources ([`IlluminationSource`]):
//!
//! - calibration: `exposure · I · colour · pattern / (π d²)` from the
//!   manifest's light (intensity, colour, the capture's uniform pattern
//!   level), the calibrated distance and shadow mask, warped into the
//!   reference image; exact for direct light, blind to interreflections;
//! - the roughness network's per-view illumination (luma of the white
//!   diffuse render, interreflections included but blurred and clamped to
//!   [0, 1]), tinted by the white reference's colour and divided by the
//!   white diffuse BSDF's `π f cos` to undo its cosine.
//!
//! Which is better was measured on the held-out set (see `refine`'s doc);
//! a view the chosen source cannot light (no intensity in the manifest, a
//! checkerboard pattern) falls back to the network, or is left out.

use super::error::RefineError;
use super::loss::{view_weight, ViewEvidence};
use super::model::{directions, white_response, Observation};
use crate::pipeline::inputs::{SceneInputs, ViewPlanes};
use matscan_calib::photos::luma;
use matscan_calib::ScanCalibration;
use matscan_scan::Bundle;
use serde::{Deserialize, Serialize};

/// Where the light arriving at each pixel comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IlluminationSource {
    /// Manifest light, calibrated distance and shadow mask.
    #[default]
    Calibration,
    /// The roughness network's per-view illumination estimate.
    Network,
}

/// One view's light per reference pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct ViewLighting {
    /// White-Lambertian radiance at normal incidence, RGB, photo units.
    pub light: Vec<[f32; 3]>,
    /// The light's share of the pixel (1 lit, 0 shadow).
    pub lit: Vec<f32>,
    /// Per channel, the photo value at or above which it counts as
    /// clipped, in the view's (ambient exposure) units.
    pub clip: [f32; 3],
    /// The global light this view's light puts on each pixel (see
    /// `fit::separation`); `None` where it was not measured.
    pub global: Option<Vec<[f32; 3]>>,
}

/// The lighting of `planes` from calibration; `None` when the manifest
/// lacks what it needs (no intensity, a patterned capture).
pub fn calibrated_lighting(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    reference: &str,
    planes: &ViewPlanes,
    saturation: f32,
) -> Result<Option<ViewLighting>, RefineError> {
    let view = &planes.view;
    let capture = bundle.capture(&view.position, &view.capture)?;
    let Some(level) = capture.uniform_level() else {
        return Ok(None);
    };
    let Some(PointLight { light, lit }) = point_light(
        bundle,
        calibration,
        reference,
        &view.position,
        &view.light,
        light_exposure(planes) * level,
    )?
    else {
        return Ok(None);
    };
    Ok(Some(ViewLighting {
        light,
        lit,
        clip: clip_level(planes, saturation),
        global: None,
    }))
}

/// The exposure, s, that a view's calibrated light is given in: its
/// photos' (the ambient exposure), 1 where that is not usable.
pub fn light_exposure(planes: &ViewPlanes) -> f64 {
    let ambient_exposure = planes.ambient_exposure();
    if ambient_exposure.is_finite() && ambient_exposure > 0.0 {
        ambient_exposure
    } else {
        1.0
    }
}

/// A light of one position seen from the reference image.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    /// White-Lambertian radiance at normal incidence per reference pixel,
    /// RGB: `scale · I · colour / (π d²)`, 0 where the distance is not
    /// usable.
    pub light: Vec<[f32; 3]>,
    /// The light's share of the pixel (1 lit, 0 shadow).
    pub lit: Vec<f32>,
}

/// Light `name` of `position` per reference pixel from the manifest's
/// intensity and the calibrated distance and shadow maps (warped into
/// `reference`), scaled by `scale` (exposure times pattern level); `None`
/// when the manifest gives the light no usable intensity.
pub fn point_light(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    reference: &str,
    position: &str,
    name: &str,
    scale: f64,
) -> Result<Option<PointLight>, RefineError> {
    let Some(light) = bundle.position(position)?.light(name) else {
        return Ok(None);
    };
    let Some(intensity) = light.intensity.filter(|i| i.is_finite() && *i >= 0.0) else {
        return Ok(None);
    };
    let maps = calibration
        .position(position)
        .and_then(|p| p.maps.light(name))
        .ok_or_else(|| RefineError::MissingMaps(format!("{position}/{name}")))?;
    let lit_map = maps.lit.map(|&l| if l { 1.0f32 } else { 0.0 });
    let (distance, lit) = if position == reference {
        (maps.distance.data.clone(), lit_map.data)
    } else {
        let c = calibration
            .correspondence(reference, position)
            .ok_or_else(|| RefineError::MissingMaps(format!("{position}/{name}")))?;
        (
            c.warp_scalar(&maps.distance, "light distance")?.data,
            c.warp_scalar(&lit_map, "light shadow mask")?.data,
        )
    };
    let k = scale * intensity / std::f64::consts::PI;
    let light = distance
        .iter()
        .map(|&d| {
            let d = f64::from(d);
            if d.is_finite() && d > 1e-6 {
                light.color.map(|c| (k * c / (d * d)) as f32)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    Ok(Some(PointLight { light, lit }))
}

/// The lighting of `planes` from the roughness network's illumination
/// (values in [0, 1], one per reference pixel).
pub fn network_lighting(planes: &ViewPlanes, illumination: &[f32], clip: [f32; 3]) -> ViewLighting {
    let white = planes.white_light();
    let y = luma(white);
    let tint = if y.is_finite() && y > 1e-6 {
        white.map(|c| (c / y).max(0.0))
    } else {
        [1.0; 3]
    };
    let n = planes.mask.len();
    let light = (0..n)
        .map(|i| {
            let (wo, wi) = directions(planes.cos_nv()[i], planes.cos_nl()[i], planes.cos_vl()[i]);
            let response = white_response(wo, wi);
            let e = illumination.get(i).copied().unwrap_or(0.0);
            if response > 0.05 && e.is_finite() {
                tint.map(|t| t * e.max(0.0) / response)
            } else {
                [0.0; 3]
            }
        })
        .collect();
    ViewLighting {
        light,
        lit: vec![1.0; n],
        clip,
        global: None,
    }
}

/// The level at or above which a channel of `planes`' lit photo counts as
/// clipped, in ambient exposure units: `saturation` times the level the
/// photo shows it clipped at, infinite where it shows none.
pub fn clip_level(planes: &ViewPlanes, saturation: f32) -> [f32; 3] {
    planes.lit_clip().map(|level| saturation * level)
}

/// One view of one pixel as the photos show it, before deciding what a
/// clipped channel means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seen {
    /// Lit minus ambient as measured, and the trust of an unclipped view.
    pub observation: Observation,
    /// Per channel: the lit photo reached the clipping level (or is NaN).
    pub clipped: [bool; 3],
    /// Per channel: the clipping level minus ambient, the least that a
    /// clipped channel's lit minus ambient would have been.
    pub floor: [f32; 3],
    /// Per channel, the part of lit minus ambient that is global light
    /// (0 where unmeasured).
    pub global: [f32; 3],
}

/// View `planes` of reference pixel `i` under `lighting`.
pub fn seen(planes: &ViewPlanes, lighting: &ViewLighting, i: usize) -> Seen {
    let lit = planes.lit()[i];
    let ambient = planes.ambient()[i];
    let weight = view_weight(&ViewEvidence {
        visible: planes.mask[i] > 0.5,
        lit: lighting.lit[i],
        cos_nl: planes.cos_nl()[i],
        cos_nv: planes.cos_nv()[i],
        saturated: false,
    });
    let finite = |d: f32| if d.is_finite() { d } else { 0.0 };
    let global = lighting
        .global
        .as_ref()
        .and_then(|g| g.get(i).copied())
        .map_or([0.0; 3], |g| g.map(finite));
    let (wo, wi) = directions(planes.cos_nv()[i], planes.cos_nl()[i], planes.cos_vl()[i]);
    Seen {
        observation: Observation {
            wo,
            wi,
            light: lighting.light[i],
            observed: [0, 1, 2].map(|c| finite(lit[c] - ambient[c])),
            weight,
        },
        clipped: [0, 1, 2].map(|c| lit[c].is_nan() || lit[c] >= lighting.clip[c]),
        floor: [0, 1, 2].map(|c| finite(lighting.clip[c] - ambient[c])),
        global,
    }
}

/// Every view's observation of reference pixel `i` (views whose lighting
/// is `None` are left out); a view with a clipped channel gets weight 0.
pub fn observations(
    inputs: &SceneInputs,
    lighting: &[Option<ViewLighting>],
    i: usize,
) -> Vec<Observation> {
    inputs
        .views
        .iter()
        .zip(lighting)
        .filter_map(|(planes, lighting)| {
            let s = seen(planes, lighting.as_ref()?, i);
            let mut o = s.observation;
            if s.clipped.iter().any(|&c| c) {
                o.weight = 0.0;
            }
            Some(o)
        })
        .collect()
}
