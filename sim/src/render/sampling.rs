//! Random numbers and the sampling building blocks of the path tracer:
//! per-pixel seeded generators, hemisphere and sphere warps, orthonormal
//! frames, piecewise-constant 1D/2D distributions and the power heuristic.
//!
//! Boundaries: pure math, no scene knowledge.

use glam::{Vec2, Vec3};
use rand_pcg::Pcg32;
use std::f32::consts::PI;

/// SplitMix64 finalizer: decorrelates nearby integers (pixel indices, seeds)
/// before they seed a generator.
pub fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The generator of one pixel of one render pass. Seeded only from
/// (seed, position, pass, pixel), so a pixel's samples do not depend on the
/// order in which tiles or threads reach it.
pub struct PixelRng(Pcg32);

impl PixelRng {
    pub fn new(seed: u64, position: u64, pass: u64, pixel: u64) -> Self {
        let state = mix64(seed ^ mix64(position.wrapping_add(mix64(pass))));
        let stream = mix64(pixel ^ state.rotate_left(17));
        PixelRng(Pcg32::new(state, stream))
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        use rand::RngCore;
        (self.0.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    #[inline]
    pub fn next2(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }

    #[inline]
    pub fn next3(&mut self) -> [f32; 3] {
        [self.next_f32(), self.next_f32(), self.next_f32()]
    }
}

/// Cosine-weighted direction about +Z; pdf = cos / pi.
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let z = (1.0 - u[0]).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction on the unit sphere; pdf = 1 / (4 pi).
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Power heuristic (beta = 2) weight of a strategy with pdf `a` against one
/// with pdf `b`; 0 when both are 0, never NaN.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    let s = a2 + b2;
    if s > 0.0 && s.is_finite() {
        a2 / s
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// An orthonormal frame with `n` as its Z axis.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Duff et al. 2017 branchless basis; `n` must be unit length.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Frame {
            t: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            b: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// A piecewise-constant distribution over [0, 1) with `func.len()` cells.
#[derive(Debug, Clone)]
pub struct Distribution1D {
    func: Vec<f32>,
    /// `cdf[i]` = mass of cells before i; `cdf[n]` = 1.
    cdf: Vec<f32>,
    /// Integral of `func` over [0, 1).
    integral: f32,
}

impl Distribution1D {
    /// Negative and non-finite weights count as 0; all-zero weights give the
    /// uniform distribution, so sampling is always defined.
    pub fn new(weights: &[f32]) -> Self {
        let n = weights.len().max(1);
        let mut func: Vec<f32> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        if func.is_empty() {
            func.push(1.0);
        }
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f32);
        let mut acc = 0.0f64;
        for &f in &func {
            acc += f as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let integral = acc as f32;
        if integral > 0.0 && integral.is_finite() {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        } else {
            func.iter_mut().for_each(|f| *f = 1.0);
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let integral = if integral > 0.0 && integral.is_finite() {
            integral
        } else {
            1.0
        };
        Distribution1D {
            func,
            cdf,
            integral,
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// A point in [0, 1), its density, and its cell.
    pub fn sample(&self, u: f32) -> (f32, f32, usize) {
        let n = self.func.len();
        // Largest i with cdf[i] <= u, kept inside [0, n - 1].
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .saturating_sub(1)
            .min(n - 1);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let x = ((i as f32 + du) / n as f32).min(1.0 - f32::EPSILON);
        (x, self.func[i] / self.integral, i)
    }

    /// Density at `x` in [0, 1).
    pub fn pdf(&self, x: f32) -> f32 {
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.func[i] / self.integral
    }

    /// Density of cell `i` (piecewise constant).
    pub fn cell_pdf(&self, i: usize) -> f32 {
        self.func.get(i).map_or(0.0, |f| f / self.integral)
    }
}

/// A piecewise-constant distribution over [0, 1)^2 given row-major weights
/// (`width` columns per row): a marginal over rows, a conditional per row.
#[derive(Debug, Clone)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let width = width.max(1);
        let height = height.max(1);
        let rows: Vec<Distribution1D> = (0..height)
            .map(|y| {
                let start = (y * width).min(weights.len());
                let end = ((y + 1) * width).min(weights.len());
                Distribution1D::new(&weights[start..end])
            })
            .collect();
        // Rows with all-zero weight were made uniform for sampling; their
        // marginal mass must stay 0, so it comes from the raw weights.
        let row_mass: Vec<f32> = (0..height)
            .map(|y| {
                let start = (y * width).min(weights.len());
                let end = ((y + 1) * width).min(weights.len());
                weights[start..end]
                    .iter()
                    .filter(|w| w.is_finite() && **w > 0.0)
                    .sum::<f32>()
                    / width as f32
            })
            .collect();
        Distribution2D {
            rows,
            marginal: Distribution1D::new(&row_mass),
        }
    }

    /// A point (x, y) in [0, 1)^2 and its density.
    pub fn sample(&self, u: [f32; 2]) -> (Vec2, f32) {
        let (y, pdf_y, row) = self.marginal.sample(u[1]);
        let (x, pdf_x, _) = self.rows[row].sample(u[0]);
        (Vec2::new(x, y), pdf_x * pdf_y)
    }

    pub fn pdf(&self, p: Vec2) -> f32 {
        let h = self.rows.len();
        let row = ((p.y * h as f32).max(0.0) as usize).min(h - 1);
        self.marginal.cell_pdf(row) * self.rows[row].pdf(p.x.clamp(0.0, 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_1d_samples_cells_in_proportion_to_weight() {
        let d = Distribution1D::new(&[1.0, 3.0, 0.0, 4.0]);
        let mut counts = [0usize; 4];
        let n = 8000;
        for k in 0..n {
            let (x, pdf, i) = d.sample((k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&x));
            assert!((pdf - d.pdf(x)).abs() < 1e-5);
            counts[i] += 1;
        }
        assert_eq!(counts[2], 0);
        assert!((counts[1] as f32 / n as f32 - 3.0 / 8.0).abs() < 0.01);
        assert!((counts[3] as f32 / n as f32 - 4.0 / 8.0).abs() < 0.01);
    }

    #[test]
    fn distribution_2d_density_integrates_to_one() {
        let w: Vec<f32> = (0..12).map(|i| (i % 5) as f32).collect();
        let d = Distribution2D::new(&w, 4, 3);
        let n = 64;
        let mut sum = 0.0;
        for y in 0..n {
            for x in 0..n {
                let p = Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32);
                sum += d.pdf(p) / (n * n) as f32;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        let (p, pdf) = d.sample([0.3, 0.7]);
        assert!((pdf - d.pdf(p)).abs() < 1e-4);
    }

    #[test]
    fn all_zero_weights_give_a_uniform_distribution() {
        let d = Distribution1D::new(&[0.0, f32::NAN, -1.0]);
        let (x, pdf, _) = d.sample(0.5);
        assert!(x.is_finite() && (pdf - 1.0).abs() < 1e-6);
    }

    #[test]
    fn frames_are_orthonormal_for_any_normal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, -0.8).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!(f.t.dot(f.b).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5 && (f.b.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn pixel_rng_depends_only_on_its_key() {
        let mut a = PixelRng::new(7, 1, 2, 99);
        let mut b = PixelRng::new(7, 1, 2, 99);
        let mut c = PixelRng::new(7, 1, 2, 100);
        let (xa, xb, xc) = (a.next_f32(), b.next_f32(), c.next_f32());
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
    }

    #[test]
    fn power_heuristic_is_finite_for_degenerate_pdfs() {
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-6);
    }
}
