//! All per-pixel maps of one position: geometry, every posed light, every
//! projector's pattern maps. This is what the networks see of the geometry
//! and calibration of a scan.

use crate::geometry::{position_geometry, PositionGeometry};
use crate::lights::{light_maps, LightMaps, LightSource};
use crate::projector::{projector_maps, ProjectorMaps};
use matscan_scan::bvh::RayCaster;
use matscan_scan::{Intrinsics, PinholeCamera, Position};

/// The maps of one position.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelMaps {
    /// The position's name in the manifest.
    pub position: String,
    pub camera: PinholeCamera,
    pub geometry: PositionGeometry,
    /// One entry per point light and projector, in manifest order.
    pub lights: Vec<LightMaps>,
    /// One entry per projector, in manifest order.
    pub projectors: Vec<ProjectorMaps>,
}

impl PixelMaps {
    pub fn light(&self, name: &str) -> Option<&LightMaps> {
        self.lights.iter().find(|l| l.light == name)
    }

    pub fn projector(&self, name: &str) -> Option<&ProjectorMaps> {
        self.projectors.iter().find(|p| p.light == name)
    }
}

/// Computes every map of `position` seen through `intrinsics`.
pub fn position_maps(
    caster: &RayCaster,
    intrinsics: &Intrinsics,
    position: &Position,
) -> PixelMaps {
    let camera = PinholeCamera::new(*intrinsics, position.camera_to_world);
    let geometry = position_geometry(caster, &camera);
    let lights: Vec<LightMaps> = position
        .lights
        .iter()
        .filter_map(|l| LightSource::of(l).map(|s| (l, s)))
        .map(|(l, source)| {
            light_maps(
                caster,
                &position.camera_to_world,
                &geometry,
                &l.name,
                source,
            )
        })
        .collect();
    let projectors = lights
        .iter()
        .filter_map(|m| projector_maps(position, m, &geometry.position))
        .collect();
    PixelMaps {
        position: position.name.clone(),
        camera,
        geometry,
        lights,
        projectors,
    }
}
