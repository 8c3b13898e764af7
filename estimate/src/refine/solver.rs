//! One pixel's fit: projected Levenberg–Marquardt on the robust,
//! prior-regularized cost, with a finite-difference Jacobian.
//!
//! Cost: `Σ huber(√w (predicted - observed) / σ) + ½ Σ λ_p (x_p - x0_p)²`
//! (see `loss`), minimized by iteratively reweighted Gauss–Newton steps
//! `(JᵀWJ + Λ + μ diag) δ = -(JᵀWz + Λ (x - x0))`. Box bounds: parameters
//! that sit on a bound with the gradient pushing outward leave the step
//! (active set), and the step is clamped into the box. A step is kept
//! only when it lowers the cost; otherwise the damping μ grows.
//!
//! Jacobian: central differences in solver space (one-sided at a bound).
//! The model is evaluated in f32 by the simulator's BSDF, so the step
//! (1e-3 in solver units: 0.1% of a unit parameter, 0.1% relative
//! roughness) keeps rounding error near 1e-4 relative. Analytic derivatives
//! would have to follow every lobe of the Cycles model and its energy
//! tables; ten extra evaluations per iteration cost less than the risk.
//!
//! Every iteration (one Jacobian and one trial step, kept or not) counts
//! toward `max_iterations`, so run time is proportional to it.

use super::loss::{huber, sigma, Prior};
use super::model::{self, clamp_to_box, Fixed, Observation, N, X};
use serde::{Deserialize, Serialize};

/// Tuning of one fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Iterations at most (each: one Jacobian, one trial step).
    pub max_iterations: u32,
    /// Huber threshold in standard units.
    pub huber_k: f64,
    /// Absolute noise per channel, photo units.
    pub noise_abs: f64,
    /// Relative noise per channel.
    pub noise_rel: f64,
    /// Converged when a kept step lowers the cost by less than this
    /// fraction, or moves no parameter by more than it (solver units).
    pub tolerance: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            max_iterations: 10,
            huber_k: 2.0,
            noise_abs: 0.01,
            noise_rel: 0.1,
            tolerance: 1e-4,
        }
    }
}

/// Why a pixel's fit stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The last kept step changed cost or parameters by less than the
    /// tolerance.
    Converged,
    /// The iteration budget ran out.
    MaxIterations,
    /// No step lowered the cost even with the largest damping.
    StepTooSmall,
    /// No trusted observation: the prior's answer stands.
    NoData,
}

impl StopReason {
    /// Every reason, for counting.
    pub const ALL: [StopReason; 4] = [
        StopReason::Converged,
        StopReason::MaxIterations,
        StopReason::StepTooSmall,
        StopReason::NoData,
    ];

    /// The snake_case name used in `result.toml`.
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Converged => "converged",
            StopReason::MaxIterations => "max_iterations",
            StopReason::StepTooSmall => "step_too_small",
            StopReason::NoData => "no_data",
        }
    }
}

/// One pixel's problem.
#[derive(Clone, Copy, Debug)]
pub struct Problem<'a> {
    /// Where the fit starts (solver space).
    pub start: X,
    /// Pull toward the network's answer.
    pub prior: Prior,
    /// Parameters held fixed.
    pub fixed: Fixed,
    /// Every view of the pixel (weight 0 ones are skipped).
    pub observations: &'a [Observation],
}

/// One pixel's result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// The solution, inside the box.
    pub x: X,
    /// Why it stopped.
    pub stop: StopReason,
    /// Iterations used.
    pub iterations: u32,
    /// Diagonal of `(JᵀWJ + Λ)⁻¹` at the solution (solver units²).
    pub posterior_variance: X,
    /// Cost at the start and at the solution.
    pub start_cost: f64,
    pub cost: f64,
}

const FD_STEP: f64 = 1e-3;
const MAX_DAMPING: f64 = 1e8;

/// Fits one pixel; never returns non-finite numbers.
pub fn solve(problem: &Problem<'_>, settings: &Settings) -> Fit {
    let obs: Vec<Observation> = problem
        .observations
        .iter()
        .filter(|o| o.weight > 0.0 && o.weight.is_finite())
        .copied()
        .collect();
    let prior = sanitize_prior(&problem.prior);
    let mut x = clamp_to_box(&problem.start);
    let prior_variance: X = std::array::from_fn(|p| 1.0 / prior.precision[p]);
    if obs.is_empty() {
        let c = prior.cost(&x);
        return Fit {
            x,
            stop: StopReason::NoData,
            iterations: 0,
            posterior_variance: prior_variance,
            start_cost: c,
            cost: c,
        };
    }
    let eval = Evaluator {
        obs: &obs,
        fixed: problem.fixed,
        prior,
        settings: *settings,
    };
    let (lo, hi) = (model::lower(), model::upper());
    let mut z = eval.residuals(&x);
    let mut cost = eval.cost(&x, &z);
    let start_cost = cost;
    let mut jac: Option<Vec<X>> = None;
    let mut damping = 1e-3;
    let mut iterations = 0;
    let mut stop = StopReason::MaxIterations;
    while iterations < settings.max_iterations {
        let j = jac.get_or_insert_with(|| eval.jacobian(&x, &z));
        let (h, g) = eval.normal_equations(&x, &z, j);
        let free: [bool; N] = std::array::from_fn(|p| {
            let at_lo = x[p] <= lo[p] + 1e-12 && g[p] > 0.0;
            let at_hi = x[p] >= hi[p] - 1e-12 && g[p] < 0.0;
            !(at_lo || at_hi)
        });
        iterations += 1;
        let mut a = h;
        for p in 0..N {
            a[p][p] += damping * h[p][p] + 1e-12;
        }
        let rhs: X = std::array::from_fn(|p| if free[p] { -g[p] } else { 0.0 });
        restrict(&mut a, &free);
        let step = cholesky_solve(&a, &rhs).unwrap_or([0.0; N]);
        let trial = clamp_to_box(&std::array::from_fn(|p| x[p] + step[p]));
        let moved = (0..N).map(|p| (trial[p] - x[p]).abs()).fold(0.0, f64::max);
        let trial_z = eval.residuals(&trial);
        let trial_cost = eval.cost(&trial, &trial_z);
        if trial_cost < cost {
            let gain = (cost - trial_cost) / cost.max(1e-30);
            x = trial;
            z = trial_z;
            cost = trial_cost;
            jac = None;
            damping = (damping / 3.0).max(1e-9);
            if gain < settings.tolerance || moved < settings.tolerance {
                stop = StopReason::Converged;
                break;
            }
        } else if moved < 1e-12 {
            // The projected Gauss–Newton step is zero: a stationary point
            // of the box-constrained problem.
            stop = StopReason::Converged;
            break;
        } else {
            damping *= 4.0;
            if damping > MAX_DAMPING {
                stop = StopReason::StepTooSmall;
                break;
            }
        }
    }
    let j = jac.unwrap_or_else(|| eval.jacobian(&x, &z));
    let (h, _) = eval.normal_equations(&x, &z, &j);
    let posterior_variance = inverse_diagonal(&h).unwrap_or(prior_variance);
    Fit {
        x,
        stop,
        iterations,
        posterior_variance: std::array::from_fn(|p| {
            let v = posterior_variance[p];
            if v.is_finite() && v >= 0.0 {
                v.min(prior_variance[p])
            } else {
                prior_variance[p]
            }
        }),
        start_cost,
        cost,
    }
}

/// A prior with finite mean inside the box and positive finite precision.
fn sanitize_prior(prior: &Prior) -> Prior {
    Prior {
        mean: clamp_to_box(&prior.mean),
        precision: std::array::from_fn(|p| {
            let l = prior.precision[p];
            if l.is_finite() {
                l.clamp(1e-6, 1e12)
            } else {
                1e12
            }
        }),
    }
}

struct Evaluator<'a> {
    obs: &'a [Observation],
    fixed: Fixed,
    prior: Prior,
    settings: Settings,
}

impl Evaluator<'_> {
    /// Standardized residuals, three per observation.
    fn residuals(&self, x: &X) -> Vec<f64> {
        let bsdf = model::bsdf(x, &self.fixed);
        let s = &self.settings;
        let mut z = Vec::with_capacity(3 * self.obs.len());
        for o in self.obs {
            let predicted = model::predict(&bsdf, o);
            let w = f64::from(o.weight).sqrt();
            for (&p, &o) in predicted.iter().zip(&o.observed) {
                let observed = if o.is_finite() { f64::from(o) } else { 0.0 };
                let r = w * (p - observed) / sigma(o, s.noise_abs, s.noise_rel);
                z.push(if r.is_finite() { r } else { 0.0 });
            }
        }
        z
    }

    fn cost(&self, x: &X, z: &[f64]) -> f64 {
        let data: f64 = z.iter().map(|&r| huber(r, self.settings.huber_k).0).sum();
        data + self.prior.cost(x)
    }

    /// Columns ∂z/∂x_p.
    fn jacobian(&self, x: &X, z: &[f64]) -> Vec<X> {
        let (lo, hi) = (model::lower(), model::upper());
        let mut columns: Vec<Vec<f64>> = Vec::with_capacity(N);
        for p in 0..N {
            let up = (x[p] + FD_STEP).min(hi[p]);
            let down = (x[p] - FD_STEP).max(lo[p]);
            let shifted = |v: f64| {
                let mut y = *x;
                y[p] = v;
                y
            };
            let z_up = if up > x[p] {
                self.residuals(&shifted(up))
            } else {
                z.to_vec()
            };
            let z_down = if down < x[p] {
                self.residuals(&shifted(down))
            } else {
                z.to_vec()
            };
            let span = up - down;
            columns.push(
                z_up.iter()
                    .zip(&z_down)
                    .map(|(a, b)| if span > 0.0 { (a - b) / span } else { 0.0 })
                    .collect(),
            );
        }
        (0..z.len())
            .map(|i| std::array::from_fn(|p| columns[p][i]))
            .collect()
    }

    /// `H = JᵀWJ + Λ` and `g = JᵀWz + Λ (x - x0)` with Huber's IRLS weights.
    fn normal_equations(&self, x: &X, z: &[f64], j: &[X]) -> ([X; N], X) {
        let mut h = [[0.0; N]; N];
        let mut g = [0.0; N];
        for (row, &r) in j.iter().zip(z) {
            let w = huber(r, self.settings.huber_k).1;
            if w == 0.0 {
                continue;
            }
            for a in 0..N {
                g[a] += w * row[a] * r;
                for b in a..N {
                    h[a][b] += w * row[a] * row[b];
                }
            }
        }
        for a in 0..N {
            // Mirror the upper triangle accumulated above.
            let column: [f64; N] = std::array::from_fn(|b| h[b][a]);
            h[a][..a].copy_from_slice(&column[..a]);
            h[a][a] += self.prior.precision[a];
            g[a] += self.prior.precision[a] * (x[a] - self.prior.mean[a]);
        }
        (h, g)
    }
}

/// Removes the parameters not `free` from the system (identity rows).
fn restrict(a: &mut [X; N], free: &[bool; N]) {
    for (p, _) in free.iter().enumerate().filter(|(_, f)| !**f) {
        for row in a.iter_mut() {
            row[p] = 0.0;
        }
        a[p] = [0.0; N];
        a[p][p] = 1.0;
    }
}

/// Solves `a y = b` for symmetric positive definite `a`.
fn cholesky_solve(a: &[X; N], b: &X) -> Option<X> {
    let l = cholesky(a)?;
    let mut y = [0.0; N];
    for i in 0..N {
        let s: f64 = (0..i).map(|k| l[i][k] * y[k]).sum();
        y[i] = (b[i] - s) / l[i][i];
    }
    let mut out = [0.0; N];
    for i in (0..N).rev() {
        let s: f64 = (i + 1..N).map(|k| l[k][i] * out[k]).sum();
        out[i] = (y[i] - s) / l[i][i];
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

fn cholesky(a: &[X; N]) -> Option<[X; N]> {
    let mut l = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i][k] * l[j][k]).sum();
            if i == j {
                let d = a[i][i] - s;
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                l[i][j] = d.sqrt();
            } else {
                l[i][j] = (a[i][j] - s) / l[j][j];
            }
        }
    }
    Some(l)
}

/// Diagonal of `a⁻¹` for symmetric positive definite `a`.
fn inverse_diagonal(a: &[X; N]) -> Option<X> {
    let mut d = [0.0; N];
    for (p, out) in d.iter_mut().enumerate() {
        let e: X = std::array::from_fn(|q| if q == p { 1.0 } else { 0.0 });
        *out = cholesky_solve(a, &e)?[p];
    }
    Some(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_symmetric_positive_definite_system() {
        let mut a = [[0.0; N]; N];
        for i in 0..N {
            a[i][i] = 2.0 + i as f64;
            if i + 1 < N {
                a[i][i + 1] = 0.5;
                a[i + 1][i] = 0.5;
            }
        }
        let want: X = [1.0, -2.0, 0.5, 3.0, -1.0];
        let b: X = std::array::from_fn(|i| (0..N).map(|k| a[i][k] * want[k]).sum());
        let got = cholesky_solve(&a, &b).unwrap();
        for i in 0..N {
            assert!((got[i] - want[i]).abs() < 1e-12);
        }
        let mut singular = a;
        singular[2][2] = -1.0;
        assert!(cholesky(&singular).is_none());
    }
}
