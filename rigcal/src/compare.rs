//! Two rig files side by side: how far one's camera and poses lie from the
//! other's (a calibration against the truth, or today's against last
//! month's).

use glam::DMat4;
use matscan_scan::camera::Intrinsics;
use matscan_scan::{LightKind, Manifest};
use serde::Serialize;

/// Differences of `measured` from `reference`, per quantity the worst over
/// the positions both files name.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct RigDifference {
    /// |fx - fx'| / fx' and the same for fy, the larger, in percent.
    pub focal_percent: f64,
    /// Principal point distance, pixels (at the reference's image size).
    pub principal_px: f64,
    /// Camera centre distance, in the files' units.
    pub position: f64,
    /// Rotation between the camera orientations, degrees.
    pub rotation_deg: f64,
    /// Positions compared.
    pub positions: usize,
    /// The projector's figures, where both files have one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub projector: Option<ProjectorDifference>,
}

/// The projector's differences, worst over the positions.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct ProjectorDifference {
    pub focal_percent: f64,
    pub principal_px: f64,
    pub position: f64,
    pub rotation_deg: f64,
}

/// A position's projector: its intrinsics and pose.
fn projector_of(p: &matscan_scan::Position) -> Option<(Intrinsics, DMat4)> {
    p.lights.iter().find_map(|l| match &l.kind {
        LightKind::Projector {
            projector_to_world,
            intrinsics,
        } => Some((*intrinsics, *projector_to_world)),
        _ => None,
    })
}

fn intrinsics_difference(m: &Intrinsics, r: &Intrinsics) -> (f64, f64) {
    let m = m.scaled_to(r.width, r.height);
    (
        100.0 * ((m.fx - r.fx).abs() / r.fx).max((m.fy - r.fy).abs() / r.fy),
        ((m.cx - r.cx).powi(2) + (m.cy - r.cy).powi(2)).sqrt(),
    )
}

pub fn compare(measured: &Manifest, reference: &Manifest) -> RigDifference {
    let (focal_percent, principal_px) = intrinsics_difference(&measured.camera, &reference.camera);
    let mut out = RigDifference {
        focal_percent,
        principal_px,
        position: 0.0,
        rotation_deg: 0.0,
        positions: 0,
        projector: None,
    };
    for p in &reference.positions {
        let Some(q) = measured.position(&p.name) else {
            continue;
        };
        let (dp, dr) = pose_difference(&q.camera_to_world, &p.camera_to_world);
        out.position = out.position.max(dp);
        out.rotation_deg = out.rotation_deg.max(dr);
        out.positions += 1;
        if let (Some((km, tm)), Some((kr, tr))) = (projector_of(q), projector_of(p)) {
            let (focal_percent, principal_px) = intrinsics_difference(&km, &kr);
            let (dp, dr) = pose_difference(&tm, &tr);
            let prev = out.projector.unwrap_or(ProjectorDifference {
                focal_percent,
                principal_px,
                position: 0.0,
                rotation_deg: 0.0,
            });
            out.projector = Some(ProjectorDifference {
                position: prev.position.max(dp),
                rotation_deg: prev.rotation_deg.max(dr),
                ..prev
            });
        }
    }
    out
}

/// Translation distance and rotation angle (degrees) between two rigid
/// transforms.
pub fn pose_difference(a: &DMat4, b: &DMat4) -> (f64, f64) {
    let (_, qa, ta) = a.to_scale_rotation_translation();
    let (_, qb, tb) = b.to_scale_rotation_translation();
    let angle = qa.angle_between(qb).to_degrees();
    (
        (ta - tb).length(),
        if angle.is_finite() { angle } else { 0.0 },
    )
}
