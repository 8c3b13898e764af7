//! The parameters the solver moves: the camera's intrinsics and
//! distortion (scan's OpenCV model, [`Intrinsics`]) and one rigid pose per
//! shot as a rotation vector and a translation.

use glam::{DMat4, DQuat, DVec2, DVec3};
use matscan_scan::camera::Intrinsics;

/// Intrinsic parameters in solver order: fx fy cx cy k1 k2 p1 p2 k3.
pub const INTRINSIC_COUNT: usize = 9;
/// Pose parameters: rotation vector (3), translation (3).
pub const POSE_COUNT: usize = 6;

pub fn pack_intrinsics(k: &Intrinsics) -> [f64; INTRINSIC_COUNT] {
    let d = k.distortion;
    [k.fx, k.fy, k.cx, k.cy, d[0], d[1], d[2], d[3], d[4]]
}

pub fn unpack_intrinsics(p: &[f64], width: u32, height: u32) -> Intrinsics {
    Intrinsics {
        width,
        height,
        fx: p[0],
        fy: p[1],
        cx: p[2],
        cy: p[3],
        distortion: [p[4], p[5], p[6], p[7], p[8]],
    }
}

/// A rigid board-to-camera transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotation vector (axis times angle, radians).
    pub rotation: DVec3,
    pub translation: DVec3,
}

impl Pose {
    pub fn from_matrix(m: &DMat4) -> Pose {
        let (_, q, t) = m.to_scale_rotation_translation();
        Pose {
            rotation: q.to_scaled_axis(),
            translation: t,
        }
    }

    pub fn matrix(&self) -> DMat4 {
        DMat4::from_rotation_translation(DQuat::from_scaled_axis(self.rotation), self.translation)
    }

    pub fn pack(&self) -> [f64; POSE_COUNT] {
        let (r, t) = (self.rotation, self.translation);
        [r.x, r.y, r.z, t.x, t.y, t.z]
    }

    pub fn unpack(p: &[f64]) -> Pose {
        Pose {
            rotation: DVec3::new(p[0], p[1], p[2]),
            translation: DVec3::new(p[3], p[4], p[5]),
        }
    }

    /// The board point `x` in the camera frame.
    pub fn apply(&self, x: DVec3) -> DVec3 {
        DQuat::from_scaled_axis(self.rotation) * x + self.translation
    }

    /// Angle between the board's normal and the line of sight to its
    /// origin, degrees (0 = seen head-on).
    pub fn tilt_deg(&self) -> f64 {
        let normal = DQuat::from_scaled_axis(self.rotation) * DVec3::Z;
        let sight = self.translation.normalize_or_zero();
        normal.dot(sight).abs().clamp(0.0, 1.0).acos().to_degrees()
    }
}

/// Where `camera` sees the board point `x` of a board at `pose`. A point
/// behind the camera projects far outside (so a solver step that puts one
/// there is rejected by its cost, never turned into NaN).
pub fn project(camera: &Intrinsics, pose: &Pose, x: DVec3) -> DVec2 {
    let pc = pose.apply(x);
    camera
        .project_camera_point(pc)
        .filter(|p| p.is_finite())
        .unwrap_or(DVec2::splat(1e6))
}
