//! What rays can hit at one rig position: the object mesh (through its BVH)
//! and the backlight panel (intersected analytically beside it), plus the
//! ray-offset rule that keeps secondary rays from re-hitting their origin.
//!
//! Offsets follow `matscan_scan::bvh::offset_origin_scaled` (2^-15 times
//! the larger of |p| and the scene's magnitude, along the geometric normal,
//! toward the side the new ray leaves on), which holds for scenes from 1e-3
//! to 1e3 units in f32.
//!
//! Boundaries: intersection and visibility only; no shading.

use super::lights::Panel;
use glam::Vec3;
use matscan_scan::bvh::offset_origin_scaled;
use matscan_scan::{Bvh, Mesh, Ray, SurfacePoint};

/// What a ray hit first.
#[derive(Debug, Clone, Copy)]
pub enum Surface {
    Object(SurfacePoint),
    /// The backlight panel at `position`.
    Panel {
        position: Vec3,
    },
}

#[derive(Debug, Clone, Copy)]
pub struct Intersection {
    pub t: f32,
    pub surface: Surface,
}

/// The object's acceleration structure, built once per scene.
pub struct ObjectGeometry<'a> {
    pub mesh: &'a Mesh,
    bvh: Bvh,
    /// Largest absolute coordinate of the mesh.
    pub magnitude: f32,
    /// Axis-aligned bounds of the mesh (`None` when it is empty).
    pub bounds: Option<(Vec3, Vec3)>,
}

impl<'a> ObjectGeometry<'a> {
    pub fn new(mesh: &'a Mesh) -> Self {
        let bvh = Bvh::build(mesh);
        let magnitude = bvh
            .bounds()
            .map_or(0.0, |(lo, hi)| lo.abs().max(hi.abs()).max_element());
        ObjectGeometry {
            mesh,
            bvh,
            magnitude,
            bounds: mesh.bounds(),
        }
    }
}

/// Object plus the panel of one position.
pub struct World<'a> {
    pub object: &'a ObjectGeometry<'a>,
    pub panel: Option<&'a Panel>,
    magnitude: f32,
}

impl<'a> World<'a> {
    pub fn new(object: &'a ObjectGeometry<'a>, panel: Option<&'a Panel>) -> Self {
        let panel_magnitude = panel.map_or(0.0, |p| p.center.abs().max_element() + p.extent());
        let magnitude = object.magnitude.max(panel_magnitude);
        World {
            object,
            panel,
            magnitude: if magnitude.is_finite() {
                magnitude
            } else {
                0.0
            },
        }
    }

    pub fn intersect(&self, ray: &Ray) -> Option<Intersection> {
        let mut best = self.object.bvh.intersect(ray).map(|h| Intersection {
            t: h.t,
            surface: Surface::Object(self.object.mesh.surface(h.triangle, h.u, h.v)),
        });
        if let Some(panel) = self.panel {
            let mut r = *ray;
            if let Some(b) = &best {
                r.t_max = b.t;
            }
            if let Some(t) = panel.intersect(&r) {
                best = Some(Intersection {
                    t,
                    surface: Surface::Panel {
                        position: ray.at(t),
                    },
                });
            }
        }
        best
    }

    /// Only the object (for the random walk inside it).
    pub fn intersect_object(&self, ray: &Ray) -> Option<(f32, SurfacePoint)> {
        self.object
            .bvh
            .intersect(ray)
            .map(|h| (h.t, self.object.mesh.surface(h.triangle, h.u, h.v)))
    }

    /// Scale-relative offset distance at `p`.
    pub fn epsilon(&self, p: Vec3) -> f32 {
        let m = p.abs().max_element().max(self.magnitude).max(1e-3);
        if m.is_finite() {
            m / 32768.0
        } else {
            0.0
        }
    }

    /// `p` moved off its surface (normal `ng`) to the side of `dir`.
    pub fn offset(&self, p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
        let n = if dir.dot(ng) >= 0.0 { ng } else { -ng };
        offset_origin_scaled(p, n, self.magnitude)
    }

    /// Is the segment from `from` (already offset) to a point light at `to`
    /// blocked by the object or the panel?
    pub fn occluded_point(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let dist = d.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return true;
        }
        let ray = Ray::segment(from, d / dist, 0.0, dist);
        self.object.bvh.occluded(&ray) || self.panel.is_some_and(|p| p.intersect(&ray).is_some())
    }

    /// Is the segment from `from` (already offset) to a point on the panel
    /// blocked? The planar panel cannot block itself.
    pub fn occluded_panel_point(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let dist = d.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return true;
        }
        let end = dist - self.epsilon(to);
        if end <= 0.0 {
            return false;
        }
        self.object
            .bvh
            .occluded(&Ray::segment(from, d / dist, 0.0, end))
    }

    /// Is direction `dir` from `from` (already offset) blocked before
    /// reaching the environment?
    pub fn occluded_dir(&self, from: Vec3, dir: Vec3) -> bool {
        let ray = Ray::new(from, dir);
        self.object.bvh.occluded(&ray) || self.panel.is_some_and(|p| p.intersect(&ray).is_some())
    }
}
