//! The camera's response curve: from 8-bit code values to linear values.
//!
//! Webcams encode with the sRGB transfer function (or close to it); a
//! measured curve (a radiometric calibration, one value per code) replaces
//! it where known. Boundaries: the curve only; pixel layouts are
//! `super::formats`'.

use matscan_scan::image_io::srgb_to_linear;

/// How code values map to linear light, `0..=1`.
#[derive(Debug, Clone, PartialEq)]
pub enum Response {
    /// The sRGB transfer function (IEC 61966-2-1).
    Srgb,
    /// Code / 255: the camera is already linear.
    Linear,
    /// `(code / 255) ^ gamma`.
    Gamma(f32),
    /// A measured curve: the linear value of each code 0..=255.
    Table(Box<[f32; 256]>),
}

impl Response {
    /// A measured curve; `None` unless it has 256 finite, non-decreasing,
    /// non-negative values.
    pub fn table(values: &[f32]) -> Option<Response> {
        let table: [f32; 256] = values.try_into().ok()?;
        let ok = table.iter().all(|v| v.is_finite() && *v >= 0.0)
            && table.windows(2).all(|w| w[0] <= w[1]);
        ok.then(|| Response::Table(Box::new(table)))
    }

    /// The lookup table of this curve, one linear value per code.
    pub fn lut(&self) -> [f32; 256] {
        let mut lut = [0.0f32; 256];
        for (code, out) in lut.iter_mut().enumerate() {
            let x = code as f32 / 255.0;
            *out = match self {
                Response::Srgb => srgb_to_linear(x),
                Response::Linear => x,
                Response::Gamma(g) => {
                    let g = if g.is_finite() && *g > 0.0 { *g } else { 1.0 };
                    x.powf(g)
                }
                Response::Table(t) => t[code],
            };
        }
        lut
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_lut_hits_the_standard_points() {
        let lut = Response::Srgb.lut();
        assert_eq!(lut[0], 0.0);
        assert!((lut[255] - 1.0).abs() < 1e-6);
        // sRGB 128 is 0.2158 linear.
        assert!((lut[128] - 0.2158605).abs() < 1e-5, "{}", lut[128]);
        assert!(lut.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn gamma_and_table_curves() {
        let lut = Response::Gamma(2.0).lut();
        assert!((lut[51] - 0.04).abs() < 1e-6);
        let ramp: Vec<f32> = (0..256).map(|i| i as f32 * 2.0).collect();
        assert_eq!(Response::table(&ramp).unwrap().lut()[10], 20.0);
        let mut bad = ramp.clone();
        bad[3] = f32::NAN;
        assert!(Response::table(&bad).is_none());
        assert!(Response::table(&ramp[..100]).is_none());
        assert!(Response::Gamma(f32::NAN)
            .lut()
            .iter()
            .all(|v| v.is_finite()));
    }
}
