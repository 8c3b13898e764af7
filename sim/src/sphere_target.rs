//! The light-calibration target on the simulated rig: a glossy black
//! sphere of known radius, held up in front of the backlight panel at
//! random places in the camera's view, rendered by the same path tracer
//! as the scans. Its silhouette against the panel locates it; each
//! flash's highlight on it is a reflected ray towards that flash.
//!
//! The sphere is a fine triangle mesh with the true sphere's normals at
//! its vertices (shading follows the sphere, the outline strays from it by
//! under 1e-4 of the radius), black (albedo 0.02) and glossy (roughness
//! 0.3, a dielectric's 4 % reflectance), so each flash leaves a highlight
//! a few pixels wide (its centroid is then sub-pixel) and hardly any
//! diffuse light.
//!
//! Boundaries: scenes and placements only; the capture path renders them.

use crate::calib_target::target_scene;
use crate::render::SimError;
use crate::scene::{Rig, Scene, Texture};
use glam::{DMat4, DVec3, Vec2};
use matscan_scan::Mesh;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Segments around the sphere's equator.
const SEGMENTS: u32 = 256;

/// The sphere's scene: `radius` at `centre` (world), under `rig`.
pub fn sphere_scene(centre: DVec3, radius: f64, rig: &Rig) -> Scene {
    let (nu, nv) = (SEGMENTS, SEGMENTS / 2);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=nv {
        let theta = std::f64::consts::PI * f64::from(j) / f64::from(nv);
        for i in 0..=nu {
            let phi = std::f64::consts::TAU * f64::from(i) / f64::from(nu);
            let n = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push((centre + n * radius).as_vec3());
            normals.push(n.as_vec3());
            uvs.push(Vec2::new(i as f32 / nu as f32, 1.0 - j as f32 / nv as f32));
        }
    }
    let row = nu + 1;
    let mut triangles = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let (a, b) = (j * row + i, j * row + i + 1);
            let (c, d) = ((j + 1) * row + i, (j + 1) * row + i + 1);
            // Counter-clockwise seen from outside.
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    let mesh = Mesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        triangles,
    };
    target_scene(
        "sphere",
        "sphere",
        mesh,
        Texture::Constant([0.02; 3]),
        0.3,
        rig,
    )
}

/// A person holding the sphere up in front of a simulated rig: its radius
/// fitted to the rig (about 5 % of the camera's view across at the
/// working distance, rounded to a millimetre), and where it goes next.
#[derive(Debug, Clone)]
pub struct SphereHolder {
    rig: Rig,
    radius: f64,
    rng: Pcg64,
}

impl SphereHolder {
    /// The sphere for `rig`; `seed` picks its places.
    pub fn new(rig: &Rig, seed: u64) -> SphereHolder {
        let k = &rig.intrinsics;
        let distance = rig
            .positions
            .first()
            .map_or(1.0, |p| p.camera_to_world.w_axis.truncate().length());
        let view = distance * f64::from(k.width) / k.fx;
        let radius = ((0.05 * view) * 1000.0).round().max(1.0) / 1000.0;
        SphereHolder {
            rig: rig.clone(),
            radius,
            rng: Pcg64::seed_from_u64(seed ^ 0x5fe7),
        }
    }

    /// The sphere's radius, metres.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The scene with the sphere at a fresh place before the camera of
    /// rig position `position`: whole in view, the backlight panel behind
    /// all of it, anywhere from three quarters of the working distance to
    /// just past it and across two thirds of the view, so that the rays of
    /// different places cross at wide angles.
    pub fn place(&mut self, position: usize) -> Result<Scene, SimError> {
        let at = self.rig.positions.get(position).ok_or_else(|| {
            SimError::Options(format!(
                "rig position {position} does not exist ({} positions)",
                self.rig.positions.len()
            ))
        })?;
        let k = self.rig.intrinsics;
        let c2w = at.camera_to_world;
        let distance = c2w.w_axis.truncate().length();
        for _ in 0..1000 {
            let z = distance * self.rng.gen_range(0.45..0.75);
            let spread = 0.38 * z * f64::from(k.width) / k.fx;
            let centre = DVec3::new(
                self.rng.gen_range(-spread..spread),
                self.rng.gen_range(-spread..spread),
                z,
            );
            if self.fits(&c2w, centre, at) {
                return Ok(sphere_scene(
                    c2w.transform_point3(centre),
                    self.radius,
                    &self.rig,
                ));
            }
        }
        Err(SimError::Options(format!(
            "no place for the sphere before the backlight panel fits the view at position {}",
            at.name
        )))
    }

    /// Whether the sphere at `centre` (camera frame) shows whole, with a
    /// margin, the panel lies behind its outline and the projector lights
    /// it.
    fn fits(&self, c2w: &DMat4, centre: DVec3, at: &crate::scene::RigPosition) -> bool {
        let k = self.rig.intrinsics;
        let a = centre.normalize();
        let sin_b = (1.5 * self.radius / centre.length()).min(0.99);
        let cos_b = (1.0 - sin_b * sin_b).sqrt();
        let e1 = a.any_orthonormal_vector();
        let e2 = a.cross(e1);
        let margin = 0.05 * f64::from(k.width.min(k.height));
        (0..16).all(|i| {
            let t = std::f64::consts::TAU * f64::from(i) / 16.0;
            let ray = a * cos_b + (e1 * t.cos() + e2 * t.sin()) * sin_b;
            let in_view = k.project_camera_point(ray).is_some_and(|p| {
                p.x > margin
                    && p.y > margin
                    && p.x < f64::from(k.width) - margin
                    && p.y < f64::from(k.height) - margin
            });
            let origin = c2w.transform_point3(DVec3::ZERO);
            let dir = c2w.transform_vector3(ray).normalize();
            in_view && hits_panel(&at.backlight, origin, dir)
        }) && {
            // Inside the projector's image too, whose highlight centres it.
            let projector = matscan_scan::PinholeCamera::new(
                at.projector.intrinsics,
                at.projector.projector_to_world,
            );
            let p = &at.projector.intrinsics;
            projector
                .project(c2w.transform_point3(centre))
                .is_some_and(|px| {
                    px.x > 0.1 * f64::from(p.width)
                        && px.y > 0.1 * f64::from(p.height)
                        && px.x < 0.9 * f64::from(p.width)
                        && px.y < 0.9 * f64::from(p.height)
                })
        }
    }
}

/// Whether the ray from `origin` along `dir` meets the backlight panel.
fn hits_panel(b: &crate::scene::Backlight, origin: DVec3, dir: DVec3) -> bool {
    let (c, u, v) = (
        b.center.as_dvec3(),
        b.half_u.as_dvec3(),
        b.half_v.as_dvec3(),
    );
    let n = u.cross(v).normalize_or_zero();
    let facing = dir.dot(n);
    if facing.abs() < 1e-9 {
        return false;
    }
    let t = (c - origin).dot(n) / facing;
    let q = origin + dir * t - c;
    t > 0.0
        && (q.dot(u) / u.length_squared()).abs() <= 1.0
        && (q.dot(v) / v.length_squared()).abs() <= 1.0
}
