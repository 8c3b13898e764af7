//! Where calibration gets the photos and masks of a scan from, and the few
//! pixel operations shared by the photo-based modules (luma, exposure
//! scaling, quantiles).
//!
//! [`PhotoSource`] keeps calibration independent of files: the bundle
//! reader implements it for folders on disk, [`MemoryScan`] for photos held
//! in memory (tests, the simulator, a live capture).

use crate::error::CalibError;
use matscan_scan::raster::{MaskRaster, RgbRaster};
use matscan_scan::{Bundle, Capture, Intrinsics, Position};
use std::collections::BTreeMap;

/// Photos and masks of a scan, by position and capture.
pub trait PhotoSource {
    /// The linear RGB photo of `capture` at `position`, as stored (still
    /// scaled by the capture's exposure).
    fn photo(&self, position: &Position, capture: &Capture) -> Result<RgbRaster, CalibError>;
    /// The object mask of `position`, where the scan has one.
    fn object_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError>;
    /// The white-reference mask of `position`, where the scan has one.
    fn white_reference_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError>;
}

/// A scan's photos held in memory.
#[derive(Debug, Clone, Default)]
pub struct MemoryScan {
    /// Keyed by (position name, capture name).
    pub photos: BTreeMap<(String, String), RgbRaster>,
    pub object_masks: BTreeMap<String, MaskRaster>,
    pub white_reference_masks: BTreeMap<String, MaskRaster>,
}

impl MemoryScan {
    pub fn insert_photo(&mut self, position: &str, capture: &str, photo: RgbRaster) {
        self.photos
            .insert((position.to_string(), capture.to_string()), photo);
    }
}

impl PhotoSource for MemoryScan {
    fn photo(&self, position: &Position, capture: &Capture) -> Result<RgbRaster, CalibError> {
        self.photos
            .get(&(position.name.clone(), capture.name.clone()))
            .cloned()
            .ok_or_else(|| CalibError::MissingPhoto {
                position: position.name.clone(),
                capture: capture.name.clone(),
            })
    }

    fn object_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError> {
        Ok(self.object_masks.get(&position.name).cloned())
    }

    fn white_reference_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError> {
        Ok(self.white_reference_masks.get(&position.name).cloned())
    }
}

impl PhotoSource for Bundle {
    fn photo(&self, position: &Position, capture: &Capture) -> Result<RgbRaster, CalibError> {
        Ok(self.read_photo(&position.name, &capture.name)?)
    }

    fn object_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError> {
        Ok(self.read_mask(&position.name)?)
    }

    fn white_reference_mask(&self, position: &Position) -> Result<Option<MaskRaster>, CalibError> {
        Ok(self.read_white_reference_mask(&position.name)?)
    }
}

/// Loads a photo and checks it has the camera's size.
pub(crate) fn load(
    source: &dyn PhotoSource,
    camera: &Intrinsics,
    position: &Position,
    capture: &Capture,
) -> Result<RgbRaster, CalibError> {
    let photo = source.photo(position, capture)?;
    check_size(camera, position, &capture.name, photo.width, photo.height)?;
    Ok(photo)
}

pub(crate) fn check_size(
    camera: &Intrinsics,
    position: &Position,
    what: &str,
    w: u32,
    h: u32,
) -> Result<(), CalibError> {
    if (w, h) == (camera.width, camera.height) {
        return Ok(());
    }
    Err(CalibError::SizeMismatch {
        position: position.name.clone(),
        capture: what.to_string(),
        expected_w: camera.width,
        expected_h: camera.height,
        found_w: w,
        found_h: h,
    })
}

/// BT.601 luma of linear RGB (the Y of [`crate::white_reference::ycbcr`]).
pub fn luma(c: [f32; 3]) -> f32 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

/// `lit - ambient`, with the ambient photo rescaled to the lit capture's
/// exposure (photos are radiance times exposure), in the lit photo's units.
pub(crate) fn difference(
    lit: &RgbRaster,
    lit_exposure: f64,
    ambient: &RgbRaster,
    ambient_exposure: f64,
) -> RgbRaster {
    let k = if ambient_exposure > 0.0 && lit_exposure.is_finite() {
        (lit_exposure / ambient_exposure) as f32
    } else {
        1.0
    };
    let mut out = lit.clone();
    for (o, a) in out.data.iter_mut().zip(&ambient.data) {
        for c in 0..3 {
            o[c] -= k * a[c];
        }
    }
    out
}

/// The `q` quantile (0..=1, nearest rank) of the finite `values`; `None`
/// when there are none.
pub(crate) fn quantile(values: &mut Vec<f32>, q: f64) -> Option<f32> {
    values.retain(|v| v.is_finite());
    if values.is_empty() {
        return None;
    }
    let rank = ((values.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, v, _) = values.select_nth_unstable_by(rank, f32::total_cmp);
    Some(*v)
}
