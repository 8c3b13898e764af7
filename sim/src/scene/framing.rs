//! Framing the object the way an operator sets up a real rig: every
//! position's camera aims at the object's centre, and one focal length,
//! shared by the positions as on a rig with one lens, makes the object
//! fill a chosen share of the frame.
//!
//! The thesis's randomization (see [`super::rig`]) aims the camera at a
//! random point near the origin with a random focal length, so the object
//! may cover a few hundred pixels of the frame: right for training data,
//! which must show every framing, wrong for a demonstration or a scan an
//! operator would take. The data-set recipes keep the thesis's framing;
//! the daemon's simulated rig frames its object.
//!
//! Only the cameras change: flashes, projector and backlight stay where the
//! rig put them (the backlight panel is large enough to lie behind the
//! silhouette for every focal length, see [`super::rig`]).

use super::model::Scene;
use glam::DMat3;
use matscan_scan::camera::look_at;

/// Why a scene cannot be framed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FramingError {
    #[error("frame fill {0}: expected a share of the frame in (0, 1]")]
    Fill(f64),
    #[error("the scene's mesh has no vertex, or one that is not finite: nothing to frame")]
    EmptyMesh,
    #[error(
        "position {position}: part of the object is at or behind the camera; it cannot be framed"
    )]
    BehindCamera { position: String },
}

/// Aims every position's camera at the centre of the object's bounding box
/// and sets the focal length so that the object's farthest vertex, over
/// all positions, lies at `fill` of the way from the image centre to the
/// nearest image edge. The principal point stays at the image centre.
pub fn frame_object(scene: &mut Scene, fill: f64) -> Result<(), FramingError> {
    if !(fill > 0.0 && fill <= 1.0) {
        return Err(FramingError::Fill(fill));
    }
    let (lo, hi) = scene.mesh.bounds().ok_or(FramingError::EmptyMesh)?;
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(FramingError::EmptyMesh);
    }
    let centre = 0.5 * (lo + hi);
    let k = scene.rig.intrinsics;
    let (half_w, half_h) = (k.width as f64 / 2.0, k.height as f64 / 2.0);
    let mut focal = f64::INFINITY;
    for position in &mut scene.rig.positions {
        let eye = position.camera_to_world.w_axis.truncate();
        // The OpenCV frame's y points down the image: keep the head's up.
        let up = -position.camera_to_world.y_axis.truncate();
        let aimed = look_at(eye, centre, up);
        let to_camera = DMat3::from_mat4(aimed).transpose();
        let (mut tan_x, mut tan_y) = (0.0f64, 0.0f64);
        for v in &scene.mesh.positions {
            let offset = v.as_dvec3() - eye;
            let p = to_camera * offset;
            if p.z <= 1e-6 * offset.length().max(1e-12) {
                return Err(FramingError::BehindCamera {
                    position: position.name.clone(),
                });
            }
            tan_x = tan_x.max((p.x / p.z).abs());
            tan_y = tan_y.max((p.y / p.z).abs());
        }
        let fx = if tan_x > 0.0 {
            fill * half_w / tan_x
        } else {
            f64::INFINITY
        };
        let fy = if tan_y > 0.0 {
            fill * half_h / tan_y
        } else {
            f64::INFINITY
        };
        focal = focal.min(fx).min(fy);
        position.camera_to_world = aimed;
    }
    if !focal.is_finite() {
        return Err(FramingError::EmptyMesh);
    }
    scene.rig.intrinsics.fx = focal;
    scene.rig.intrinsics.fy = focal;
    scene.rig.intrinsics.cx = half_w;
    scene.rig.intrinsics.cy = half_h;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
    use glam::DVec3;
    use matscan_scan::camera::PinholeCamera;

    fn scene(geometry: GeometryKind, seed: u64) -> Scene {
        generate(&SceneOptions {
            seed,
            kind: SceneKind::TwoMat,
            geometry: GeometrySource::Kind(geometry),
            width: 64,
            height: 48,
            positions: 3,
            map_size: 16,
        })
    }

    /// Per position, the largest distance of a projected vertex from the
    /// image centre as a share of the half side, along x and y.
    fn reach(s: &Scene) -> Vec<(f64, f64)> {
        let k = s.rig.intrinsics;
        s.rig
            .positions
            .iter()
            .map(|p| {
                let cam = PinholeCamera::new(k, p.camera_to_world);
                s.mesh
                    .positions
                    .iter()
                    .fold((0.0f64, 0.0f64), |(rx, ry), v| {
                        let px = cam.project(v.as_dvec3()).expect("in front");
                        (
                            rx.max((px.x - k.cx).abs() / k.cx),
                            ry.max((px.y - k.cy).abs() / k.cy),
                        )
                    })
            })
            .collect()
    }

    #[test]
    fn the_object_reaches_the_fill_share_and_stays_inside_every_frame() {
        for (geometry, seed) in [(GeometryKind::Sphere, 1), (GeometryKind::Leaves, 5)] {
            let mut s = scene(geometry, seed);
            frame_object(&mut s, 0.8).unwrap();
            let r = reach(&s);
            let widest = r.iter().map(|(x, y)| x.max(*y)).fold(0.0, f64::max);
            assert!((widest - 0.8).abs() < 1e-6, "{geometry:?}: {r:?}");
            assert!(r.iter().all(|(x, y)| *x <= 0.8 + 1e-9 && *y <= 0.8 + 1e-9));
        }
    }

    #[test]
    fn cameras_keep_their_place_and_look_at_the_object() {
        let mut s = scene(GeometryKind::Torus, 3);
        let before: Vec<DVec3> = s
            .rig
            .positions
            .iter()
            .map(|p| p.camera_to_world.w_axis.truncate())
            .collect();
        frame_object(&mut s, 0.9).unwrap();
        let (lo, hi) = s.mesh.bounds().unwrap();
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        let centre = 0.5 * (lo + hi);
        for (p, eye) in s.rig.positions.iter().zip(before) {
            let c2w = p.camera_to_world;
            assert!((c2w.w_axis.truncate() - eye).length() < 1e-12);
            let forward = c2w.z_axis.truncate();
            let to_centre = (centre - eye).normalize();
            assert!(forward.dot(to_centre) > 1.0 - 1e-12, "{}", p.name);
        }
    }

    #[test]
    fn a_fill_outside_the_frame_is_refused() {
        let mut s = scene(GeometryKind::Sphere, 1);
        for fill in [0.0, -0.5, 1.5, f64::NAN] {
            assert!(matches!(
                frame_object(&mut s, fill),
                Err(FramingError::Fill(_))
            ));
        }
        s.mesh.positions.clear();
        assert_eq!(frame_object(&mut s, 0.5), Err(FramingError::EmptyMesh));
    }
}
