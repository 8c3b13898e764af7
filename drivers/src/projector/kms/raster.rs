//! Renders a [`ProjectorPattern`] into an XRGB8888 scanout buffer.
//!
//! Levels are linear light, as the scan contract means them: a checker
//! `high` of 0.5 must put half the light of full white on the object.
//! Projectors take gamma-encoded video (like a monitor), so each level is
//! sent as `code = round(255 * level^(1/gamma))` ([`Gamma`], 2.2 by default;
//! measure the projector and set its own). The same grey goes to R, G and B.
//!
//! Speed: a checkerboard has only two distinct rows (even and odd squares
//! down the image), so those two are rendered once with integer arithmetic
//! and copied to every row: 1920x1080 costs about a memcpy of the frame.

use crate::traits::ProjectorPattern;
use matscan_scan::GrayAxis;

/// Bytes per XRGB8888 pixel.
pub const BYTES_PER_PIXEL: usize = 4;

/// The projector's video response: level = (code / 255)^gamma.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gamma(f32);

impl Gamma {
    /// The usual video response (sRGB-like displays and most projectors).
    pub const DEFAULT: Gamma = Gamma(2.2);

    /// `None` unless `gamma` is finite and within 0.1..=10 (1.0: linear).
    pub fn new(gamma: f32) -> Option<Gamma> {
        (gamma.is_finite() && (0.1..=10.0).contains(&gamma)).then_some(Gamma(gamma))
    }

    pub fn get(self) -> f32 {
        self.0
    }

    /// The 8-bit video code that makes the projector emit `level` (linear
    /// light, clamped to 0..=1).
    pub fn code(self, level: f32) -> u8 {
        let l = if level.is_finite() {
            level.clamp(0.0, 1.0) as f64
        } else {
            0.0
        };
        (255.0 * l.powf(1.0 / self.0 as f64)).round() as u8
    }
}

impl Default for Gamma {
    fn default() -> Self {
        Gamma::DEFAULT
    }
}

/// A buffer that cannot hold the image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RasterError {
    #[error("stride {stride} bytes is less than {width} pixels of 4 bytes")]
    Stride { stride: usize, width: u32 },
    #[error("buffer of {got} bytes is too small for {width}x{height} at stride {stride} (needs {needed})")]
    Small {
        got: usize,
        needed: usize,
        width: u32,
        height: u32,
        stride: usize,
    },
}

/// The checker square index along one axis: the contract's
/// `floor((x - phase) / (period / 2))` in integers, `floor(2(x - phase) /
/// period)`. Equal to the contract's f64 value for every u32 input: the f64
/// quotient is within |q|·2⁻⁵³ < 2⁻¹⁹/period of the true one, and a true
/// quotient that is not a whole number is at least 1/period from the next
/// one, so the floor never differs.
pub fn checker_index(x: u32, phase: u32, period: u32) -> i64 {
    (2 * (x as i64 - phase as i64)).div_euclid(period.max(1) as i64)
}

/// Fills the top-left `width` x `height` pixels of `buf` (rows `stride`
/// bytes apart; the padding after each row is left alone) with `pattern`,
/// pixel (u, v) getting `gamma.code(pattern.value_at(u, v))`.
pub fn render(
    pattern: &ProjectorPattern,
    gamma: Gamma,
    width: u32,
    height: u32,
    stride: usize,
    buf: &mut [u8],
) -> Result<(), RasterError> {
    let row_bytes = width as usize * BYTES_PER_PIXEL;
    if stride < row_bytes {
        return Err(RasterError::Stride { stride, width });
    }
    if height == 0 || width == 0 {
        return Ok(());
    }
    let needed = stride
        .checked_mul(height as usize - 1)
        .and_then(|n| n.checked_add(row_bytes))
        .unwrap_or(usize::MAX);
    if buf.len() < needed {
        return Err(RasterError::Small {
            got: buf.len(),
            needed,
            width,
            height,
            stride,
        });
    }
    let pixel = |code: u8| [code, code, code, 0];
    let rows = buf[..needed].chunks_mut(stride);
    match *pattern {
        ProjectorPattern::Black | ProjectorPattern::Uniform(_) => {
            let px = pixel(gamma.code(pattern.value_at(0, 0)));
            let mut template = vec![0u8; row_bytes];
            template
                .chunks_exact_mut(BYTES_PER_PIXEL)
                .for_each(|p| p.copy_from_slice(&px));
            rows.for_each(|r| r[..row_bytes].copy_from_slice(&template));
        }
        ProjectorPattern::Checker(c) => {
            let period = c.period_px.get();
            let high = pixel(gamma.code(c.high.get()));
            let low = pixel(gamma.code(c.low.get()));
            // Row templates for an even and an odd square index down the
            // image: high where the indices' sum is even.
            let mut even = vec![0u8; row_bytes];
            let mut odd = vec![0u8; row_bytes];
            for (u, (e, o)) in even
                .chunks_exact_mut(BYTES_PER_PIXEL)
                .zip(odd.chunks_exact_mut(BYTES_PER_PIXEL))
                .enumerate()
            {
                let i_even = checker_index(u as u32, c.phase_px[0], period) % 2 == 0;
                e.copy_from_slice(if i_even { &high } else { &low });
                o.copy_from_slice(if i_even { &low } else { &high });
            }
            for (v, r) in rows.enumerate() {
                let j_even = checker_index(v as u32, c.phase_px[1], period) % 2 == 0;
                r[..row_bytes].copy_from_slice(if j_even { &even } else { &odd });
            }
        }
        ProjectorPattern::GrayCode(g) => {
            let code = |at: u32| {
                let v = pattern.value_at(
                    at * u32::from(g.axis == GrayAxis::Columns),
                    at * u32::from(g.axis == GrayAxis::Rows),
                );
                pixel(gamma.code(v))
            };
            match g.axis {
                // Stripes across the columns: one row template for all rows.
                GrayAxis::Columns => {
                    let mut template = vec![0u8; row_bytes];
                    for (u, p) in template.chunks_exact_mut(BYTES_PER_PIXEL).enumerate() {
                        p.copy_from_slice(&code(u as u32));
                    }
                    rows.for_each(|r| r[..row_bytes].copy_from_slice(&template));
                }
                GrayAxis::Rows => {
                    for (v, r) in rows.enumerate() {
                        let px = code(v as u32);
                        r[..row_bytes]
                            .chunks_exact_mut(BYTES_PER_PIXEL)
                            .for_each(|p| p.copy_from_slice(&px));
                    }
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traits::{Checker, Level};
    use std::num::NonZeroU32;

    fn checker(period: u32, phase: [u32; 2], low: f32, high: f32) -> ProjectorPattern {
        ProjectorPattern::Checker(Checker {
            period_px: NonZeroU32::new(period).unwrap(),
            phase_px: phase,
            low: Level::new(low).unwrap(),
            high: Level::new(high).unwrap(),
        })
    }

    /// Every pixel's code against the contract's value, and the padding
    /// untouched.
    fn assert_matches_contract(p: &ProjectorPattern, w: u32, h: u32, pad: usize, g: Gamma) {
        let stride = w as usize * 4 + pad;
        let mut buf = vec![0xabu8; stride * h as usize];
        render(p, g, w, h, stride, &mut buf).unwrap();
        let contract = p.to_pattern();
        for v in 0..h {
            for u in 0..w {
                let at = v as usize * stride + u as usize * 4;
                let want = g.code(contract.value_at(u as i64, v as i64) as f32);
                assert_eq!(
                    buf[at..at + 4],
                    [want, want, want, 0],
                    "{p:?} {w}x{h} pixel ({u}, {v})"
                );
            }
            let end = v as usize * stride + w as usize * 4;
            assert!(buf[end..end + pad].iter().all(|&b| b == 0xab), "padding");
        }
    }

    #[test]
    fn gamma_encodes_linear_levels_as_video_codes() {
        let g = Gamma::DEFAULT;
        assert_eq!(g.code(0.0), 0);
        assert_eq!(g.code(1.0), 255);
        // 0.5 linear at gamma 2.2: 255 * 0.5^(1/2.2) = 186.1.
        assert_eq!(g.code(0.5), 186);
        // 0.18 (mid grey): 255 * 0.18^(1/2.2) = 117.1.
        assert_eq!(g.code(0.18), 117);
        let linear = Gamma::new(1.0).unwrap();
        assert_eq!(linear.code(0.5), 128);
        assert_eq!(linear.code(0.2), 51);
        assert_eq!(Gamma::new(0.0), None);
        assert_eq!(Gamma::new(f32::NAN), None);
    }

    #[test]
    fn checker_index_equals_the_contract_floor_everywhere() {
        let contract = |x: u32, p: u32, period: u32| {
            ((x as f64 - p as f64) / (period as f64 / 2.0)).floor() as i64
        };
        for period in (1..=40).chain([63, 64, 1000, 65_535, u32::MAX / 3, u32::MAX]) {
            for phase in [0, 1, 2, 7, 13, 1000, 1_000_003, u32::MAX - 1, u32::MAX] {
                for x in (0..300).chain([4095, 1_000_000, u32::MAX / 2, u32::MAX - 3, u32::MAX]) {
                    assert_eq!(
                        checker_index(x, phase, period),
                        contract(x, phase, period),
                        "x {x} phase {phase} period {period}"
                    );
                }
            }
        }
    }

    #[test]
    fn checkers_match_value_at_for_many_periods_phases_and_odd_sizes() {
        let g = Gamma::DEFAULT;
        for period in [1, 2, 3, 4, 5, 7, 8, 9, 16, 17, 33] {
            for phase in [[0, 0], [1, 0], [0, 3], [5, 11], [40, 7], [1000, 999]] {
                let p = checker(period, phase, 0.1, 0.9);
                assert_matches_contract(&p, 37, 23, 12, g);
            }
        }
        // Odd sizes, no padding, linear response.
        let lin = Gamma::new(1.0).unwrap();
        for (w, h) in [(1, 1), (1, 9), (9, 1), (13, 17), (31, 2)] {
            assert_matches_contract(&checker(6, [2, 1], 0.0, 1.0), w, h, 0, lin);
        }
    }

    #[test]
    fn checker_at_full_hd_has_the_expected_squares() {
        let g = Gamma::new(1.0).unwrap();
        let (w, h) = (1920u32, 1080u32);
        let stride = w as usize * 4;
        let mut buf = vec![0u8; stride * h as usize];
        let p = checker(32, [8, 0], 0.0, 1.0);
        render(&p, g, w, h, stride, &mut buf).unwrap();
        let code = |u: usize, v: usize| buf[v * stride + u * 4];
        // Squares of 16 px shifted 8 right: u 0..8 belongs to square -1.
        assert_eq!(code(0, 0), 0);
        assert_eq!(code(7, 0), 0);
        assert_eq!(code(8, 0), 255);
        assert_eq!(code(23, 0), 255);
        assert_eq!(code(24, 0), 0);
        assert_eq!(code(8, 16), 0);
        assert_eq!(code(1919, 1079), {
            let want = p.value_at(1919, 1079);
            g.code(want)
        });
        // Sampled comparison over the whole frame.
        for v in (0..h).step_by(7) {
            for u in (0..w).step_by(5) {
                assert_eq!(code(u as usize, v as usize), g.code(p.value_at(u, v)));
            }
        }
    }

    #[test]
    fn uniform_and_black_fill_every_pixel_and_leave_padding() {
        let g = Gamma::DEFAULT;
        let half = ProjectorPattern::Uniform(Level::new(0.5).unwrap());
        assert_matches_contract(&half, 11, 5, 8, g);
        assert_matches_contract(&ProjectorPattern::Black, 11, 5, 4, g);
        let mut buf = vec![0u8; 8 * 2];
        render(&half, g, 2, 2, 8, &mut buf).unwrap();
        assert_eq!(buf[..4], [186, 186, 186, 0]);
    }

    #[test]
    fn every_gray_code_image_matches_the_contract() {
        let g = Gamma::DEFAULT;
        let codes = crate::traits::GrayCode::sequence(37, 23);
        // 6 column bits and 5 row bits, each with its inverse.
        assert_eq!(codes.len(), 2 * (6 + 5));
        for code in codes {
            assert_matches_contract(&ProjectorPattern::GrayCode(code), 37, 23, 8, g);
        }
    }

    #[test]
    fn short_stride_and_small_buffer_are_refused() {
        let g = Gamma::DEFAULT;
        let p = ProjectorPattern::Black;
        let mut buf = vec![0u8; 100];
        assert_eq!(
            render(&p, g, 10, 2, 39, &mut buf),
            Err(RasterError::Stride {
                stride: 39,
                width: 10
            })
        );
        // 3 rows of stride 40: 2 * 40 + 40 = 120 > 100.
        let err = render(&p, g, 10, 3, 40, &mut buf).unwrap_err();
        assert_eq!(
            err,
            RasterError::Small {
                got: 100,
                needed: 120,
                width: 10,
                height: 3,
                stride: 40
            }
        );
        // The last row needs no padding: 2 rows of stride 60 fit in 100.
        assert!(render(&p, g, 10, 2, 60, &mut buf).is_ok());
    }
}
