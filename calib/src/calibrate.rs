//! Calibration of a whole scan: the maps of every position, the light
//! response and bad-light verdict of every position, and the
//! correspondences between every ordered pair of positions.
//!
//! Errors reading photos (missing, wrong size, unreadable) fail the whole
//! calibration. A missing white reference (no mask, no backlit capture) or
//! one with too few pixels only makes that position's light response
//! unavailable, with the error kept as the reason, since the contract lets
//! a scan lack every role but ambient.

use crate::bad_light::{bad_light, BadLight, BadLightOptions};
use crate::error::CalibError;
use crate::maps::{position_maps, PixelMaps};
use crate::photos::PhotoSource;
use crate::warp::{correspondence, Correspondence, WarpOptions};
use crate::white_reference::{white_reference, WhiteReference, WhiteReferenceOptions};
use matscan_scan::bvh::RayCaster;
use matscan_scan::{Bundle, Manifest};

#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CalibOptions {
    pub warp: WarpOptions,
    pub white_reference: WhiteReferenceOptions,
    pub bad_light: BadLightOptions,
}

/// Everything calibration knows about one position.
#[derive(Debug)]
pub struct PositionCalibration {
    pub maps: PixelMaps,
    /// The white reference's response per lit capture, or why there is none.
    pub light_response: Result<WhiteReference, CalibError>,
    pub bad_light: BadLight,
}

/// The calibration of a whole scan.
#[derive(Debug)]
pub struct ScanCalibration {
    /// In manifest order.
    pub positions: Vec<PositionCalibration>,
    /// One per ordered pair of distinct positions.
    pub correspondences: Vec<Correspondence>,
}

impl ScanCalibration {
    pub fn position(&self, name: &str) -> Option<&PositionCalibration> {
        self.positions.iter().find(|p| p.maps.position == name)
    }

    /// Where the pixels of `reference` are seen in `other`.
    pub fn correspondence(&self, reference: &str, other: &str) -> Option<&Correspondence> {
        self.correspondences
            .iter()
            .find(|c| c.reference == reference && c.other == other)
    }

    /// Positions with usable light, in manifest order.
    pub fn usable_positions(&self) -> impl Iterator<Item = &PositionCalibration> {
        self.positions.iter().filter(|p| !p.bad_light.is_bad())
    }
}

/// The maps of every position and the correspondences between them: the
/// geometry-only part of calibration (no photos needed).
pub fn geometry_maps(
    manifest: &Manifest,
    caster: &RayCaster,
    options: &WarpOptions,
) -> (Vec<PixelMaps>, Vec<Correspondence>) {
    let maps: Vec<PixelMaps> = manifest
        .positions
        .iter()
        .map(|p| position_maps(caster, &manifest.camera, p))
        .collect();
    let correspondences = correspondences(&maps, options);
    (maps, correspondences)
}

/// Correspondences for every ordered pair of distinct positions: n (n - 1)
/// maps of 9 bytes per pixel, cheap for the handful of positions a scan
/// has (use [`correspondence`] directly for a chosen pair on huge scans).
pub fn correspondences(maps: &[PixelMaps], options: &WarpOptions) -> Vec<Correspondence> {
    let mut out = Vec::new();
    for (i, reference) in maps.iter().enumerate() {
        for (j, other) in maps.iter().enumerate() {
            if i != j {
                out.push(correspondence(reference, other, options));
            }
        }
    }
    out
}

/// Calibrates a scan from its manifest, its mesh and its photos.
pub fn calibrate(
    manifest: &Manifest,
    caster: &RayCaster,
    source: &dyn PhotoSource,
    options: &CalibOptions,
) -> Result<ScanCalibration, CalibError> {
    if caster.mesh.triangles.is_empty() {
        return Err(CalibError::EmptyMesh);
    }
    let (maps, correspondences) = geometry_maps(manifest, caster, &options.warp);
    let mut positions = Vec::with_capacity(maps.len());
    for (position, maps) in manifest.positions.iter().zip(maps) {
        let light_response =
            match white_reference(&manifest.camera, position, source, &options.white_reference) {
                Err(
                    e @ (CalibError::NoWhiteReference { .. }
                    | CalibError::TooFewReferencePixels { .. }),
                ) => {
                    tracing::warn!("{e}");
                    Err(e)
                }
                other => Ok(other?),
            };
        let bad_light = bad_light(&manifest.camera, position, source, &options.bad_light)?;
        if let Some(reason) = bad_light.reason() {
            tracing::warn!("{reason}");
        }
        positions.push(PositionCalibration {
            maps,
            light_response,
            bad_light,
        });
    }
    Ok(ScanCalibration {
        positions,
        correspondences,
    })
}

/// Calibrates the scan bundle `bundle`: reads its mesh, builds the ray
/// caster and calibrates from its photos.
pub fn calibrate_bundle(
    bundle: &Bundle,
    options: &CalibOptions,
) -> Result<ScanCalibration, CalibError> {
    let caster = RayCaster::new(bundle.read_mesh()?);
    calibrate(&bundle.manifest, &caster, bundle, options)
}
