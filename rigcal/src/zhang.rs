//! The closed-form start (Zhang 2000, "A flexible new technique for camera
//! calibration"): one homography per shot of the flat board, the intrinsics
//! from the homographies' constraints on the image of the absolute conic,
//! then each shot's pose from its homography. Distortion starts at zero;
//! the refinement ([`crate::refine`]) adds it.

use crate::error::RigcalError;
use crate::model::Pose;
use glam::{DMat3, DMat4, DVec2, DVec3};
use matscan_scan::camera::Intrinsics;
use nalgebra::{DMatrix, Matrix3};

/// The homography taking board-plane points (x, y) to pixels, by the
/// normalized direct linear transform; `None` for fewer than 4 points or a
/// degenerate set.
pub fn homography(board: &[DVec2], pixels: &[DVec2]) -> Option<DMat3> {
    if board.len() < 4 || board.len() != pixels.len() {
        return None;
    }
    let (tb, nb) = normalizer(board)?;
    let (tp, np) = normalizer(pixels)?;
    let mut a = DMatrix::<f64>::zeros(2 * board.len(), 9);
    for (k, (b, p)) in nb.iter().zip(&np).enumerate() {
        let (x, y, u, v) = (b.x, b.y, p.x, p.y);
        let rows = [
            [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u],
            [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v],
        ];
        for (r, row) in rows.iter().enumerate() {
            for (c, value) in row.iter().enumerate() {
                a[(2 * k + r, c)] = *value;
            }
        }
    }
    let h = null_vector(&a)?;
    let hn = DMat3::from_cols(
        DVec3::new(h[0], h[3], h[6]),
        DVec3::new(h[1], h[4], h[7]),
        DVec3::new(h[2], h[5], h[8]),
    );
    let m = tp.inverse() * hn * tb;
    let scale = m.z_axis.z;
    (scale.abs() > 1e-300 && m.is_finite()).then(|| m * (1.0 / scale))
}

/// Similarity that moves the points' centroid to 0 and their mean distance
/// to sqrt(2) (Hartley's normalization), and the moved points.
fn normalizer(points: &[DVec2]) -> Option<(DMat3, Vec<DVec2>)> {
    let n = points.len() as f64;
    let centroid = points.iter().copied().sum::<DVec2>() / n;
    let mean = points.iter().map(|p| (*p - centroid).length()).sum::<f64>() / n;
    if mean.partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / mean;
    let t = DMat3::from_cols(
        DVec3::new(s, 0.0, 0.0),
        DVec3::new(0.0, s, 0.0),
        DVec3::new(-s * centroid.x, -s * centroid.y, 1.0),
    );
    Some((t, points.iter().map(|p| (*p - centroid) * s).collect()))
}

/// The right singular vector of the smallest singular value.
fn null_vector(a: &DMatrix<f64>) -> Option<Vec<f64>> {
    let svd = a.clone().svd(false, true);
    let v_t = svd.v_t?;
    let k = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.total_cmp(y.1))?
        .0;
    Some(v_t.row(k).iter().copied().collect())
}

/// Zhang's `v_ij` row of a homography.
fn v(h: &DMat3, i: usize, j: usize) -> [f64; 6] {
    let (hi, hj) = (h.col(i), h.col(j));
    [
        hi.x * hj.x,
        hi.x * hj.y + hi.y * hj.x,
        hi.y * hj.y,
        hi.z * hj.x + hi.x * hj.z,
        hi.z * hj.y + hi.y * hj.z,
        hi.z * hj.z,
    ]
}

/// Intrinsics (no skew, no distortion) from three or more homographies of
/// differently tilted boards.
pub fn intrinsics(
    homographies: &[DMat3],
    width: u32,
    height: u32,
) -> Result<Intrinsics, RigcalError> {
    let degenerate = |why: &str| RigcalError::Degenerate(why.to_string());
    if homographies.len() < 2 {
        return Err(degenerate("fewer than two usable shots"));
    }
    // Two rows per homography plus the zero-skew row.
    let mut a = DMatrix::<f64>::zeros(2 * homographies.len() + 1, 6);
    // Condition: work in pixels over the image size.
    let scale = f64::from(width.max(height).max(1));
    let to_units = DMat3::from_diagonal(DVec3::new(1.0 / scale, 1.0 / scale, 1.0));
    for (k, h) in homographies.iter().enumerate() {
        let h = to_units * *h;
        let v12 = v(&h, 0, 1);
        let (v11, v22) = (v(&h, 0, 0), v(&h, 1, 1));
        for c in 0..6 {
            a[(2 * k, c)] = v12[c];
            a[(2 * k + 1, c)] = v11[c] - v22[c];
        }
    }
    a[(2 * homographies.len(), 1)] = 1.0;
    let b = null_vector(&a).ok_or_else(|| degenerate("no solution for the conic"))?;
    let b = if b[0] < 0.0 {
        b.iter().map(|x| -x).collect()
    } else {
        b
    };
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let den = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / den;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / den).sqrt();
    let u0 = -b13 * alpha * alpha / lambda;
    let k = Intrinsics {
        width,
        height,
        fx: alpha * scale,
        fy: beta * scale,
        cx: u0 * scale,
        cy: v0 * scale,
        distortion: [0.0; 5],
    };
    if ![k.fx, k.fy, k.cx, k.cy].iter().all(|x| x.is_finite()) || k.fx <= 0.0 || k.fy <= 0.0 {
        return Err(degenerate(
            "the boards' tilts do not separate focal length from distance (tilt the board \
             differently, about both axes, in several shots)",
        ));
    }
    Ok(k)
}

/// The board's pose from its homography and the intrinsics (board in front
/// of the camera, rotation made orthonormal).
pub fn pose(h: &DMat3, k: &Intrinsics) -> Option<Pose> {
    let kinv = DMat3::from_cols(
        DVec3::new(k.fx, 0.0, 0.0),
        DVec3::new(0.0, k.fy, 0.0),
        DVec3::new(k.cx, k.cy, 1.0),
    )
    .inverse();
    let m = kinv * *h;
    let mut s = 1.0 / m.x_axis.length();
    if (m.z_axis * s).z < 0.0 {
        s = -s;
    }
    let r1 = m.x_axis * s;
    let r2 = m.y_axis * s;
    let r3 = r1.cross(r2);
    let t = m.z_axis * s;
    let q = Matrix3::from_columns(&[
        nalgebra::Vector3::new(r1.x, r1.y, r1.z),
        nalgebra::Vector3::new(r2.x, r2.y, r2.z),
        nalgebra::Vector3::new(r3.x, r3.y, r3.z),
    ]);
    let svd = q.svd(true, true);
    let mut r = svd.u? * svd.v_t?;
    if r.determinant() < 0.0 {
        r = -r;
    }
    let rot = DMat3::from_cols(
        DVec3::new(r[(0, 0)], r[(1, 0)], r[(2, 0)]),
        DVec3::new(r[(0, 1)], r[(1, 1)], r[(2, 1)]),
        DVec3::new(r[(0, 2)], r[(1, 2)], r[(2, 2)]),
    );
    let m = DMat4::from_rotation_translation(glam::DQuat::from_mat3(&rot), t);
    m.is_finite().then(|| Pose::from_matrix(&m))
}
