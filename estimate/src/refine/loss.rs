//! The data term's robustness and the prior.
//!
//! - Noise: each channel's residual is divided by `σ = abs + rel · |observed|`
//!   so that a bright highlight does not outweigh every diffuse view (the
//!   model's errors, interreflections above all, scale with the signal).
//! - [`huber`]: quadratic up to `k` standard units, linear beyond: a view
//!   the model cannot explain (a reflection of the rig, a missed shadow)
//!   pulls with bounded force.
//! - [`view_weight`]: trust in one observation before fitting: 0 for
//!   clipped (saturated) photos and for pixels outside the light or the
//!   view, fading to 0 at grazing light or view and across shadow edges
//!   (where the warped shadow mask is fractional).
//! - [`Prior`]: a Tikhonov term `½ Σ λ_p (x_p - x0_p)²` toward the
//!   network's answer, `λ_p = 1 / σ_p²` in solver space; it decides
//!   wherever the data say little.

use super::model::N;

/// Huber cost of a standardized residual `z` and its IRLS weight.
pub fn huber(z: f64, k: f64) -> (f64, f64) {
    let a = z.abs();
    if !a.is_finite() {
        return (0.0, 0.0);
    }
    if a <= k {
        (0.5 * z * z, 1.0)
    } else {
        (k * (a - 0.5 * k), k / a)
    }
}

/// The per-channel noise scale of an observed value.
pub fn sigma(observed: f32, abs: f64, rel: f64) -> f64 {
    let o = f64::from(observed);
    let o = if o.is_finite() { o.abs() } else { 0.0 };
    (abs + rel * o).max(1e-6)
}

/// What decides whether one view of one pixel can be trusted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewEvidence {
    /// The view sees the pixel (mapped mask).
    pub visible: bool,
    /// Fraction of the pixel the light reaches (the warped shadow mask):
    /// 1 lit, 0 shadow, between on a shadow edge.
    pub lit: f32,
    /// N·L and N·V.
    pub cos_nl: f32,
    pub cos_nv: f32,
    /// Any channel of the lit photo at or above the clipping level.
    pub saturated: bool,
}

/// Below this cosine (light or view) an observation fades out: calibration
/// normals are least accurate and the foreshortened pixel mixes surfaces.
pub const GRAZING_COS: f32 = 0.2;

/// Trust in [0, 1] of an observation; 0 drops it.
pub fn view_weight(e: &ViewEvidence) -> f32 {
    if !e.visible || e.saturated {
        return 0.0;
    }
    let lit = if e.lit.is_finite() { e.lit } else { 0.0 };
    // A fractional shadow mask marks a shadow edge: the light's share of
    // the pixel is unknown there, so only a fully lit pixel counts.
    if lit < 0.999 {
        return 0.0;
    }
    let fade = |c: f32| {
        let c = if c.is_finite() { c } else { 0.0 };
        smoothstep(0.0, GRAZING_COS, c)
    };
    fade(e.cos_nl) * fade(e.cos_nv)
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The Tikhonov prior toward the start (the network's answer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prior {
    /// Mean in solver space.
    pub mean: [f64; N],
    /// Precision `1 / σ²` per parameter; larger holds harder.
    pub precision: [f64; N],
}

impl Prior {
    /// `½ Σ λ (x - x0)²`.
    pub fn cost(&self, x: &[f64; N]) -> f64 {
        (0..N)
            .map(|p| 0.5 * self.precision[p] * (x[p] - self.mean[p]).powi(2))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huber_is_quadratic_inside_and_linear_outside() {
        assert_eq!(huber(1.0, 2.0), (0.5, 1.0));
        let (cost, w) = huber(6.0, 2.0);
        assert!((cost - 10.0).abs() < 1e-12 && (w - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(huber(f64::NAN, 2.0), (0.0, 0.0));
    }

    #[test]
    fn saturated_shadow_edge_and_grazing_views_are_dropped_or_faded() {
        let good = ViewEvidence {
            visible: true,
            lit: 1.0,
            cos_nl: 0.9,
            cos_nv: 0.8,
            saturated: false,
        };
        assert_eq!(view_weight(&good), 1.0);
        assert_eq!(
            view_weight(&ViewEvidence {
                saturated: true,
                ..good
            }),
            0.0
        );
        assert_eq!(view_weight(&ViewEvidence { lit: 0.5, ..good }), 0.0);
        let grazing = view_weight(&ViewEvidence {
            cos_nl: 0.05,
            ..good
        });
        assert!(grazing > 0.0 && grazing < 0.2, "{grazing}");
        assert_eq!(
            view_weight(&ViewEvidence {
                cos_nv: f32::NAN,
                ..good
            }),
            0.0
        );
    }
}
