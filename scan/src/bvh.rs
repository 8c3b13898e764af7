//! Ray casting against a [`Mesh`]: closest hit and any-hit (shadows).
//!
//! PLACEHOLDER IMPLEMENTATION: brute force over all triangles, correct but
//! O(n). Being replaced by a SAH BVH.

use crate::mesh::Mesh;
use glam::Vec3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Unit length.
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    pub fn segment(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Self {
            origin,
            dir,
            t_min,
            t_max,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Closest intersection: distance along the ray, triangle, barycentrics
/// (point = (1-u-v) a + u b + v c).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

pub struct Bvh {
    triangles: Vec<[Vec3; 3]>,
}

impl Bvh {
    pub fn build(mesh: &Mesh) -> Self {
        Self {
            triangles: (0..mesh.triangle_count() as u32)
                .map(|t| mesh.triangle_vertices(t))
                .collect(),
        }
    }

    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut t_max = ray.t_max;
        for (i, tri) in self.triangles.iter().enumerate() {
            if let Some((t, u, v)) = intersect_triangle(ray, tri, t_max) {
                t_max = t;
                best = Some(Hit {
                    t,
                    triangle: i as u32,
                    u,
                    v,
                });
            }
        }
        best
    }

    pub fn occluded(&self, ray: &Ray) -> bool {
        self.triangles
            .iter()
            .any(|tri| intersect_triangle(ray, tri, ray.t_max).is_some())
    }
}

/// Möller–Trumbore, two-sided.
fn intersect_triangle(ray: &Ray, [a, b, c]: &[Vec3; 3], t_max: f32) -> Option<(f32, f32, f32)> {
    let e1 = *b - *a;
    let e2 = *c - *a;
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv = 1.0 / det;
    let s = ray.origin - *a;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > ray.t_min && t < t_max).then_some((t, u, v))
}
