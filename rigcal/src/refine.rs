//! Joint refinement (bundle adjustment): the camera's intrinsics and
//! distortion, shared by every shot, and each shot's board pose, moved
//! together to minimise the squared reprojection error of every corner, by
//! Levenberg-Marquardt.
//!
//! Each corner's residual depends on the 9 intrinsics and its own shot's 6
//! pose parameters only, so the normal equations are accumulated block by
//! block (15 x 15 per corner) into one small dense system (9 + 6 per shot)
//! and solved by Cholesky, instead of factoring the whole Jacobian: a
//! 60-shot calibration is a 369-unknown system. Derivatives are central
//! differences, exact enough for a least-squares step at these scales.

use crate::model::{project, unpack_intrinsics, Pose, INTRINSIC_COUNT, POSE_COUNT};
use glam::{DVec2, DVec3};
use matscan_scan::camera::Intrinsics;
use nalgebra::{DMatrix, DVector};

/// One shot's corners: board-frame points and where the photo shows them.
#[derive(Debug, Clone)]
pub struct ShotPoints {
    pub board: Vec<DVec3>,
    pub pixels: Vec<DVec2>,
}

/// The refined camera and poses, with the statistics the report needs.
#[derive(Debug, Clone)]
pub struct Refined {
    pub camera: Intrinsics,
    pub poses: Vec<Pose>,
    /// One standard deviation of each intrinsic (fx fy cx cy k1 k2 p1 p2
    /// k3), from the normal equations and the residual spread.
    /// `None` where the system is singular.
    pub sigma: Option<[f64; INTRINSIC_COUNT]>,
    pub iterations: usize,
}

const PER_POINT: usize = INTRINSIC_COUNT + POSE_COUNT;
/// The camera's intrinsics held at their start: k3 (0), which shapes only
/// the field's far edge, where a board rarely reaches, and elsewhere trades
/// off against k2 (OpenCV's `CALIB_FIX_K3` for ordinary lenses).
pub const CAMERA_FIXED: &[usize] = &[8];
/// A projector's: its whole distortion (the contract's projector has none).
pub const PROJECTOR_FIXED: &[usize] = &[4, 5, 6, 7, 8];
const MAX_ITERATIONS: usize = 200;

struct Problem<'a> {
    shots: &'a [ShotPoints],
    width: u32,
    height: u32,
}

impl Problem<'_> {
    fn unknowns(&self) -> usize {
        INTRINSIC_COUNT + POSE_COUNT * self.shots.len()
    }

    fn residual(&self, intr: &[f64], pose: &[f64], x: DVec3, observed: DVec2) -> DVec2 {
        let camera = unpack_intrinsics(intr, self.width, self.height);
        project(&camera, &Pose::unpack(pose), x) - observed
    }

    fn cost(&self, params: &[f64]) -> f64 {
        let intr = &params[..INTRINSIC_COUNT];
        self.shots
            .iter()
            .enumerate()
            .map(|(s, shot)| {
                let pose = &params[INTRINSIC_COUNT + POSE_COUNT * s..][..POSE_COUNT];
                shot.board
                    .iter()
                    .zip(&shot.pixels)
                    .map(|(&x, &p)| self.residual(intr, pose, x, p).length_squared())
                    .sum::<f64>()
            })
            .sum()
    }

    /// J^T J and J^T r, accumulated corner by corner.
    fn normal_equations(&self, params: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
        let n = self.unknowns();
        let mut jtj = DMatrix::<f64>::zeros(n, n);
        let mut jtr = DVector::<f64>::zeros(n);
        let mut local = [0.0f64; PER_POINT];
        for (s, shot) in self.shots.iter().enumerate() {
            let offset = INTRINSIC_COUNT + POSE_COUNT * s;
            local[..INTRINSIC_COUNT].copy_from_slice(&params[..INTRINSIC_COUNT]);
            local[INTRINSIC_COUNT..].copy_from_slice(&params[offset..offset + POSE_COUNT]);
            let index = |k: usize| {
                if k < INTRINSIC_COUNT {
                    k
                } else {
                    offset + k - INTRINSIC_COUNT
                }
            };
            for (&x, &p) in shot.board.iter().zip(&shot.pixels) {
                let eval = |l: &[f64; PER_POINT]| {
                    self.residual(&l[..INTRINSIC_COUNT], &l[INTRINSIC_COUNT..], x, p)
                };
                let r = eval(&local);
                let mut jac = [DVec2::ZERO; PER_POINT];
                for (k, column) in jac.iter_mut().enumerate() {
                    let h = 1e-6 * local[k].abs().max(1e-3);
                    let mut plus = local;
                    plus[k] += h;
                    let mut minus = local;
                    minus[k] -= h;
                    *column = (eval(&plus) - eval(&minus)) / (2.0 * h);
                }
                for a in 0..PER_POINT {
                    let ia = index(a);
                    jtr[ia] += jac[a].dot(r);
                    for b in 0..=a {
                        let v = jac[a].dot(jac[b]);
                        let ib = index(b);
                        jtj[(ia, ib)] += v;
                        if ia != ib {
                            jtj[(ib, ia)] += v;
                        }
                    }
                }
            }
        }
        (jtj, jtr)
    }
}

/// Refines `camera` and `poses` (one per shot) against the shots' corners.
/// `fixed` lists intrinsics (by solver index) held at their start.
pub fn refine(
    camera: &Intrinsics,
    poses: &[Pose],
    shots: &[ShotPoints],
    fixed: &[usize],
) -> Refined {
    let problem = Problem {
        shots,
        width: camera.width,
        height: camera.height,
    };
    let mut params: Vec<f64> = crate::model::pack_intrinsics(camera).to_vec();
    for pose in poses {
        params.extend_from_slice(&pose.pack());
    }
    let mut cost = problem.cost(&params);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let (mut jtj, mut jtr) = problem.normal_equations(&params);
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut damped = jtj.clone();
        for &k in fixed {
            damped.row_mut(k).fill(0.0);
            damped.column_mut(k).fill(0.0);
            damped[(k, k)] = 1.0;
        }
        let mut rhs = jtr.clone();
        for &k in fixed {
            rhs[k] = 0.0;
        }
        for k in 0..damped.nrows() {
            damped[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
        }
        let Some(chol) = damped.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let step = chol.solve(&(-&rhs));
        let trial: Vec<f64> = params.iter().zip(step.iter()).map(|(p, d)| p + d).collect();
        let trial_cost = problem.cost(&trial);
        if trial_cost.is_finite() && trial_cost < cost {
            let gain = (cost - trial_cost) / cost.max(1e-300);
            params = trial;
            cost = trial_cost;
            lambda = (lambda * 0.3).max(1e-12);
            (jtj, jtr) = problem.normal_equations(&params);
            if gain < 1e-12 || cost < 1e-20 {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
        }
    }
    let residuals: usize = shots.iter().map(|s| 2 * s.board.len()).sum();
    let dof = residuals.saturating_sub(problem.unknowns()).max(1);
    let variance = cost / dof as f64;
    for &k in fixed {
        jtj.row_mut(k).fill(0.0);
        jtj.column_mut(k).fill(0.0);
        jtj[(k, k)] = 1.0;
    }
    let sigma = jtj.try_inverse().map(|inverse| {
        std::array::from_fn(|k| {
            if fixed.contains(&k) {
                0.0
            } else {
                (inverse[(k, k)].max(0.0) * variance).sqrt()
            }
        })
    });
    Refined {
        camera: unpack_intrinsics(&params, camera.width, camera.height),
        poses: (0..shots.len())
            .map(|s| Pose::unpack(&params[INTRINSIC_COUNT + POSE_COUNT * s..][..POSE_COUNT]))
            .collect(),
        sigma,
        iterations,
    }
}

/// A small dense least-squares problem by Levenberg-Marquardt: `residuals`
/// of the parameters, minimised from `start` (central-difference
/// Jacobian). For the few-unknown fits beside the main refinement.
pub fn least_squares(start: &[f64], residuals: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let n = start.len();
    let mut params = start.to_vec();
    let cost_of = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let mut r = residuals(&params);
    let mut cost = cost_of(&r);
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let m = r.len();
        let mut jac = DMatrix::<f64>::zeros(m, n);
        for k in 0..n {
            let h = 1e-6 * params[k].abs().max(1e-3);
            let mut plus = params.clone();
            plus[k] += h;
            let mut minus = params.clone();
            minus[k] -= h;
            let (rp, rm) = (residuals(&plus), residuals(&minus));
            for i in 0..m.min(rp.len()).min(rm.len()) {
                jac[(i, k)] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * DVector::from_column_slice(&r);
        let mut improved = false;
        while lambda < 1e12 {
            let mut damped = jtj.clone();
            for k in 0..n {
                damped[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(chol) = damped.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = chol.solve(&(-&jtr));
            let trial: Vec<f64> = params.iter().zip(step.iter()).map(|(p, d)| p + d).collect();
            let tr = residuals(&trial);
            let trial_cost = cost_of(&tr);
            if trial_cost.is_finite() && trial_cost < cost {
                let gain = (cost - trial_cost) / cost.max(1e-300);
                params = trial;
                r = tr;
                cost = trial_cost;
                lambda = (lambda * 0.3).max(1e-12);
                improved = gain > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    params
}
