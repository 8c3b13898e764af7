//! One position prepared for the fusion: its camera, the valid pixels, the
//! distance of every pixel to the silhouette, how well the rig's lights
//! reach each pixel, and its maps as planes indexed by output slot.
//!
//! Illumination comes from `matscan_calib::position_maps`: a pixel is lit
//! where at least one posed light (flash or projector) reaches it (front
//! side, unoccluded, inside the projector's image). The backlight has no
//! pose and does not count. Those maps are the scan's calibration's own
//! where the caller has it (the estimate just made it); otherwise they
//! are computed here, at the camera's resolution, at the cost of one
//! calibration of the position, not per texel.

use crate::distance::distance_to_background;
use crate::error::BakeError;
use crate::maps::BakeInput;
use crate::sampling::{scalar_plane, Plane};
use glam::Vec3;
use matscan_calib::PixelMaps;
use matscan_scan::bvh::RayCaster;
use matscan_scan::estimate_maps::MapValues;
use matscan_scan::{Manifest, Param, PinholeCamera, ScanError};
use std::path::Path;

/// One parameter map of a view, in the slot of its parameter.
#[derive(Debug, Clone)]
pub(crate) struct ViewMap {
    pub values: Plane,
    pub confidence: Option<Vec<f32>>,
}

#[derive(Debug, Clone)]
pub(crate) struct PositionView {
    pub camera: PinholeCamera,
    pub center: Vec3,
    pub width: usize,
    pub height: usize,
    /// Pixels whose map values may be used.
    pub valid: Vec<bool>,
    /// Distance to the nearest invalid pixel, pixels.
    pub silhouette: Vec<f32>,
    /// 1 where some posed light reaches the pixel, else 0.
    pub lit: Vec<f32>,
    /// Indexed like the fusion's parameter slots.
    pub maps: Vec<Option<ViewMap>>,
}

impl PositionView {
    /// Prepares `input` for parameter slots `slots`; `manifest_path` names
    /// the manifest in errors. `calibrated` is the position's pixel maps
    /// where a calibration of the scan already made them.
    pub fn prepare(
        manifest: &Manifest,
        manifest_path: &Path,
        caster: &RayCaster,
        input: &BakeInput,
        slots: &[Param],
        calibrated: Option<&PixelMaps>,
    ) -> Result<PositionView, BakeError> {
        let position = manifest
            .positions
            .iter()
            .find(|p| p.name == input.position_maps.position)
            .ok_or_else(|| ScanError::NotInManifest {
                path: manifest_path.to_path_buf(),
                message: format!(
                    "maps were given for position `{}`, which the manifest does not list",
                    input.position_maps.position
                ),
            })?;
        let computed;
        let calib = match calibrated {
            Some(maps) => maps,
            None => {
                computed = matscan_calib::position_maps(caster, &manifest.camera, position);
                &computed
            }
        };
        let camera = calib.camera;
        let (width, height) = (
            manifest.camera.width as usize,
            manifest.camera.height as usize,
        );
        let mut valid = calib.geometry.mask.data.clone();
        if let Some(mask) = &input.mask {
            check_size(
                &input.position_maps.position,
                "mask",
                mask.width,
                mask.height,
                mask.data.len(),
                width,
                height,
            )?;
            for (v, &m) in valid.iter_mut().zip(&mask.data) {
                *v &= m;
            }
        }
        let mut lit = vec![0.0f32; width * height];
        for light in &calib.lights {
            for (l, &on) in lit.iter_mut().zip(&light.lit.data) {
                if on {
                    *l = 1.0;
                }
            }
        }
        let mut maps: Vec<Option<ViewMap>> = vec![None; slots.len()];
        for map in &input.position_maps.maps {
            let Some(slot) = slots.iter().position(|&p| p == map.param()) else {
                continue;
            };
            let (w, h, len) = match map.values() {
                MapValues::Rgb(r) => (r.width, r.height, r.data.len()),
                MapValues::Scalar(r) => (r.width, r.height, r.data.len()),
            };
            check_size(
                &input.position_maps.position,
                map.param().name(),
                w,
                h,
                len,
                width,
                height,
            )?;
            let values = match map.values() {
                MapValues::Rgb(r) => Plane {
                    channels: 3,
                    data: r.data.iter().flatten().map(|&v| finite(v)).collect(),
                },
                MapValues::Scalar(r) => {
                    let mut p = scalar_plane(r);
                    p.data.iter_mut().for_each(|v| *v = finite(*v));
                    p
                }
            };
            if let Some(c) = map.confidence() {
                let what = format!("{}_confidence", map.param());
                check_size(
                    &input.position_maps.position,
                    &what,
                    c.width,
                    c.height,
                    c.data.len(),
                    width,
                    height,
                )?;
            }
            let confidence = map
                .confidence()
                .map(|c| c.data.iter().map(|&v| finite(v).clamp(0.0, 1.0)).collect());
            maps[slot] = Some(ViewMap { values, confidence });
        }
        let silhouette = distance_to_background(&valid, width, height);
        Ok(PositionView {
            center: camera.center().as_vec3(),
            camera,
            width,
            height,
            valid,
            silhouette,
            lit,
            maps,
        })
    }
}

/// NaN and infinity count as 0 (a map never legitimately holds them; the
/// scan crate's readers already refuse them, in-memory callers may not).
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

fn check_size(
    position: &str,
    what: &str,
    w: u32,
    h: u32,
    len: usize,
    width: usize,
    height: usize,
) -> Result<(), BakeError> {
    // The fields of a raster are public: its data may not fill its size.
    if (w as usize, h as usize) != (width, height) || len != width * height {
        return Err(BakeError::SizeMismatch {
            param: format!("position {position}: {what}"),
            expected_width: width as u32,
            expected_height: height as u32,
            found_width: w,
            found_height: h,
        });
    }
    Ok(())
}
