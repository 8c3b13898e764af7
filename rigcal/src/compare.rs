//! Two rig files side by side: how far one's camera and poses lie from the
//! other's (a calibration against the truth, or today's against last
//! month's).

use glam::DMat4;
use matscan_scan::camera::Intrinsics;
use matscan_scan::{LightKind, Manifest};
use serde::Serialize;

/// Differences of `measured` from `reference`, per quantity the worst over
/// the positions both files name.
#[derive(Debug, Clone, Serialize, PartialEq)]
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
    /// Largest distance, in the reference's pixels, between where the two
    /// cameras see a point of the box within [`OBJECT_HALF_SIZE`] of the
    /// world origin (where the object stands), over the points in view: what the estimator feels of
    /// the differences above, which partly cancel there.
    pub object_px: f64,
    /// The projector's figures, where both files have one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub projector: Option<ProjectorDifference>,
    /// Per point light both files name (the flashes): the largest distance
    /// between its two positions over the positions, in the files' units.
    pub flashes: Vec<(String, f64)>,
    /// Per light both files give an intensity: the largest relative
    /// difference of the measured from the reference over the positions
    /// (signed, 0.01 = 1 % brighter).
    pub intensities: Vec<(String, f64)>,
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

/// Half the edge of the box around the world origin whose points
/// [`RigDifference::object_px`] projects, in the files' units.
pub const OBJECT_HALF_SIZE: f64 = 0.5;

/// The largest pixel distance between two cameras' images of the points
/// of a 9 x 9 x 9 grid over the object's box that the reference camera
/// sees (outside its image the lens model is extrapolated).
fn object_difference(
    measured: &matscan_scan::PinholeCamera,
    reference: &matscan_scan::PinholeCamera,
) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..9 {
        for j in 0..9 {
            for k in 0..9 {
                let at = |n: i32| OBJECT_HALF_SIZE * (f64::from(n) / 4.0 - 1.0);
                let x = glam::DVec3::new(at(i), at(j), at(k));
                let k = &reference.intrinsics;
                if let (Some(a), Some(b)) = (measured.project(x), reference.project(x)) {
                    let seen = b.x >= 0.0
                        && b.y >= 0.0
                        && b.x <= f64::from(k.width)
                        && b.y <= f64::from(k.height);
                    if seen {
                        worst = worst.max((a - b).length());
                    }
                }
            }
        }
    }
    worst
}

pub fn compare(measured: &Manifest, reference: &Manifest) -> RigDifference {
    let (focal_percent, principal_px) = intrinsics_difference(&measured.camera, &reference.camera);
    let mut out = RigDifference {
        focal_percent,
        principal_px,
        position: 0.0,
        rotation_deg: 0.0,
        positions: 0,
        object_px: 0.0,
        projector: None,
        flashes: Vec::new(),
        intensities: Vec::new(),
    };
    let measured_camera = measured
        .camera
        .scaled_to(reference.camera.width, reference.camera.height);
    for p in &reference.positions {
        let Some(q) = measured.position(&p.name) else {
            continue;
        };
        let (dp, dr) = pose_difference(&q.camera_to_world, &p.camera_to_world);
        out.position = out.position.max(dp);
        out.rotation_deg = out.rotation_deg.max(dr);
        out.positions += 1;
        out.object_px = out.object_px.max(object_difference(
            &matscan_scan::PinholeCamera::new(measured_camera, q.camera_to_world),
            &matscan_scan::PinholeCamera::new(reference.camera, p.camera_to_world),
        ));
        for light in &p.lights {
            let measured_intensity = q
                .lights
                .iter()
                .find(|l| l.name == light.name)
                .and_then(|l| l.intensity);
            if let (Some(m), Some(r)) = (measured_intensity, light.intensity) {
                let d = m / r - 1.0;
                match out.intensities.iter_mut().find(|(n, _)| *n == light.name) {
                    Some((_, worst)) if worst.abs() >= d.abs() => {}
                    Some((_, worst)) => *worst = d,
                    None => out.intensities.push((light.name.clone(), d)),
                }
            }
            let matscan_scan::LightKind::Point { position: want } = light.kind else {
                continue;
            };
            let found = q.lights.iter().find_map(|l| match l.kind {
                matscan_scan::LightKind::Point { position } if l.name == light.name => {
                    Some(position)
                }
                _ => None,
            });
            if let Some(found) = found {
                let d = (found - want).length();
                match out.flashes.iter_mut().find(|(n, _)| *n == light.name) {
                    Some((_, worst)) => *worst = worst.max(d),
                    None => out.flashes.push((light.name.clone(), d)),
                }
            }
        }
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
