//! Per-parameter confidence of a fit, in [0, 1]: how much the data shrank
//! the prior's uncertainty. `1 - σ²_posterior / σ²_prior`, with the
//! posterior variance the diagonal of `(JᵀWJ + Λ)⁻¹` at the solution (the
//! Laplace approximation) and the prior variance `1 / λ`. 0 means the
//! prior alone decided (no data, or data blind to the parameter, e.g.
//! roughness where no highlight is ever seen); 1 means the data pinned the
//! value. Basecolor's three channels share one map: their mean.

use super::loss::Prior;
use super::model::{METALLIC, N, ROUGHNESS, X};

/// Confidences of one fit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Confidence {
    pub basecolor: f32,
    pub roughness: f32,
    pub metallic: f32,
}

impl Confidence {
    /// From a fit's posterior variance and its prior.
    pub fn of(posterior_variance: &X, prior: &Prior) -> Confidence {
        let c: [f32; N] = std::array::from_fn(|p| {
            let prior_var = 1.0 / prior.precision[p];
            let ratio = posterior_variance[p] / prior_var;
            let c = 1.0 - ratio;
            if c.is_finite() {
                c.clamp(0.0, 1.0) as f32
            } else {
                0.0
            }
        });
        Confidence {
            basecolor: (c[0] + c[1] + c[2]) / 3.0,
            roughness: c[ROUGHNESS],
            metallic: c[METALLIC],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confidence_is_the_shrinkage_of_the_prior_variance() {
        let prior = Prior {
            mean: [0.5; N],
            precision: [4.0; N],
        };
        let untouched = Confidence::of(&[0.25; N], &prior);
        assert_eq!(untouched, Confidence::default());
        let pinned = Confidence::of(&[0.025, 0.025, 0.025, 0.0, 0.125], &prior);
        assert!((pinned.basecolor - 0.9).abs() < 1e-6);
        assert_eq!(pinned.roughness, 1.0);
        assert!((pinned.metallic - 0.5).abs() < 1e-6);
        assert_eq!(Confidence::of(&[f64::NAN; N], &prior).roughness, 0.0);
    }
}
