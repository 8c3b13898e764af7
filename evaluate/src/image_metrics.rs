//! How alike two renders of the same view are: PSNR and SSIM on the
//! luminance of tone-mapped images, over the object's pixels. Used by
//! `matscan render` (estimated against true material) and by
//! `matscan eval --textures`.
//!
//! Tone mapping ([`tone_map`]): each linear channel `x` goes to
//! `srgb(x / (1 + x))` (Reinhard, then the sRGB transfer curve), so every
//! radiance lands in `[0, 1)` and highlights keep their differences instead
//! of clipping; negative or non-finite values count as 0. The written PNGs
//! show exactly this image. Luminance ([`luma`]) is the Rec. 709 weighting
//! `0.2126 R + 0.7152 G + 0.0722 B` of the tone-mapped channels.
//!
//! PSNR: `matscan_estimate::pipeline::metrics::error_metrics` on the luminance over
//! the mask (peak 1, capped at `PSNR_CAP` = 100 dB for identical images);
//! this module does not compute MAD/MSE/PSNR itself.
//!
//! SSIM: Wang, Bovik, Sheikh and Simoncelli (2004), eq. 13, with an 11 x 11
//! Gaussian window of sigma 1.5, K1 = 0.01, K2 = 0.03 and dynamic range
//! L = 1. The local statistics are computed at every pixel; near the border
//! the window is cut to the image and its weights renormalized (instead of
//! dropping a 5-pixel border, which would leave little of a 32-pixel image).
//! The mean SSIM is taken over the mask's pixels. C1, C2 > 0 keep it finite
//! for flat and black images (two black images score exactly 1).
//!
//! Boundaries: pixels in, numbers out; no files.

use matscan_estimate::pipeline::metrics::{error_metrics, ErrorMetrics};
use matscan_scan::image_io::linear_to_srgb;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};

/// Side of the SSIM window, pixels.
pub const SSIM_WINDOW: usize = 11;
/// Standard deviation of the SSIM window's Gaussian, pixels.
pub const SSIM_SIGMA: f64 = 1.5;
pub const SSIM_K1: f64 = 0.01;
pub const SSIM_K2: f64 = 0.03;

/// PSNR and SSIM of one image pair (plus the MAD and MSE behind the PSNR).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    /// dB, capped at `matscan_estimate::pipeline::metrics::PSNR_CAP`.
    pub psnr: f64,
    /// Mean SSIM over the mask, in [-1, 1].
    pub ssim: f64,
    pub mad: f64,
    pub mse: f64,
    /// Pixels compared.
    pub pixels: usize,
}

/// The display value of one linear channel: Reinhard then sRGB, in [0, 1).
pub fn tone_map(x: f32) -> f32 {
    linear_to_srgb(reinhard(x))
}

/// `x / (1 + x)`: the linear half of [`tone_map`] (what an 8-bit sRGB
/// preview writer that applies the sRGB curve itself needs).
pub fn reinhard(x: f32) -> f32 {
    let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
    x / (1.0 + x)
}

/// Rec. 709 relative luminance of the tone-mapped image, in [0, 1) (not
/// the BT.601 luma the networks' inputs use, `matscan_calib::photos::luma`).
pub fn tone_mapped_luminance(image: &RgbRaster) -> ScalarRaster {
    image.map(|p| {
        let [r, g, b] = p.map(tone_map);
        0.2126 * r + 0.7152 * g + 0.0722 * b
    })
}

/// PSNR and SSIM of two linear renders of one view over `mask`; `None`
/// when the sizes differ or the mask is empty.
pub fn compare(a: &RgbRaster, b: &RgbRaster, mask: &MaskRaster) -> Option<Similarity> {
    if !a.same_size(b) || !a.same_size(mask) {
        return None;
    }
    let (la, lb) = (tone_mapped_luminance(a), tone_mapped_luminance(b));
    let ErrorMetrics {
        mad,
        mse,
        psnr,
        pixels,
    } = error_metrics(&la.data, &lb.data, &mask.data, 1)?;
    let ssim = mean_ssim(&la, &lb, mask)?;
    Some(Similarity {
        psnr,
        ssim,
        mad,
        mse,
        pixels,
    })
}

/// Mean of [`ssim_map`] over `mask`; `None` when the sizes differ or the
/// mask is empty.
pub fn mean_ssim(a: &ScalarRaster, b: &ScalarRaster, mask: &MaskRaster) -> Option<f64> {
    if !a.same_size(mask) {
        return None;
    }
    let map = ssim_map(a, b)?;
    let (sum, n) = map
        .iter()
        .zip(&mask.data)
        .filter(|(_, m)| **m)
        .fold((0.0f64, 0usize), |(s, n), (v, _)| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The SSIM index at every pixel of two grey images with values in [0, 1]
/// (row-major); `None` when the sizes differ. Non-finite values count as 0.
pub fn ssim_map(a: &ScalarRaster, b: &ScalarRaster) -> Option<Vec<f64>> {
    if !a.same_size(b) {
        return None;
    }
    let (w, h) = (a.width as usize, a.height as usize);
    let clean = |v: &f32| if v.is_finite() { f64::from(*v) } else { 0.0 };
    let x: Vec<f64> = a.data.iter().map(clean).collect();
    let y: Vec<f64> = b.data.iter().map(clean).collect();
    let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
    let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
    let xy: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a * b).collect();
    let kernel = gaussian_kernel();
    let blur = |v: &[f64]| blur_separable(v, w, h, &kernel);
    let (mx, my) = (blur(&x), blur(&y));
    let (exx, eyy, exy) = (blur(&xx), blur(&yy), blur(&xy));
    let c1 = (SSIM_K1 * 1.0).powi(2);
    let c2 = (SSIM_K2 * 1.0).powi(2);
    Some(
        (0..w * h)
            .map(|i| {
                let (ux, uy) = (mx[i], my[i]);
                // Rounding can leave a variance a hair below 0 on flat
                // patches; the true value is never negative.
                let vx = (exx[i] - ux * ux).max(0.0);
                let vy = (eyy[i] - uy * uy).max(0.0);
                let cov = exy[i] - ux * uy;
                ((2.0 * ux * uy + c1) * (2.0 * cov + c2))
                    / ((ux * ux + uy * uy + c1) * (vx + vy + c2))
            })
            .collect(),
    )
}

/// The normalized 1-D Gaussian of the SSIM window.
fn gaussian_kernel() -> [f64; SSIM_WINDOW] {
    let r = (SSIM_WINDOW / 2) as f64;
    let mut k = [0.0; SSIM_WINDOW];
    for (i, v) in k.iter_mut().enumerate() {
        let d = i as f64 - r;
        *v = (-d * d / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp();
    }
    let sum: f64 = k.iter().sum();
    k.map(|v| v / sum)
}

/// Gaussian-weighted local mean at every pixel, the window cut to the image
/// and renormalized (rows, then columns: the cut window is a rectangle, so
/// the two renormalized passes equal one renormalized 2-D window).
fn blur_separable(v: &[f64], w: usize, h: usize, kernel: &[f64]) -> Vec<f64> {
    let r = kernel.len() / 2;
    let pass = |src: &[f64], along_x: bool| -> Vec<f64> {
        let mut out = vec![0.0; src.len()];
        for yy in 0..h {
            for xx in 0..w {
                let (pos, len) = if along_x { (xx, w) } else { (yy, h) };
                let lo = pos.saturating_sub(r);
                let hi = (pos + r).min(len - 1);
                let (mut sum, mut weight) = (0.0, 0.0);
                for p in lo..=hi {
                    let k = kernel[p + r - pos];
                    let idx = if along_x { yy * w + p } else { p * w + xx };
                    sum += k * src[idx];
                    weight += k;
                }
                out[yy * w + xx] = sum / weight;
            }
        }
        out
    };
    pass(&pass(v, true), false)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> ScalarRaster {
        ScalarRaster::from_fn(w, h, |x, y| {
            0.5 + 0.4 * ((x as f32 * 0.7).sin() * (y as f32 * 0.45).cos())
        })
    }

    fn all(w: u32, h: u32) -> MaskRaster {
        MaskRaster::filled(w, h, true)
    }

    #[test]
    fn identical_images_have_ssim_one() {
        let a = gradient(32, 24);
        let s = mean_ssim(&a, &a, &all(32, 24)).unwrap();
        assert!((s - 1.0).abs() < 1e-12, "{s}");
    }

    #[test]
    fn an_image_against_its_negative_scores_below_one_half() {
        let a = gradient(32, 32);
        let neg = a.map(|v| 1.0 - v);
        let s = mean_ssim(&a, &neg, &all(32, 32)).unwrap();
        assert!(s < 0.5, "{s}");
        // Structure is inverted, so the index is strongly negative.
        assert!(s < -0.5, "{s}");
    }

    #[test]
    fn black_images_are_identical_and_finite() {
        let black = RgbRaster::filled(16, 16, [0.0; 3]);
        let s = compare(&black, &black, &all(16, 16)).unwrap();
        assert_eq!(s.ssim, 1.0);
        assert_eq!(s.psnr, matscan_estimate::pipeline::metrics::PSNR_CAP);
        // Black against white: finite, low.
        let white = RgbRaster::filled(16, 16, [1e6; 3]);
        let s = compare(&black, &white, &all(16, 16)).unwrap();
        assert!(s.ssim.is_finite() && s.psnr.is_finite(), "{s:?}");
        assert!(s.ssim < 0.01 && s.psnr < 1.0, "{s:?}");
    }

    #[test]
    fn non_finite_pixels_count_as_black() {
        let mut a = RgbRaster::filled(8, 8, [0.0; 3]);
        a.data[5] = [f32::NAN, f32::INFINITY, -3.0];
        let black = RgbRaster::filled(8, 8, [0.0; 3]);
        let s = compare(&a, &black, &all(8, 8)).unwrap();
        assert_eq!(s.ssim, 1.0, "{s:?}");
    }

    #[test]
    fn ssim_matches_the_closed_form_on_constant_images() {
        // Constant images: sigma = 0, so SSIM = (2 m1 m2 + C1) / (m1^2 + m2^2 + C1).
        let (m1, m2) = (0.3f64, 0.6f64);
        let a = ScalarRaster::filled(12, 12, m1 as f32);
        let b = ScalarRaster::filled(12, 12, m2 as f32);
        let c1 = 0.0001;
        let expected = (2.0 * m1 * m2 + c1) / (m1 * m1 + m2 * m2 + c1);
        let s = mean_ssim(&a, &b, &all(12, 12)).unwrap();
        assert!((s - expected).abs() < 1e-6, "{s} vs {expected}");
    }

    #[test]
    fn noise_lowers_ssim_more_than_a_small_brightness_shift() {
        let a = gradient(32, 32);
        let shifted = a.map(|v| v + 0.02);
        let noisy = ScalarRaster::from_fn(32, 32, |x, y| {
            a.get(x, y) + if (x * 7 + y * 13) % 3 == 0 { 0.2 } else { -0.1 }
        });
        let m = all(32, 32);
        let s_shift = mean_ssim(&a, &shifted, &m).unwrap();
        let s_noise = mean_ssim(&a, &noisy, &m).unwrap();
        assert!(s_shift > 0.98, "{s_shift}");
        assert!(s_noise < s_shift - 0.2, "{s_noise} vs {s_shift}");
    }

    #[test]
    fn only_masked_pixels_count() {
        let a = RgbRaster::filled(16, 16, [0.5; 3]);
        let mut b = a.clone();
        // Differ only in the right half; the mask covers the left quarter,
        // more than a window away from the difference.
        for y in 0..16 {
            for x in 8..16 {
                *b.get_mut(x, y) = [0.0; 3];
            }
        }
        let mask = MaskRaster::from_fn(16, 16, |x, _| x < 2);
        let s = compare(&a, &b, &mask).unwrap();
        assert_eq!(s.psnr, matscan_estimate::pipeline::metrics::PSNR_CAP);
        assert!(s.ssim > 0.99, "{s:?}");
        assert_eq!(s.pixels, 32);
        assert!(compare(&a, &b, &MaskRaster::filled(16, 16, false)).is_none());
        assert!(compare(&a, &RgbRaster::filled(8, 8, [0.0; 3]), &mask).is_none());
    }

    #[test]
    fn tone_map_is_bounded_monotone_and_nan_free() {
        assert_eq!(tone_map(0.0), 0.0);
        assert_eq!(tone_map(f32::NAN), 0.0);
        assert_eq!(tone_map(-1.0), 0.0);
        assert!(tone_map(f32::INFINITY) == 0.0);
        let mut last = 0.0;
        for i in 1..100 {
            let v = tone_map(i as f32 * 0.37);
            assert!(v > last && v < 1.0, "{i}: {v}");
            last = v;
        }
        // White diffuse lit to radiance 1 shows as sRGB(0.5).
        assert!((tone_map(1.0) - 0.7354).abs() < 1e-3);
    }
}
