//! Per-light maps of one position: light vector, distance, the BRDF angle
//! cosines NL and VL (eqs. 3.2, 3.4) and whether the light reaches each
//! surface point (the shadow mask, from the known geometry).
//!
//! Lights with a pose get maps: point lights (to their position) and
//! projectors (to their centre of projection). The backlight panel has no
//! pose and gets none. Vectors are unit, in the camera frame of the
//! position (like `geometry`'s normal and view); distances in world units.
//!
//! A point is `lit` when the light is in front of the surface (both the
//! geometric and the shading normal face it), the segment to the light is
//! free of geometry and, for a projector, the point lies inside the
//! projector's image. Cosines keep their sign (a light behind the surface
//! gives `cos_nl < 0`, clamped to [-1, 1]), and `lit` flags it.
//! Background pixels: every map 0, `lit` false.

use crate::angles::{cos_between, cos_vl};
use crate::geometry::{to_f32, to_f64, PositionGeometry};
use crate::par::par_raster;
use glam::{DMat4, DVec3};
use matscan_scan::bvh::RayCaster;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::{Intrinsics, Light, LightKind, PinholeCamera};

/// Where a light sits and how far it shines.
#[derive(Debug, Clone, PartialEq)]
pub enum LightSource {
    Point(DVec3),
    /// A pinhole projector: it lights only what falls inside its image.
    Projector(Box<PinholeCamera>),
}

impl LightSource {
    /// The source of a rig light; `None` for the pose-less backlight.
    pub fn of(light: &Light) -> Option<Self> {
        match light.kind {
            LightKind::Point { position } => Some(LightSource::Point(position)),
            LightKind::Projector {
                projector_to_world,
                intrinsics,
            } => Some(LightSource::Projector(Box::new(PinholeCamera::new(
                intrinsics,
                projector_to_world,
            )))),
            LightKind::Backlight => None,
        }
    }

    /// World position of the light (a projector's centre of projection).
    pub fn position(&self) -> DVec3 {
        match self {
            LightSource::Point(p) => *p,
            LightSource::Projector(cam) => cam.center(),
        }
    }

    /// Continuous projector pixel coordinates of a world point, when the
    /// point lies inside the projector's image; always `None` for a point
    /// light.
    pub fn projector_pixel(&self, world: DVec3) -> Option<glam::DVec2> {
        let LightSource::Projector(cam) = self else {
            return None;
        };
        let Intrinsics { width, height, .. } = cam.intrinsics;
        cam.project(world).filter(|q| {
            q.is_finite()
                && q.x >= 0.0
                && q.y >= 0.0
                && q.x < f64::from(width)
                && q.y < f64::from(height)
        })
    }

    fn covers(&self, world: DVec3) -> bool {
        match self {
            LightSource::Point(_) => true,
            LightSource::Projector(_) => self.projector_pixel(world).is_some(),
        }
    }
}

/// The maps of one light at one position.
#[derive(Debug, Clone, PartialEq)]
pub struct LightMaps {
    /// The light's name in the manifest.
    pub light: String,
    pub source: LightSource,
    /// Unit vector from the surface point to the light, camera frame.
    pub direction: RgbRaster,
    /// Distance from the surface point to the light, world units.
    pub distance: ScalarRaster,
    /// Eq. 3.2 with the shading normal.
    pub cos_nl: ScalarRaster,
    /// Eq. 3.4 (see [`crate::angles::cos_vl`] for the pole).
    pub cos_vl: ScalarRaster,
    /// The light reaches the point (front side, unoccluded, inside a
    /// projector's image).
    pub lit: MaskRaster,
}

impl LightMaps {
    /// 1 where an object pixel is in this light's shadow (or faces away
    /// from it), 0 where it is lit and on the background.
    pub fn shadow(&self, mask: &MaskRaster) -> ScalarRaster {
        let mut out = mask.map(|&m| if m { 1.0 } else { 0.0 });
        for (o, &lit) in out.data.iter_mut().zip(&self.lit.data) {
            if lit {
                *o = 0.0;
            }
        }
        out
    }
}

#[derive(Clone, Copy, Default)]
struct PixelLight {
    direction: [f32; 3],
    distance: f32,
    cos_nl: f32,
    cos_vl: f32,
    lit: bool,
}

/// The maps of one light, given the geometry of the position that sees it.
pub fn light_maps(
    caster: &RayCaster,
    camera_to_world: &DMat4,
    geometry: &PositionGeometry,
    light: &str,
    source: LightSource,
) -> LightMaps {
    let world_to_camera = camera_to_world.inverse();
    let light_world = source.position();
    let light_cam = world_to_camera.transform_point3(light_world);
    let pixels = par_raster(geometry.width(), geometry.height(), |x, y| {
        if !*geometry.mask.get(x, y) {
            return PixelLight::default();
        }
        let p_world = to_f64(geometry.position.get(x, y));
        let p_cam = world_to_camera.transform_point3(p_world);
        let ns = to_f64(geometry.normal.get(x, y));
        let ng = to_f64(geometry.geometric_normal.get(x, y));
        let view = to_f64(geometry.view.get(x, y));
        let to_light = light_cam - p_cam;
        let distance = to_light.length();
        let Some(l) = to_light.try_normalize() else {
            // The light sits on the surface: no direction, nothing lit.
            return PixelLight::default();
        };
        let facing = ng.dot(l) > 0.0 && ns.dot(l) > 0.0;
        let lit = facing
            && source.covers(p_world)
            && caster.visible(
                caster.offset(
                    p_world.as_vec3(),
                    camera_to_world.transform_vector3(ng).as_vec3(),
                ),
                light_world.as_vec3(),
            );
        PixelLight {
            direction: to_f32(l),
            distance: distance as f32,
            cos_nl: cos_between(ns, l) as f32,
            cos_vl: cos_vl(ns, view, l) as f32,
            lit,
        }
    });
    LightMaps {
        light: light.to_string(),
        source,
        direction: pixels.map(|p| p.direction),
        distance: pixels.map(|p| p.distance),
        cos_nl: pixels.map(|p| p.cos_nl),
        cos_vl: pixels.map(|p| p.cos_vl),
        lit: pixels.map(|p| p.lit),
    }
}
