//! Lookups in camera images at continuous pixel coordinates (pixel
//! centres at +0.5, as `matscan_scan::camera` projects).

use matscan_scan::raster::ScalarRaster;

/// An image of one or three channels, row-major, interleaved.
#[derive(Debug, Clone)]
pub(crate) struct Plane {
    pub channels: usize,
    pub data: Vec<f32>,
}

/// The four pixels around a continuous position and their bilinear
/// weights; pixels beyond the border are clamped onto it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Taps {
    pub index: [usize; 4],
    pub weight: [f32; 4],
}

impl Taps {
    pub fn at(x: f64, y: f64, width: usize, height: usize) -> Taps {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
        let clampx = |v: f64| v.clamp(0.0, width as f64 - 1.0) as usize;
        let clampy = |v: f64| v.clamp(0.0, height as f64 - 1.0) as usize;
        let (xa, xb, ya, yb) = (clampx(x0), clampx(x0 + 1.0), clampy(y0), clampy(y0 + 1.0));
        Taps {
            index: [
                ya * width + xa,
                ya * width + xb,
                yb * width + xa,
                yb * width + xb,
            ],
            weight: [
                (1.0 - tx) * (1.0 - ty),
                tx * (1.0 - ty),
                (1.0 - tx) * ty,
                tx * ty,
            ],
        }
    }

    /// Bilinear value of a scalar image.
    pub fn scalar(&self, data: &[f32]) -> f32 {
        (0..4).map(|k| data[self.index[k]] * self.weight[k]).sum()
    }

    /// Bilinear value of `plane` over the taps inside `valid` only,
    /// renormalized, into `out[..channels]`: maps hold 0 outside their
    /// mask, which a plain lookup at the silhouette would mix in. `false`
    /// when no tap is valid.
    pub fn masked(&self, plane: &Plane, valid: &[bool], out: &mut [f32; 3]) -> bool {
        let c = plane.channels;
        let mut sum = [0.0f32; 3];
        let mut wsum = 0.0f32;
        for k in 0..4 {
            let i = self.index[k];
            let w = self.weight[k];
            if !valid[i] || w <= 0.0 {
                continue;
            }
            for (ch, s) in sum.iter_mut().enumerate().take(c) {
                *s += w * plane.data[i * c + ch];
            }
            wsum += w;
        }
        if wsum <= 1e-6 {
            return false;
        }
        for ch in 0..c {
            out[ch] = sum[ch] / wsum;
        }
        true
    }
}

/// A scalar raster's data as a plane of one channel.
pub(crate) fn scalar_plane(r: &ScalarRaster) -> Plane {
    Plane {
        channels: 1,
        data: r.data.clone(),
    }
}
