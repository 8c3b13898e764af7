//! Per-pixel geometry of one position: ray-cast the mesh through the camera
//! model (distortion included) at every pixel centre.
//!
//! Frames: `position` is in world space (the thesis's global position map,
//! the same value for a point seen from any position); `normal`,
//! `geometric_normal` and `view` are unit vectors in that position's camera
//! frame (OpenCV: x right, y down, z forward), as the thesis gives its
//! networks vectors "in the camera-space pointing from the object to the
//! camera". `depth` is the camera-frame z of the hit (not the ray length).
//!
//! Normals face the camera: the geometric normal is flipped to the camera's
//! side, and the shading normal onto the geometric normal's side, so the
//! mesh's winding (or thin two-sided sheets seen from behind) does not
//! matter. The shading normal can still face slightly away from the camera
//! near silhouettes (`cos_nv < 0` there), as interpolated normals do.
//!
//! Background pixels (no hit): `mask` false and every other map 0.

use crate::angles::cos_between;
use crate::par::par_raster;
use glam::{DVec3, Vec2};
use matscan_scan::bvh::RayCaster;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::{PinholeCamera, Raster};

/// The ray-cast maps of one position, all of the camera's size.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionGeometry {
    /// True where a camera ray hits the mesh.
    pub mask: MaskRaster,
    /// World-space hit point.
    pub position: RgbRaster,
    /// Unit shading normal (interpolated), camera frame, on the camera side.
    pub normal: RgbRaster,
    /// Unit triangle normal, camera frame, facing the camera.
    pub geometric_normal: RgbRaster,
    /// Camera-frame z of the hit point, in world units.
    pub depth: ScalarRaster,
    /// Unit vector from the surface point to the camera centre, camera frame.
    pub view: RgbRaster,
    /// Eq. 3.3: cosine between the shading normal and the view vector.
    pub cos_nv: ScalarRaster,
    /// Texture coordinates (origin bottom left) where the mesh has them.
    pub uv: Option<Raster<[f32; 2]>>,
}

#[derive(Clone, Copy, Default)]
struct PixelGeometry {
    hit: bool,
    position: [f32; 3],
    normal: [f32; 3],
    geometric_normal: [f32; 3],
    depth: f32,
    view: [f32; 3],
    cos_nv: f32,
    uv: [f32; 2],
}

pub(crate) fn to_f32(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

pub(crate) fn to_f64(v: &[f32; 3]) -> DVec3 {
    DVec3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]))
}

/// Ray-casts every pixel centre of `camera` against the mesh of `caster`.
pub fn position_geometry(caster: &RayCaster, camera: &PinholeCamera) -> PositionGeometry {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let world_to_camera = camera.world_to_camera();
    let pixels = par_raster(w, h, |x, y| {
        let ray = camera.pixel_ray(x, y);
        let Some(sp) = caster.closest(&ray).map(|(_, sp)| sp) else {
            return PixelGeometry::default();
        };
        let p_world = sp.position.as_dvec3();
        let p_cam = world_to_camera.transform_point3(p_world);
        let Some(view) = (-p_cam).try_normalize() else {
            return PixelGeometry::default();
        };
        let to_cam = |n: glam::Vec3| {
            world_to_camera
                .transform_vector3(n.as_dvec3())
                .try_normalize()
                .unwrap_or(view)
        };
        let mut ng = to_cam(sp.geometric_normal);
        if ng.dot(view) < 0.0 {
            ng = -ng;
        }
        let mut ns = to_cam(sp.shading_normal);
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        PixelGeometry {
            hit: true,
            position: sp.position.to_array(),
            normal: to_f32(ns),
            geometric_normal: to_f32(ng),
            depth: p_cam.z as f32,
            view: to_f32(view),
            cos_nv: cos_between(ns, view) as f32,
            uv: sp
                .uv
                .filter(|uv| uv.is_finite())
                .unwrap_or(Vec2::ZERO)
                .to_array(),
        }
    });
    PositionGeometry {
        mask: pixels.map(|p| p.hit),
        position: pixels.map(|p| p.position),
        normal: pixels.map(|p| p.normal),
        geometric_normal: pixels.map(|p| p.geometric_normal),
        depth: pixels.map(|p| p.depth),
        view: pixels.map(|p| p.view),
        cos_nv: pixels.map(|p| p.cos_nv),
        uv: caster.mesh.uvs.is_some().then(|| pixels.map(|p| p.uv)),
    }
}

impl PositionGeometry {
    pub fn width(&self) -> u32 {
        self.mask.width
    }

    pub fn height(&self) -> u32 {
        self.mask.height
    }

    /// Number of object pixels.
    pub fn object_pixels(&self) -> usize {
        self.mask.data.iter().filter(|&&m| m).count()
    }
}
