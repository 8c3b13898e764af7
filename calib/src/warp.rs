//! Correspondences between positions from the known geometry, and photos
//! of one position resampled into another position's image.
//!
//! For each object pixel of the reference position, its world point is
//! projected into the other position's camera (distortion included). The
//! match is kept where that camera sees the same point: the projection falls
//! inside the image, the four bilinear taps around it are object pixels of
//! the other position, and the other position's depth map, interpolated
//! bilinearly there, agrees with the point's depth in that camera within a
//! relative tolerance (an occluder in front gives a much smaller depth).
//! This replaces the thesis's 8-bit matchmaps: any image size, any number of
//! positions, sub-pixel coordinates.
//!
//! Taps outside the image are clamped to the edge pixel. Invalid pixels
//! (background, unmatched) hold 0 in every warped map.

use crate::error::CalibError;
use crate::geometry::to_f64;
use crate::maps::PixelMaps;
use crate::par::par_raster;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::Raster;

/// Tolerances of the depth test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WarpOptions {
    /// Allowed |interpolated depth - point depth| as a fraction of the
    /// point's depth in the other camera.
    pub depth_tolerance: f64,
}

impl Default for WarpOptions {
    fn default() -> Self {
        // 1% of the depth: far above the bilinear interpolation error of a
        // smooth surface (second order in the pixel size), far below the
        // depth jump at an occluding contour of any real object.
        Self {
            depth_tolerance: 0.01,
        }
    }
}

/// Where each reference pixel is seen in another position's image.
#[derive(Debug, Clone, PartialEq)]
pub struct Correspondence {
    /// The position whose image the correspondence lives in.
    pub reference: String,
    /// The position whose photos it samples.
    pub other: String,
    /// Continuous pixel coordinates (column, row; pixel centres at +0.5) in
    /// the other image; 0 where not valid.
    pub coords: Raster<[f32; 2]>,
    /// Object pixel of the reference that the other position sees too: the
    /// thesis's "mapped mask".
    pub valid: MaskRaster,
    /// Width and height of the other position's images.
    other_size: (u32, u32),
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Tap {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
    fx: f32,
    fy: f32,
}

impl Tap {
    /// Bilinear taps around continuous coordinates `(u, v)` of an image of
    /// `w` x `h`, clamped to the edge; `None` outside the image.
    fn at(u: f64, v: f64, w: u32, h: u32) -> Option<Tap> {
        if !(u >= 0.0 && v >= 0.0 && u < f64::from(w) && v < f64::from(h)) {
            return None;
        }
        let (x, y) = (u - 0.5, v - 0.5);
        let (xf, yf) = (x.floor(), y.floor());
        let clamp = |i: f64, n: u32| i.clamp(0.0, f64::from(n - 1)) as u32;
        Some(Tap {
            x0: clamp(xf, w),
            y0: clamp(yf, h),
            x1: clamp(xf + 1.0, w),
            y1: clamp(yf + 1.0, h),
            fx: (x - xf) as f32,
            fy: (y - yf) as f32,
        })
    }

    fn corners(&self) -> [(u32, u32, f32); 4] {
        let (fx, fy) = (self.fx, self.fy);
        [
            (self.x0, self.y0, (1.0 - fx) * (1.0 - fy)),
            (self.x1, self.y0, fx * (1.0 - fy)),
            (self.x0, self.y1, (1.0 - fx) * fy),
            (self.x1, self.y1, fx * fy),
        ]
    }

    fn sample_scalar(&self, r: &ScalarRaster) -> f32 {
        self.corners()
            .iter()
            .map(|&(x, y, w)| w * *r.get(x, y))
            .sum()
    }

    fn sample_rgb(&self, r: &RgbRaster) -> [f32; 3] {
        let mut out = [0.0; 3];
        for (x, y, w) in self.corners() {
            let p = r.get(x, y);
            for c in 0..3 {
                out[c] += w * p[c];
            }
        }
        out
    }
}

/// Where the reference position's object pixels appear in `other`.
pub fn correspondence(
    reference: &PixelMaps,
    other: &PixelMaps,
    options: &WarpOptions,
) -> Correspondence {
    let g = &reference.geometry;
    let og = &other.geometry;
    let (ow, oh) = (og.width(), og.height());
    let per_pixel = par_raster(g.width(), g.height(), |x, y| {
        if !*g.mask.get(x, y) {
            return None;
        }
        let p = to_f64(g.position.get(x, y));
        let q = other.camera.project(p)?;
        // Validated on the stored (f32) coordinates so that resampling,
        // which derives its taps from them, uses exactly the checked taps.
        let q = [q.x as f32, q.y as f32];
        let tap = Tap::at(q[0].into(), q[1].into(), ow, oh)?;
        if !tap.corners().iter().all(|&(x, y, _)| *og.mask.get(x, y)) {
            return None;
        }
        let z = other.camera.depth(p);
        let seen = f64::from(tap.sample_scalar(&og.depth));
        ((seen - z).abs() <= options.depth_tolerance * z.abs()).then_some(q)
    });
    Correspondence {
        reference: reference.position.clone(),
        other: other.position.clone(),
        coords: per_pixel.map(|m| m.unwrap_or([0.0, 0.0])),
        valid: per_pixel.map(Option::is_some),
        other_size: (ow, oh),
    }
}

impl Correspondence {
    /// The bilinear taps of a valid pixel.
    fn tap(&self, x: u32, y: u32) -> Option<Tap> {
        if !*self.valid.get(x, y) {
            return None;
        }
        let [u, v] = *self.coords.get(x, y);
        Tap::at(u.into(), v.into(), self.other_size.0, self.other_size.1)
    }

    /// Number of valid (matched) pixels.
    pub fn valid_pixels(&self) -> usize {
        self.valid.data.iter().filter(|&&v| v).count()
    }

    fn check_size(&self, w: u32, h: u32, capture: &str) -> Result<(), CalibError> {
        let (ow, oh) = self.other_size;
        if (w, h) == (ow, oh) {
            return Ok(());
        }
        Err(CalibError::SizeMismatch {
            position: self.other.clone(),
            capture: capture.to_string(),
            expected_w: ow,
            expected_h: oh,
            found_w: w,
            found_h: h,
        })
    }

    /// A photo of the other position resampled (bilinear) into the
    /// reference image; 0 where not valid. `capture` names the photo in
    /// errors.
    pub fn warp_rgb(&self, photo: &RgbRaster, capture: &str) -> Result<RgbRaster, CalibError> {
        self.check_size(photo.width, photo.height, capture)?;
        Ok(par_raster(self.valid.width, self.valid.height, |x, y| {
            self.tap(x, y).map_or([0.0; 3], |t| t.sample_rgb(photo))
        }))
    }

    /// A single-channel map of the other position resampled into the
    /// reference image; 0 where not valid.
    pub fn warp_scalar(&self, map: &ScalarRaster, name: &str) -> Result<ScalarRaster, CalibError> {
        self.check_size(map.width, map.height, name)?;
        Ok(par_raster(self.valid.width, self.valid.height, |x, y| {
            self.tap(x, y).map_or(0.0, |t| t.sample_scalar(map))
        }))
    }
}
