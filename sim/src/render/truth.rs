//! Ground-truth maps of a position: the material at the object's primary
//! hit through each pixel centre (the contract's camera, so they line up
//! pixel-exactly with the photos and the mask).
//!
//! Values follow the contract: basecolor as authored (this material model
//! has no separate subsurface colour, so the "mixed subsurface basecolor"
//! is the basecolor itself), roughness and metallic as authored,
//! transmission and subsurface effective (`Material::effective_*`).
//! Pixels off the object hold 0 and are false in `mask`.

use super::world::{Surface, World};
use crate::scene::MaterialField;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::PinholeCamera;
use rayon::prelude::*;

#[derive(Debug, Clone)]
pub struct TruthMaps {
    pub basecolor: RgbRaster,
    pub roughness: ScalarRaster,
    pub metallic: ScalarRaster,
    pub transmission: ScalarRaster,
    pub subsurface: ScalarRaster,
    /// The object is hit through the pixel centre.
    pub mask: MaskRaster,
}

/// Truth at one pixel where the object is hit.
#[derive(Debug, Clone, Copy)]
struct Texel {
    basecolor: [f32; 3],
    roughness: f32,
    metallic: f32,
    transmission: f32,
    subsurface: f32,
}

pub fn render_truth(world: &World, camera: &PinholeCamera, field: &MaterialField) -> TruthMaps {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let texels: Vec<Option<Texel>> = (0..w as usize * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
            let hit = world.intersect(&camera.pixel_ray(x, y))?;
            let Surface::Object(sp) = hit.surface else {
                return None;
            };
            let m = field.at(&sp);
            Some(Texel {
                basecolor: m.basecolor.to_array(),
                roughness: m.roughness,
                metallic: m.metallic,
                transmission: m.effective_transmission(),
                subsurface: m.effective_subsurface(),
            })
        })
        .collect();
    let scalar = |f: fn(&Texel) -> f32| {
        ScalarRaster::from_fn(w, h, |x, y| {
            texels[y as usize * w as usize + x as usize]
                .as_ref()
                .map_or(0.0, f)
        })
    };
    TruthMaps {
        basecolor: RgbRaster::from_fn(w, h, |x, y| {
            texels[y as usize * w as usize + x as usize].map_or([0.0; 3], |t| t.basecolor)
        }),
        roughness: scalar(|t| t.roughness),
        metallic: scalar(|t| t.metallic),
        transmission: scalar(|t| t.transmission),
        subsurface: scalar(|t| t.subsurface),
        mask: MaskRaster::from_fn(w, h, |x, y| {
            texels[y as usize * w as usize + x as usize].is_some()
        }),
    }
}

/// Pixels whose centre sees the front of the backlight panel first: the
/// white diffuse reference of the switched-off panel.
pub fn render_panel_mask(world: &World, camera: &PinholeCamera) -> MaskRaster {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let front = world.panel.map(|p| p.front);
    let hits: Vec<bool> = (0..w as usize * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
            let ray = camera.pixel_ray(x, y);
            match (world.intersect(&ray), front) {
                (Some(hit), Some(n)) => {
                    matches!(hit.surface, Surface::Panel { .. }) && ray.dir.dot(n) < 0.0
                }
                _ => false,
            }
        })
        .collect();
    MaskRaster::from_fn(w, h, |x, y| hits[y as usize * w as usize + x as usize])
}
