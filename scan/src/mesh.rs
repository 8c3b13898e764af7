//! Triangle meshes in world space, and the surface data at a ray hit.
//!
//! Positions are f32: the ray-casting hot path works in f32, which keeps
//! relative precision for scenes from 1e-3 to 1e3 units (hits are offset by
//! a scale-relative epsilon, see [`crate::bvh`]).
//!
//! Boundaries: plain data plus the checks ([`Mesh::validate`]) every reader
//! and writer applies; file formats live in [`crate::mesh_io`], ray casting
//! in [`crate::bvh`].

use glam::{Vec2, Vec3};

/// Why a [`Mesh`] cannot be used: the one list of structural checks shared
/// by the readers, the writers and code that builds meshes itself.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MeshDefect {
    #[error("the mesh has no triangles")]
    NoTriangles,
    #[error("triangle {triangle} refers to vertex {index}, but there are {vertex_count} vertices")]
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertex_count: usize,
    },
    #[error("vertex {vertex} has a non-finite position")]
    NonFinitePosition { vertex: usize },
    /// Zero-length normals are allowed (shading falls back to the geometric
    /// normal); NaN or infinite ones are not.
    #[error("vertex {vertex} has a NaN or infinite normal")]
    NonFiniteNormal { vertex: usize },
    #[error("vertex {vertex} has a NaN or infinite texture coordinate")]
    NonFiniteUv { vertex: usize },
    #[error("{what} has {len} entries but there are {vertex_count} vertices")]
    LengthMismatch {
        what: &'static str,
        len: usize,
        vertex_count: usize,
    },
}

#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (same length as `positions`) or none.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, origin bottom left, or none.
    pub uvs: Option<Vec<Vec2>>,
    /// Counter-clockwise triangles (seen from outside) indexing `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// What a ray hit: everything calibration and shading need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit geometric normal of the triangle (from its winding).
    pub geometric_normal: Vec3,
    /// Unit interpolated shading normal; falls back to the geometric normal
    /// where the mesh has no normals or they interpolate to zero length.
    pub shading_normal: Vec3,
    pub uv: Option<Vec2>,
    pub triangle: u32,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    pub fn triangle_vertices(&self, t: u32) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[t as usize];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Unit geometric normal of triangle `t`; +Z for a degenerate triangle
    /// (never NaN).
    pub fn geometric_normal(&self, t: u32) -> Vec3 {
        let [a, b, c] = self.triangle_vertices(t);
        (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::Z)
    }

    /// Surface data at barycentrics (`u`, `v`) of triangle `t`, where the
    /// point is `(1-u-v) a + u b + v c`.
    pub fn surface(&self, t: u32, u: f32, v: f32) -> SurfacePoint {
        let [ia, ib, ic] = self.triangles[t as usize];
        let w = 1.0 - u - v;
        let [a, b, c] = self.triangle_vertices(t);
        let position = a * w + b * u + c * v;
        let geometric_normal = self.geometric_normal(t);
        let shading_normal = self
            .normals
            .as_ref()
            .and_then(|n| {
                (n[ia as usize] * w + n[ib as usize] * u + n[ic as usize] * v).try_normalize()
            })
            .unwrap_or(geometric_normal);
        let uv = self
            .uvs
            .as_ref()
            .map(|t| t[ia as usize] * w + t[ib as usize] * u + t[ic as usize] * v);
        SurfacePoint {
            position,
            geometric_normal,
            shading_normal,
            uv,
            triangle: t,
        }
    }

    /// Axis-aligned bounds `(min, max)`; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(
            self.positions
                .iter()
                .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p))),
        )
    }

    /// Checks what every consumer relies on: at least one triangle, indices
    /// in range, per-vertex attributes of the right length, finite values.
    pub fn validate(&self) -> Result<(), MeshDefect> {
        let vertex_count = self.positions.len();
        if self.triangles.is_empty() {
            return Err(MeshDefect::NoTriangles);
        }
        for (what, len) in [
            ("normals", self.normals.as_ref().map(Vec::len)),
            ("uvs", self.uvs.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&len| len != vertex_count) {
                return Err(MeshDefect::LengthMismatch {
                    what,
                    len,
                    vertex_count,
                });
            }
        }
        if let Some(vertex) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshDefect::NonFinitePosition { vertex });
        }
        if let Some(vertex) = self.normals.iter().flatten().position(|n| !n.is_finite()) {
            return Err(MeshDefect::NonFiniteNormal { vertex });
        }
        if let Some(vertex) = self.uvs.iter().flatten().position(|t| !t.is_finite()) {
            return Err(MeshDefect::NonFiniteUv { vertex });
        }
        for (triangle, tri) in self.triangles.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(MeshDefect::IndexOutOfRange {
                    triangle,
                    index,
                    vertex_count,
                });
            }
        }
        Ok(())
    }

    /// Area-weighted vertex normals from the triangles, replacing any present.
    pub fn compute_vertex_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for tri in &self.triangles {
            let [a, b, c] = tri.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in tri {
                acc[i as usize] += n;
            }
        }
        self.normals = Some(
            acc.into_iter()
                .map(|n| n.try_normalize().unwrap_or(Vec3::Z))
                .collect(),
        );
    }
}
