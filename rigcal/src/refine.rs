//! Joint refinement (bundle adjustment): the camera's intrinsics and
//! distortion, shared by every shot, and each shot's board pose, moved
//! together to minimise the squared reprojection error of every corner, by
//! Levenberg-Marquardt. Each shot's squared errors carry its weight, the
//! inverse of its corners' noise variance ([`noise_weights`]), so that a
//! noisy steep shot moves the camera less than an averaged resting one.
//!
//! Shots may share a pose: the photos of a board resting in place from one
//! camera position all hang on that position's one pose, so each adds its
//! corners to it instead of a pose of its own. A shot may also name a
//! second pose, its placement: the board's frame in the frame its pose
//! maps, shared by every position that photographed the board resting
//! there (a placement nobody measured, found from all of them together).
//!
//! Each corner's residual depends on the 9 intrinsics and its own shot's 6
//! (or 12) pose parameters only, so the normal equations are accumulated
//! block by block (at most 21 x 21 per corner) into one small dense system
//! (9 + 6 per pose)
//! and solved by Cholesky, instead of factoring the whole Jacobian: a
//! 60-shot calibration is a 369-unknown system. Derivatives are central
//! differences, exact enough for a least-squares step at these scales.

use crate::model::{project, unpack_intrinsics, Pose, INTRINSIC_COUNT, POSE_COUNT};
use glam::{DVec2, DVec3};
use matscan_scan::camera::Intrinsics;
use nalgebra::{DMatrix, DVector};

/// One shot's corners: points in the frame of its pose and where the photo
/// shows them.
#[derive(Debug, Clone)]
pub struct ShotPoints {
    pub board: Vec<DVec3>,
    pub pixels: Vec<DVec2>,
    /// Index of the shot's pose among the refined poses.
    pub pose: usize,
    /// Index of a pose that maps `board` into the frame `pose` maps first
    /// (a resting board's unknown placement), if any.
    pub placement: Option<usize>,
    /// The weight of each of its squared residuals: the inverse of its
    /// corners' noise variance, relative to the others' (1 where every
    /// shot is alike; see [`noise_weights`]).
    pub weight: f64,
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

const PER_POINT: usize = INTRINSIC_COUNT + 2 * POSE_COUNT;
/// The camera's intrinsics held at their start: k3 (0), which shapes only
/// the field's far edge, where a board rarely reaches, and elsewhere trades
/// off against k2 (OpenCV's `CALIB_FIX_K3` for ordinary lenses).
pub const CAMERA_FIXED: &[usize] = &[8];
/// A projector's: its whole distortion (the contract's projector has none).
pub const PROJECTOR_FIXED: &[usize] = &[4, 5, 6, 7, 8];
const MAX_ITERATIONS: usize = 200;

struct Problem<'a> {
    shots: &'a [ShotPoints],
    poses: usize,
    width: u32,
    height: u32,
}

impl Problem<'_> {
    fn unknowns(&self) -> usize {
        INTRINSIC_COUNT + POSE_COUNT * self.poses
    }

    /// `placement` is empty for a shot without one.
    fn residual(
        &self,
        intr: &[f64],
        pose: &[f64],
        placement: &[f64],
        x: DVec3,
        observed: DVec2,
    ) -> DVec2 {
        let camera = unpack_intrinsics(intr, self.width, self.height);
        let x = if placement.is_empty() {
            x
        } else {
            Pose::unpack(placement).apply(x)
        };
        project(&camera, &Pose::unpack(pose), x) - observed
    }

    fn pose(params: &[f64], index: usize) -> &[f64] {
        &params[INTRINSIC_COUNT + POSE_COUNT * index..][..POSE_COUNT]
    }

    fn cost(&self, params: &[f64]) -> f64 {
        let intr = &params[..INTRINSIC_COUNT];
        self.shots
            .iter()
            .map(|shot| {
                let pose = Self::pose(params, shot.pose);
                let placement = shot.placement.map_or(&[][..], |k| Self::pose(params, k));
                shot.weight
                    * shot
                        .board
                        .iter()
                        .zip(&shot.pixels)
                        .map(|(&x, &p)| self.residual(intr, pose, placement, x, p).length_squared())
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
        const SECOND: usize = INTRINSIC_COUNT + POSE_COUNT;
        for shot in self.shots {
            let offset = INTRINSIC_COUNT + POSE_COUNT * shot.pose;
            let placed = shot.placement.map(|k| INTRINSIC_COUNT + POSE_COUNT * k);
            let used = if placed.is_some() { PER_POINT } else { SECOND };
            local[..INTRINSIC_COUNT].copy_from_slice(&params[..INTRINSIC_COUNT]);
            local[INTRINSIC_COUNT..SECOND].copy_from_slice(&params[offset..offset + POSE_COUNT]);
            if let Some(o) = placed {
                local[SECOND..].copy_from_slice(&params[o..o + POSE_COUNT]);
            }
            let index = |k: usize| {
                if k < INTRINSIC_COUNT {
                    k
                } else if k < SECOND {
                    offset + k - INTRINSIC_COUNT
                } else {
                    placed.unwrap_or(0) + k - SECOND
                }
            };
            for (&x, &p) in shot.board.iter().zip(&shot.pixels) {
                let eval = |l: &[f64; PER_POINT]| {
                    self.residual(
                        &l[..INTRINSIC_COUNT],
                        &l[INTRINSIC_COUNT..SECOND],
                        &l[SECOND..used],
                        x,
                        p,
                    )
                };
                let r = eval(&local);
                let mut jac = [DVec2::ZERO; PER_POINT];
                for (k, column) in jac.iter_mut().enumerate().take(used) {
                    let h = 1e-6 * local[k].abs().max(1e-3);
                    let mut plus = local;
                    plus[k] += h;
                    let mut minus = local;
                    minus[k] -= h;
                    *column = (eval(&plus) - eval(&minus)) / (2.0 * h);
                }
                for a in 0..used {
                    let ia = index(a);
                    jtr[ia] += shot.weight * jac[a].dot(r);
                    for b in 0..=a {
                        let v = shot.weight * jac[a].dot(jac[b]);
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

/// Refines `camera` and `poses` against the shots' corners (each shot
/// names its pose; every index must be below `poses.len()`, and a pose no
/// shot names stays where it starts). `fixed` lists intrinsics (by solver
/// index) held at their start.
pub fn refine(
    camera: &Intrinsics,
    poses: &[Pose],
    shots: &[ShotPoints],
    fixed: &[usize],
) -> Refined {
    let problem = Problem {
        shots,
        poses: poses.len(),
        width: camera.width,
        height: camera.height,
    };
    let mut start: Vec<f64> = crate::model::pack_intrinsics(camera).to_vec();
    for pose in poses {
        start.extend_from_slice(&pose.pack());
    }
    let solution = levenberg_marquardt(
        start,
        |p| problem.cost(p),
        |p| problem.normal_equations(p),
        fixed,
    );
    let residuals: usize = shots.iter().map(|s| 2 * s.board.len()).sum();
    let dof = residuals.saturating_sub(problem.unknowns()).max(1);
    let variance = solution.cost / dof as f64;
    let sigma = solution.jtj.try_inverse().map(|inverse| {
        std::array::from_fn(|k| {
            if fixed.contains(&k) {
                0.0
            } else {
                (inverse[(k, k)].max(0.0) * variance).sqrt()
            }
        })
    });
    let params = &solution.params;
    Refined {
        camera: unpack_intrinsics(params, camera.width, camera.height),
        poses: (0..poses.len())
            .map(|s| Pose::unpack(&params[INTRINSIC_COUNT + POSE_COUNT * s..][..POSE_COUNT]))
            .collect(),
        sigma,
        iterations: solution.iterations,
    }
}

/// The most one shot's weight may differ from the pooled noise's, either
/// way: a shot that happens to fit almost exactly must not outweigh the
/// rest, nor a poor one vanish (the retake rule judges it).
const MAX_WEIGHT_RATIO: f64 = 16.0;

/// Each shot's weight from the residuals of a fit: the pooled noise
/// variance over its own (each shot's squared residuals over their
/// degrees of freedom: less its own pose's 6 where no other shot shares
/// it), within [`MAX_WEIGHT_RATIO`] of 1. A photo averaged from several
/// frames, or a board seen head-on, carries less noise per corner than a
/// steep hand-held shot, and weighting each by its own noise is the
/// maximum-likelihood fit where the noise differs per shot. Shots without
/// corners, and a fit without residuals, keep weight 1.
pub fn noise_weights(camera: &Intrinsics, poses: &[Pose], shots: &[ShotPoints]) -> Vec<f64> {
    let mut sharing = vec![0usize; poses.len()];
    for shot in shots {
        if let Some(c) = sharing.get_mut(shot.pose) {
            *c += 1;
        }
    }
    let variances: Vec<Option<f64>> = shots
        .iter()
        .map(|shot| {
            let pose = poses.get(shot.pose)?;
            let placement = match shot.placement {
                Some(k) => Some(poses.get(k)?),
                None => None,
            };
            let squares: f64 = shot
                .board
                .iter()
                .zip(&shot.pixels)
                .map(|(&x, &p)| {
                    let x = placement.map_or(x, |seat| seat.apply(x));
                    (project(camera, pose, x) - p).length_squared()
                })
                .sum();
            let own = shot.placement.is_none() && sharing[shot.pose] == 1;
            let dof = (2 * shot.board.len()).saturating_sub(if own { POSE_COUNT } else { 0 });
            (dof > 0 && squares.is_finite()).then(|| squares / dof as f64)
        })
        .collect();
    let (sum, count) = variances
        .iter()
        .zip(shots)
        .filter_map(|(v, s)| v.map(|v| (v * s.board.len() as f64, s.board.len())))
        .fold((0.0, 0usize), |(a, n), (v, k)| (a + v, n + k));
    if count == 0 || sum <= 0.0 {
        return vec![1.0; shots.len()];
    }
    let pooled = sum / count as f64;
    variances
        .iter()
        .map(|v| match v {
            Some(v) => {
                (pooled / v.max(f64::MIN_POSITIVE)).clamp(1.0 / MAX_WEIGHT_RATIO, MAX_WEIGHT_RATIO)
            }
            None => 1.0,
        })
        .collect()
}

/// A small dense least-squares problem by Levenberg-Marquardt: `residuals`
/// of the parameters, minimised from `start` (central-difference
/// Jacobian). For the few-unknown fits beside the main refinement.
pub fn least_squares(start: &[f64], residuals: impl Fn(&[f64]) -> Vec<f64>) -> Vec<f64> {
    let normal_equations = |params: &[f64]| {
        let r = residuals(params);
        let mut jac = DMatrix::<f64>::zeros(r.len(), params.len());
        for k in 0..params.len() {
            let h = 1e-6 * params[k].abs().max(1e-3);
            let mut plus = params.to_vec();
            plus[k] += h;
            let mut minus = params.to_vec();
            minus[k] -= h;
            let (rp, rm) = (residuals(&plus), residuals(&minus));
            for i in 0..r.len().min(rp.len()).min(rm.len()) {
                jac[(i, k)] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let jtr = jac.transpose() * DVector::from_column_slice(&r);
        (jac.transpose() * jac, jtr)
    };
    let cost = |params: &[f64]| residuals(params).iter().map(|v| v * v).sum::<f64>();
    levenberg_marquardt(start.to_vec(), cost, normal_equations, &[]).params
}

/// Where a Levenberg-Marquardt run ends.
struct Solution {
    params: Vec<f64>,
    cost: f64,
    /// J^T J at `params`, with held parameters' rows and columns those of
    /// the identity.
    jtj: DMatrix<f64>,
    iterations: usize,
}

/// Levenberg-Marquardt from `start`: `cost` of the parameters, `normal`
/// their J^T J and J^T r; the parameters in `fixed` stay at their start.
/// A step that raises the cost (or makes it non-finite) is refused and the
/// damping raised, so no NaN reaches the result.
fn levenberg_marquardt(
    start: Vec<f64>,
    cost: impl Fn(&[f64]) -> f64,
    normal: impl Fn(&[f64]) -> (DMatrix<f64>, DVector<f64>),
    fixed: &[usize],
) -> Solution {
    let held = |(mut jtj, mut jtr): (DMatrix<f64>, DVector<f64>)| {
        for &k in fixed {
            jtj.row_mut(k).fill(0.0);
            jtj.column_mut(k).fill(0.0);
            jtj[(k, k)] = 1.0;
            jtr[k] = 0.0;
        }
        (jtj, jtr)
    };
    let mut params = start;
    let mut current = cost(&params);
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let (mut jtj, mut jtr) = held(normal(&params));
    while iterations < MAX_ITERATIONS {
        iterations += 1;
        let mut damped = jtj.clone();
        for k in 0..damped.nrows() {
            damped[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
        }
        let Some(chol) = damped.cholesky() else {
            lambda *= 10.0;
            continue;
        };
        let step = chol.solve(&(-&jtr));
        let trial: Vec<f64> = params.iter().zip(step.iter()).map(|(p, d)| p + d).collect();
        let trial_cost = cost(&trial);
        if trial_cost.is_finite() && trial_cost < current {
            let gain = (current - trial_cost) / current.max(1e-300);
            params = trial;
            current = trial_cost;
            lambda = (lambda * 0.3).max(1e-12);
            (jtj, jtr) = held(normal(&params));
            if gain < 1e-12 || current < 1e-20 {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e12 {
                break;
            }
        }
    }
    Solution {
        params,
        cost: current,
        jtj,
        iterations,
    }
}
