//! Error metrics of an estimate against ground truth (thesis chapter 4:
//! MAD, MSE and PSNR over the object mask).
//!
//! Values are compared as stored, in [0, 1]; colour maps average over their
//! channels (basecolor over RGB). PSNR uses a peak of 1 and is capped at
//! [`PSNR_CAP`] dB, so an exact match reports a finite number.
//!
//! Out of scope: reading truth files (see `pipeline`).

use serde::{Deserialize, Serialize};

/// The largest PSNR reported, in dB (an MSE of 1e-10 or less).
pub const PSNR_CAP: f64 = 100.0;

/// MAD, MSE and PSNR of one parameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorMetrics {
    /// Mean absolute deviation.
    pub mad: f64,
    /// Mean squared error.
    pub mse: f64,
    /// 10 log10(1 / MSE), capped at [`PSNR_CAP`].
    pub psnr: f64,
    /// Pixels compared.
    pub pixels: usize,
}

/// Compares `estimate` with `truth` (both `channels` values per pixel) where
/// `mask` is set; `None` when no masked pixel has finite values or the sizes
/// disagree.
pub fn error_metrics(
    estimate: &[f32],
    truth: &[f32],
    mask: &[bool],
    channels: usize,
) -> Option<ErrorMetrics> {
    if channels == 0 || estimate.len() != truth.len() || truth.len() != mask.len() * channels {
        return None;
    }
    let (mut abs, mut sq, mut n, mut pixels) = (0.0f64, 0.0f64, 0usize, 0usize);
    for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        let range = i * channels..(i + 1) * channels;
        let pairs = estimate[range.clone()].iter().zip(&truth[range]);
        if pairs.clone().any(|(e, t)| !e.is_finite() || !t.is_finite()) {
            continue;
        }
        for (e, t) in pairs {
            let d = f64::from(*e) - f64::from(*t);
            abs += d.abs();
            sq += d * d;
            n += 1;
        }
        pixels += 1;
    }
    if n == 0 {
        return None;
    }
    let mse = sq / n as f64;
    let psnr = if mse <= 1e-10 {
        PSNR_CAP
    } else {
        (10.0 * (1.0 / mse).log10()).min(PSNR_CAP)
    };
    Some(ErrorMetrics {
        mad: abs / n as f64,
        mse,
        psnr,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_metrics_match_hand_computed_values() {
        // Masked differences: 0.1, -0.3 (the third pixel is outside the mask).
        let m = error_metrics(&[0.5, 0.2, 9.0], &[0.4, 0.5, 0.0], &[true, true, false], 1).unwrap();
        assert!((m.mad - 0.2).abs() < 1e-7, "{m:?}");
        assert!((m.mse - 0.05).abs() < 1e-7, "{m:?}");
        assert!((m.psnr - 10.0 * 20f64.log10()).abs() < 1e-5, "{m:?}");
        assert_eq!(m.pixels, 2);
    }

    #[test]
    fn colour_metrics_average_over_channels() {
        let m = error_metrics(
            &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            &[0.5, 0.0, 0.0, 1.0, 1.0, 1.0],
            &[true, true],
            3,
        )
        .unwrap();
        assert!((m.mad - 0.5 / 6.0).abs() < 1e-9);
        assert!((m.mse - 0.25 / 6.0).abs() < 1e-9);
    }

    #[test]
    fn an_exact_match_has_the_capped_psnr_and_an_empty_mask_none() {
        let m = error_metrics(&[0.3], &[0.3], &[true], 1).unwrap();
        assert_eq!((m.mad, m.mse, m.psnr), (0.0, 0.0, PSNR_CAP));
        assert_eq!(error_metrics(&[0.3], &[0.3], &[false], 1), None);
        assert_eq!(error_metrics(&[0.3, 0.1], &[0.3], &[true], 1), None);
    }
}
