//! Basecolor per pixel for a fixed (roughness, metallic).
//!
//! With roughness, metallic and transmission fixed, the principled BSDF of
//! one channel depends on that channel's basecolor alone: the diffuse lobe
//! scales with it, the metallic Fresnel's F0 is it, and nothing else reads
//! it (no specular or sheen tint). The dependence is affine except for the
//! multiple-scattering compensation of rough metal, which grows with the
//! square of F0; so each observation's prediction is taken as the parabola
//! `a + b·x + q·x²` through the BSDF at basecolor 0, ½ and 1 (exact where
//! the BSDF is affine), and basecolor per channel is solved by least
//! squares: the secant solution first, then Gauss–Newton steps, clamped to
//! [0, 1].
//!
//! Robust and censored: reweighting passes make the loss the solver's
//! Huber loss, so a view the model cannot explain pulls with bounded force;
//! a clipped (saturated) channel is a lower bound, not a value: it counts
//! only while the prediction stays below it, so a highlight the photo
//! clipped still tells a glossy lobe from a broad one.

use crate::refine::loss::{huber, sigma};
use crate::refine::model::{bsdf, predict, Fixed, Observation, Params};

/// How the fit weighs residuals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// Absolute noise per channel, photo units.
    pub abs: f64,
    /// Relative noise per channel.
    pub rel: f64,
    /// Huber threshold in standard units.
    pub huber_k: f64,
}

impl Default for Noise {
    fn default() -> Self {
        let s = crate::refine::Settings::default();
        Noise {
            abs: s.noise_abs,
            rel: s.noise_rel,
            huber_k: s.huber_k,
        }
    }
}

/// One view of one pixel for the fit: the refinement's observation, and
/// per channel whether the photo clipped there (then `observed` is the
/// lowest value the unclipped photo could have had).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub observation: Observation,
    pub clipped: [bool; 3],
    /// The pixel's footprint as a spread of microfacet slopes: the GGX
    /// `α²` the pixel's own change of half-vector across it adds (see
    /// [`footprint_alpha2`]). A photo pixel averages a glossy lobe over
    /// its footprint; a point-sampled model would predict a needle there.
    pub footprint: f32,
    /// Per channel, the part of `observed` that is global light (light
    /// that reached the point by another surface or from inside the
    /// object; see `fit::separation`), 0 where unmeasured.
    pub global: [f32; 3],
}

impl Sample {
    /// An unclipped observation of a point (no footprint, no global light).
    pub fn exact(observation: Observation) -> Sample {
        Sample {
            observation,
            clipped: [false; 3],
            footprint: 0.0,
            global: [0.0; 3],
        }
    }

    /// The same view with its global light taken out: what the surface
    /// reflected of the light directly.
    pub fn direct(&self) -> Sample {
        let mut s = *self;
        for c in 0..3 {
            s.observation.observed[c] = (s.observation.observed[c] - s.global[c]).max(0.0);
        }
        s.global = [0.0; 3];
        s
    }
}

/// The `α²` a footprint adds when the half-vector's angle to the normal
/// changes by `dtheta` radians from one pixel to the next: the footprint
/// averages slopes over about that width, a uniform spread of variance
/// `dtheta² / 12`, and GGX's `α²` is about twice a slope variance.
pub fn footprint_alpha2(dtheta: f32) -> f32 {
    if dtheta.is_finite() {
        (dtheta * dtheta / 6.0).min(1.0)
    } else {
        0.0
    }
}

/// The roughness whose `α²` is `roughness⁴ + extra`.
fn widened(roughness: f32, extra: f32) -> f32 {
    let a2 = roughness.powi(4) + extra.max(0.0);
    a2.sqrt().sqrt().min(1.0)
}

/// One observation's prediction as a function of basecolor, per channel:
/// `a + b·x + q·x²`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub q: [f64; 3],
}

impl Response {
    fn at(&self, c: usize, x: f64) -> f64 {
        self.a[c] + x * (self.b[c] + x * self.q[c])
    }

    fn slope(&self, c: usize, x: f64) -> f64 {
        self.b[c] + 2.0 * x * self.q[c]
    }
}

/// The responses of `samples` for `roughness`, `metallic` and the fixed
/// transmission.
pub fn responses(
    samples: &[Sample],
    roughness: f32,
    metallic: f32,
    fixed: &Fixed,
) -> Vec<Response> {
    let at = |roughness: f32, v: f32| {
        let x = Params {
            basecolor: [v; 3],
            roughness,
            metallic,
        }
        .to_x();
        bsdf(&x, fixed)
    };
    let (black, half, white) = (at(roughness, 0.0), at(roughness, 0.5), at(roughness, 1.0));
    samples
        .iter()
        .map(|s| {
            let o = &s.observation;
            // Only a footprint wider than a tenth of the lobe changes it.
            let (f0, fh, f1) = if s.footprint > 0.1 * roughness.powi(4) {
                let r = widened(roughness, s.footprint);
                (
                    predict(&at(r, 0.0), o),
                    predict(&at(r, 0.5), o),
                    predict(&at(r, 1.0), o),
                )
            } else {
                (predict(&black, o), predict(&half, o), predict(&white, o))
            };
            let q: [f64; 3] = std::array::from_fn(|c| 2.0 * f1[c] + 2.0 * f0[c] - 4.0 * fh[c]);
            Response {
                a: f0,
                b: std::array::from_fn(|c| f1[c] - f0[c] - q[c]),
                q,
            }
        })
        .collect()
}

/// A fit: the basecolor and its robust cost (0 when no observation
/// counts).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearFit {
    pub basecolor: [f32; 3],
    pub cost: f64,
    /// Summed observation weight that entered (0: the photos say nothing).
    pub weight: f64,
    /// Per channel, how strongly the photos pin basecolor: the
    /// Gauss–Newton information `Σ w J² / σ²` at the answer (0: not at
    /// all), the prior's excluded.
    pub information: [f64; 3],
}

/// A pull toward a material's basecolor: `strength · (x - mean)²` in the
/// cost's standard units, so it decides only where the photos' own
/// information is far below `strength`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pull {
    pub mean: [f32; 3],
    pub strength: f64,
}

/// Passes after the first solve: each reweights (Huber), updates which
/// clipped channels bind, and takes a Gauss–Newton step.
const PASSES: usize = 3;

/// The best basecolor per channel for `samples` predicted by `responses`.
pub fn solve(samples: &[Sample], responses: &[Response], noise: &Noise) -> LinearFit {
    solve_pulled(samples, responses, noise, None)
}

/// [`solve`] with an optional pull toward a material's basecolor.
pub fn solve_pulled(
    samples: &[Sample],
    responses: &[Response],
    noise: &Noise,
    pull: Option<Pull>,
) -> LinearFit {
    let mut basecolor = [0.5f64; 3];
    let mut information = [0.0f64; 3];
    let mut cost = 0.0;
    let total_weight: f64 = samples
        .iter()
        .map(|s| f64::from(s.observation.weight.max(0.0)))
        .sum();
    let mut robust = vec![1.0f64; samples.len()];
    for c in 0..3 {
        robust.iter_mut().for_each(|r| *r = 1.0);
        // The secant solution over the unclipped channels.
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (s, p) in samples.iter().zip(responses) {
            let k = scale(s, c, noise);
            if k <= 0.0 || s.clipped[c] {
                continue;
            }
            let slope = p.b[c] + p.q[c];
            num += k * (f64::from(s.observation.observed[c]) - p.a[c]) * slope;
            den += k * slope * slope;
        }
        let (mean, strength) = match pull {
            Some(p) if p.strength > 0.0 => (f64::from(p.mean[c]).clamp(0.0, 1.0), p.strength),
            _ => (0.5, 0.0),
        };
        num += strength * mean;
        den += strength;
        let mut x = if den > 1e-12 && num.is_finite() {
            (num / den).clamp(0.0, 1.0)
        } else {
            0.5
        };
        for _ in 0..PASSES {
            let (mut num, mut den) = (0.0f64, 0.0f64);
            for ((s, p), r) in samples.iter().zip(responses).zip(robust.iter_mut()) {
                let k = scale(s, c, noise);
                if k <= 0.0 {
                    continue;
                }
                let z = residual(s, p, c, x, noise);
                *r = huber(z, noise.huber_k).1;
                if z == 0.0 && s.clipped[c] {
                    continue;
                }
                let j = p.slope(c, x);
                num += k * *r * (f64::from(s.observation.observed[c]) - p.at(c, x)) * j;
                den += k * *r * j * j;
            }
            information[c] = den;
            num += strength * (mean - x);
            den += strength;
            if den > 1e-12 && num.is_finite() {
                x = (x + num / den).clamp(0.0, 1.0);
            }
        }
        basecolor[c] = x;
        for (s, p) in samples.iter().zip(responses) {
            let w = f64::from(s.observation.weight);
            if w > 0.0 {
                cost += w * huber(residual(s, p, c, x, noise), noise.huber_k).0;
            }
        }
    }
    LinearFit {
        basecolor: basecolor.map(|v| v as f32),
        cost: if cost.is_finite() { cost } else { 0.0 },
        weight: total_weight,
        information: information.map(|v| if v.is_finite() { v } else { 0.0 }),
    }
}

/// The robust cost of `samples` at basecolor `x`, as [`solve`] sums it
/// at its answer (each sample weighted by its trust).
pub fn cost_at(samples: &[Sample], responses: &[Response], x: [f32; 3], noise: &Noise) -> f64 {
    samples
        .iter()
        .zip(responses)
        .map(|(s, p)| {
            let w = f64::from(s.observation.weight);
            if w.is_nan() || w <= 0.0 {
                return 0.0;
            }
            (0..3)
                .map(|c| w * huber(residual(s, p, c, f64::from(x[c]), noise), noise.huber_k).0)
                .sum::<f64>()
        })
        .sum()
}

/// The least-squares weight `w / σ²` of channel `c` (0: not counted).
fn scale(s: &Sample, c: usize, noise: &Noise) -> f64 {
    let w = f64::from(s.observation.weight);
    if w.is_nan() || w <= 0.0 {
        return 0.0;
    }
    let sg = sigma(s.observation.observed[c], noise.abs, noise.rel);
    w / (sg * sg)
}

/// The standardized residual of channel `c` at basecolor `x`; a clipped
/// channel's is 0 once the prediction reaches its bound.
fn residual(s: &Sample, p: &Response, c: usize, x: f64, noise: &Noise) -> f64 {
    let o = &s.observation;
    let predicted = p.at(c, x);
    // The scale grows with the larger of photo and prediction: a highlight
    // predicted a pixel away from where the photo has it costs as much as
    // one the prediction misses, so a narrow lobe is not punished more
    // than a broad one for the same misplacement.
    let top = f64::from(o.observed[c]).abs().max(predicted.abs());
    let sg = sigma(top as f32, noise.abs, noise.rel);
    let d = f64::from(o.observed[c]) - predicted;
    let z = if s.clipped[c] {
        d.max(0.0) / sg
    } else {
        d / sg
    };
    if z.is_finite() {
        z
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::refine::model::directions;

    fn views() -> Vec<(f32, f32, f32)> {
        vec![
            (0.9, 0.8, 0.7),
            (0.7, 0.95, 0.2),
            (0.5, 0.6, -0.4),
            (0.95, 0.9, 0.95),
            (0.8, 0.4, 0.1),
        ]
    }

    fn observe(truth: Params) -> Vec<Sample> {
        let b = bsdf(&truth.to_x(), &Fixed::default());
        views()
            .into_iter()
            .map(|(nv, nl, vl)| {
                let (wo, wi) = directions(nv, nl, vl);
                Sample::exact(Observation::rendered(&b, wo, wi, [2.0, 1.8, 1.5]))
            })
            .collect()
    }

    #[test]
    fn basecolor_is_recovered_to_half_a_percent_for_dielectrics_and_rough_or_smooth_metals() {
        for (metallic, roughness) in [(0.0, 0.3), (1.0, 0.2), (0.0, 0.9), (1.0, 0.6)] {
            let truth = Params {
                basecolor: [0.7, 0.35, 0.1],
                roughness,
                metallic,
            };
            let obs = observe(truth);
            let fit = solve(
                &obs,
                &responses(&obs, roughness, metallic, &Fixed::default()),
                &Noise::default(),
            );
            for c in 0..3 {
                assert!(
                    // The parabola in basecolor is exact for dielectrics
                    // and within 0.005 for rough metal.
                    (fit.basecolor[c] - truth.basecolor[c]).abs() < 5e-3,
                    "m {metallic} r {roughness}: {:?}",
                    fit.basecolor
                );
            }
            assert!(fit.cost < 0.02, "{}", fit.cost);
            assert!((fit.weight - 5.0).abs() < 1e-9);
        }
    }

    #[test]
    fn a_wrong_metallic_costs_more_than_the_right_one() {
        let truth = Params {
            basecolor: [0.8, 0.6, 0.2],
            roughness: 0.25,
            metallic: 1.0,
        };
        let obs = observe(truth);
        let cost = |m: f32| {
            solve(
                &obs,
                &responses(&obs, 0.25, m, &Fixed::default()),
                &Noise::default(),
            )
            .cost
        };
        assert!(
            cost(0.0) > 10.0 * cost(1.0).max(1e-3),
            "{} {}",
            cost(0.0),
            cost(1.0)
        );
    }

    #[test]
    fn a_clipped_highlight_is_a_bound_that_only_counts_while_the_prediction_is_below_it() {
        let truth = Params {
            basecolor: [0.6; 3],
            roughness: 0.1,
            metallic: 1.0,
        };
        let mut obs = observe(truth);
        // Clip every channel of the brightest view at half its value.
        let brightest = (0..obs.len())
            .max_by(|&a, &b| {
                obs[a].observation.observed[0].total_cmp(&obs[b].observation.observed[0])
            })
            .unwrap_or(0);
        obs[brightest].observation.observed = obs[brightest].observation.observed.map(|v| 0.5 * v);
        obs[brightest].clipped = [true; 3];
        obs[brightest].footprint = 0.0;
        let fit = |obs: &[Sample]| {
            solve(
                obs,
                &responses(obs, 0.1, 1.0, &Fixed::default()),
                &Noise::default(),
            )
        };
        let censored = fit(&obs);
        assert!(
            (censored.basecolor[0] - 0.6).abs() < 5e-3,
            "{:?}",
            censored.basecolor
        );
        assert!(censored.cost < 0.01, "{}", censored.cost);
        // A bound above the prediction binds: it pulls basecolor up.
        obs[brightest].observation.observed = obs[brightest].observation.observed.map(|v| 4.0 * v);
        let bound = fit(&obs);
        assert!(bound.basecolor[0] > 0.61, "{:?}", bound.basecolor);
    }

    #[test]
    fn no_usable_observation_gives_a_neutral_answer_not_nan() {
        let mut obs = observe(Params {
            basecolor: [0.2; 3],
            roughness: 0.5,
            metallic: 0.0,
        });
        for s in &mut obs {
            s.observation.weight = 0.0;
        }
        let fit = solve(
            &obs,
            &responses(&obs, 0.5, 0.0, &Fixed::default()),
            &Noise::default(),
        );
        assert_eq!(fit.basecolor, [0.5; 3]);
        assert_eq!((fit.cost, fit.weight), (0.0, 0.0));
        let fit = solve(&[], &[], &Noise::default());
        assert!(fit.basecolor.iter().all(|v| v.is_finite()));
    }
}
