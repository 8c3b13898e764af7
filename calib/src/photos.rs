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

/// Pixels that must share a channel's largest value for the photo to count
/// as clipped there. A saturated sensor piles a highlight up at one value;
/// an unclipped (HDR) photo reaches its largest value at a pixel or two,
/// even in half floats.
pub const CLIP_PILE_UP: usize = 4;

/// The value at which `photo` clipped, per channel, read from the photo
/// itself over `mask` (every pixel where `None` or of another size): the
/// channel's largest finite value where at least [`CLIP_PILE_UP`] pixels
/// sit at it (within half-float rounding), else `None` (nothing clipped).
///
/// Why the photo and not a fixed level: a camera's raw range ends at 1 in
/// its units, but an HDR merge or a renderer's EXR has no end, and a fixed
/// level would throw the brightest, most telling part of a highlight away.
pub fn clip_levels(photo: &RgbRaster, mask: Option<&MaskRaster>) -> [Option<f32>; 3] {
    let mask = mask.filter(|m| m.data.len() == photo.data.len());
    let inside = |i: usize| mask.is_none_or(|m| m.data[i]);
    std::array::from_fn(|c| {
        let values = || {
            photo
                .data
                .iter()
                .enumerate()
                .filter(|&(i, _)| inside(i))
                .map(move |(_, px)| px[c])
                .filter(|v| v.is_finite())
        };
        let top = values().fold(f32::NEG_INFINITY, f32::max);
        // `top` is finite or -inf (only finite values fold in).
        if top <= 0.0 {
            return None;
        }
        // Half floats step by 2^-10 relative: a tie within a tenth of
        // that is the same stored value.
        let floor = top * (1.0 - 1e-4);
        (values().filter(|&v| v >= floor).count() >= CLIP_PILE_UP).then_some(top)
    })
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

/// The `q` quantile (0..=1, nearest rank) of the finite `values` (which
/// it drops the others from and reorders); `None` when there are none.
pub fn quantile(values: &mut Vec<f32>, q: f64) -> Option<f32> {
    values.retain(|v| v.is_finite());
    if values.is_empty() {
        return None;
    }
    let rank = ((values.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
    let (_, v, _) = values.select_nth_unstable_by(rank, f32::total_cmp);
    Some(*v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(n: u32, top: f32) -> RgbRaster {
        RgbRaster {
            width: n,
            height: 1,
            data: (0..n)
                .map(|i| [top * (i + 1) as f32 / n as f32; 3])
                .collect(),
        }
    }

    #[test]
    fn a_highlight_piled_up_at_the_sensor_limit_reads_as_clipped_there() {
        let mut photo = ramp(100, 3.0);
        for px in &mut photo.data {
            px[1] = px[1].min(1.0);
        }
        let levels = clip_levels(&photo, None);
        assert_eq!(levels[0], None);
        assert_eq!(levels[1], Some(1.0));
        assert_eq!(levels[2], None);
    }

    #[test]
    fn an_unclipped_hdr_photo_reads_as_unclipped_even_with_a_tie_at_its_top() {
        let mut photo = ramp(100, 190.0);
        photo.data[98] = photo.data[99];
        photo.data[97] = photo.data[99];
        assert_eq!(clip_levels(&photo, None), [None; 3]);
    }

    #[test]
    fn clipping_outside_the_mask_does_not_count_and_black_or_nan_photos_are_unclipped() {
        let mut photo = ramp(100, 2.0);
        for px in &mut photo.data[..10] {
            *px = [5.0; 3];
        }
        let mask = MaskRaster {
            width: 100,
            height: 1,
            data: (0..100).map(|i| i >= 10).collect(),
        };
        assert_eq!(clip_levels(&photo, None), [Some(5.0); 3]);
        assert_eq!(clip_levels(&photo, Some(&mask)), [None; 3]);
        let black = RgbRaster::filled(8, 8, [0.0; 3]);
        assert_eq!(clip_levels(&black, None), [None; 3]);
        let nan = RgbRaster::filled(8, 8, [f32::NAN; 3]);
        assert_eq!(clip_levels(&nan, None), [None; 3]);
    }
}
