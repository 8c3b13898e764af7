//! The shading frame at one point for one outgoing direction: sanitizes the
//! normals, flips them toward `wo` when the surface is hit from behind (as
//! Cycles does for back-facing hits), bends the shading normal so that the
//! mirror reflection of `wo` stays above the geometric surface (Cycles'
//! `ensure_valid_reflection`), and converts between world and local space.
//! Knows nothing of lobes.

use glam::Vec3;

/// |cos| against the geometric normal below which `wo` counts as lying in the
/// surface plane (then nothing is reflected or transmitted).
const PLANE_COS: f32 = 1e-7;

/// Unit shading and geometric normals of a point, repaired once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SurfaceNormals {
    n: Vec3,
    ng: Vec3,
}

impl SurfaceNormals {
    /// Normalizes both; a zero or non-finite one is replaced by the other, and
    /// both by +Z when neither is usable. A shading normal on the far side of
    /// the geometric one (dot <= 0, e.g. a broken normal map or a flipped
    /// vertex normal) is replaced by the geometric normal: Cycles would shade
    /// such a point black, we shade it as flat instead.
    pub fn new(n: Vec3, ng: Vec3) -> SurfaceNormals {
        let n = n.normalize_or_zero();
        let ng = ng.normalize_or_zero();
        let (n, ng) = match (n == Vec3::ZERO, ng == Vec3::ZERO) {
            (false, false) => (n, ng),
            (true, false) => (ng, ng),
            (false, true) => (n, n),
            (true, true) => (Vec3::Z, Vec3::Z),
        };
        let n = if n.dot(ng) > 1e-4 { n } else { ng };
        SurfaceNormals { n, ng }
    }

    pub fn shading(&self) -> Vec3 {
        self.n
    }

    #[cfg(test)]
    pub fn geometric(&self) -> Vec3 {
        self.ng
    }

    /// The frame seen from the unit direction `wo`, or None when `wo` lies in
    /// the surface plane or is not finite.
    pub fn frame(&self, wo: Vec3) -> Option<ShadingFrame> {
        let cos_g = self.ng.dot(wo);
        if cos_g.is_nan() || cos_g.abs() <= PLANE_COS {
            return None;
        }
        let backfacing = cos_g < 0.0;
        let (n, ng) = if backfacing {
            (-self.n, -self.ng)
        } else {
            (self.n, self.ng)
        };
        let n = ensure_valid_reflection(ng, wo, n);
        let (t, b) = n.any_orthonormal_pair();
        let frame = ShadingFrame {
            t,
            b,
            n,
            ng,
            backfacing,
        };
        let wo_local = frame.to_local(wo);
        if wo_local.z.is_nan() || wo_local.z <= 0.0 {
            return None;
        }
        Some(frame)
    }
}

/// Orthonormal frame around the (possibly flipped and bent) shading normal,
/// with the geometric normal on the same side as `wo`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ShadingFrame {
    t: Vec3,
    b: Vec3,
    n: Vec3,
    ng: Vec3,
    backfacing: bool,
}

impl ShadingFrame {
    pub fn to_local(self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    pub fn to_world(self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// Cosine of a world direction against the geometric normal facing `wo`:
    /// positive on the reflection side, negative on the transmission side.
    pub fn geometric_cos(&self, w: Vec3) -> f32 {
        self.ng.dot(w)
    }

    /// True when `wo` came from behind the authored normals (inside a closed
    /// object): transmission then refracts with the inverse IOR.
    pub fn backfacing(&self) -> bool {
        self.backfacing
    }
}

/// Cycles' `ensure_valid_reflection`: returns a shading normal, as close to
/// `n` as possible, whose mirror reflection of `i` lies above the geometric
/// surface by a small margin. All vectors unit, `i` above `ng`.
fn ensure_valid_reflection(ng: Vec3, i: Vec3, n: Vec3) -> Vec3 {
    let r = 2.0 * n.dot(i) * n - i;
    // Reflections may always be at least as shallow as the incoming ray.
    let threshold = (0.9 * ng.dot(i)).min(0.01);
    if ng.dot(r) >= threshold {
        return n;
    }
    // Frame with ng as z and n in the x-z plane.
    let x = (n - n.dot(ng) * ng).normalize_or_zero();
    if x == Vec3::ZERO {
        return ng;
    }
    let ix = i.dot(x);
    let iz = i.dot(ng);
    let ix2 = ix * ix;
    let iz2 = iz * iz;
    let a = ix2 + iz2;
    if a.is_nan() || a <= 0.0 {
        return ng;
    }
    let b = (ix2 * (a - threshold * threshold)).max(0.0).sqrt();
    let c = iz * threshold + a;
    let fac = 0.5 / a;
    let n1_z2 = fac * (b + c);
    let n2_z2 = fac * (c - b);
    let plausible = |z2: f32| z2 > 1e-5 && z2 <= 1.0 + 1e-5;
    let to_xz = |z2: f32| ((1.0 - z2).max(0.0).sqrt(), z2.max(0.0).sqrt());
    let (nx, nz) = match (plausible(n1_z2), plausible(n2_z2)) {
        (true, true) => {
            let n1 = to_xz(n1_z2);
            let n2 = to_xz(n2_z2);
            let r1 = 2.0 * (n1.0 * ix + n1.1 * iz) * n1.1 - iz;
            let r2 = 2.0 * (n2.0 * ix + n2.1 * iz) * n2.1 - iz;
            if r1 >= 1e-5 && r2 >= 1e-5 {
                // Both valid: the shallower reflection is closer to the input.
                if r1 < r2 {
                    n1
                } else {
                    n2
                }
            } else if r1 > r2 {
                n1
            } else {
                n2
            }
        }
        (true, false) => to_xz(n1_z2),
        (false, true) => to_xz(n2_z2),
        (false, false) => return ng,
    };
    (nx * x + nz * ng).normalize_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_normals_fall_back_to_usable_ones() {
        let up = Vec3::Z;
        assert_eq!(SurfaceNormals::new(Vec3::ZERO, up * 3.0).shading(), up);
        assert_eq!(SurfaceNormals::new(Vec3::splat(f32::NAN), up).shading(), up);
        assert_eq!(SurfaceNormals::new(up * 0.1, Vec3::ZERO).geometric(), up);
        assert_eq!(SurfaceNormals::new(Vec3::ZERO, Vec3::ZERO).shading(), up);
        assert_eq!(SurfaceNormals::new(-up, up).shading(), up);
    }

    #[test]
    fn backfacing_flips_both_normals_toward_wo() {
        let normals = SurfaceNormals::new(Vec3::Z, Vec3::Z);
        let wo = Vec3::new(0.3, 0.0, -0.9).normalize();
        let frame = normals.frame(wo).unwrap();
        assert!(frame.backfacing());
        assert!(frame.geometric_cos(wo) > 0.0);
        assert!((frame.to_local(wo).z - 0.9 / 0.9_f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn wo_in_the_surface_plane_or_nan_has_no_frame() {
        let normals = SurfaceNormals::new(Vec3::Z, Vec3::Z);
        assert!(normals.frame(Vec3::X).is_none());
        assert!(normals.frame(Vec3::splat(f32::NAN)).is_none());
    }

    #[test]
    fn bent_normal_reflects_wo_above_the_geometric_surface() {
        // Shading normal tilted far from the geometric one, wo grazing on the
        // side where the plain mirror reflection would go below the surface.
        let ng = Vec3::Z;
        let n = Vec3::new(0.8, 0.0, 0.6);
        let wo = Vec3::new(-0.2, 0.0, 0.1).normalize();
        assert!(ng.dot(2.0 * n.dot(wo) * n - wo) < 0.0);
        let frame = SurfaceNormals::new(n, ng).frame(wo).unwrap();
        let bent = frame.to_world(Vec3::Z);
        let r = 2.0 * bent.dot(wo) * bent - wo;
        assert!(ng.dot(r) >= 0.009, "{}", ng.dot(r));
        assert!((bent.length() - 1.0).abs() < 1e-5);
        assert!(frame.to_local(wo).z > 0.0);
    }

    #[test]
    fn local_and_world_round_trip() {
        let normals = SurfaceNormals::new(Vec3::new(0.1, 0.2, 0.9), Vec3::Z);
        let wo = Vec3::new(0.0, 0.5, 0.8).normalize();
        let frame = normals.frame(wo).unwrap();
        let v = Vec3::new(0.3, -0.4, 0.5);
        assert!((frame.to_world(frame.to_local(v)) - v).length() < 1e-6);
    }
}
