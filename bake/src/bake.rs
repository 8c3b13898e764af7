//! The baker's entry points: [`bake_maps`] (any per-position maps, e.g. a
//! simulated scan's truth), [`bake_scan`] (a scan's `estimate/` folder)
//! and [`bake_truth`] (a simulated scan's `truth/` folder). [`bake_maps`]
//! and [`bake_bundle`] take the scan's calibration where the caller has it,
//! so the position maps are not computed again.
//!
//! Steps: rasterize the UV atlas ([`crate::atlas`]), prepare each position
//! ([`crate::views`]), fuse ([`crate::fuse`]), fill holes per parameter
//! ([`crate::pushpull`]); the coverage map is the fusion's.

use crate::atlas::Atlas;
use crate::error::BakeError;
use crate::fuse::{fuse, FuseOptions};
use crate::maps::BakeInput;
use crate::pushpull::push_pull;
use crate::textures::BakedTextures;
use crate::views::PositionView;
use matscan_calib::ScanCalibration;
use matscan_scan::bvh::RayCaster;
use matscan_scan::estimate_maps::{read_position_maps, ParamMap, PositionMaps};
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::{Bundle, Param};
use std::path::Path;

/// Default texture side, texels.
pub const DEFAULT_SIZE: u32 = 2048;
/// Largest texture side accepted (16 bytes a texel and parameter of
/// working memory: 8192^2 is already about 5 GB for all five).
pub const MAX_SIZE: u32 = 8192;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BakeOptions {
    /// Side of the square textures, texels.
    pub size: u32,
    /// Gutter around each UV chart, texels.
    pub gutter: u32,
    pub fuse: FuseOptions,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            size: DEFAULT_SIZE,
            gutter: 2,
            fuse: FuseOptions::default(),
        }
    }
}

/// Bakes `positions` (each position's maps in its camera image) into the
/// UV textures of `bundle`'s mesh. Parameters no position has are left
/// out of the result. `calibration`, the scan's where the caller already
/// made it, lends its per-position pixel maps (the same maps the baker
/// would compute; positions it lacks are computed).
pub fn bake_maps(
    bundle: &Bundle,
    positions: &[BakeInput],
    calibration: Option<&ScanCalibration>,
    options: &BakeOptions,
) -> Result<BakedTextures, BakeError> {
    if options.size == 0 || options.size > MAX_SIZE {
        return Err(BakeError::InvalidOption {
            what: "size",
            message: format!("{} texels; expected 1 to {MAX_SIZE}", options.size),
        });
    }
    let mesh = bundle.read_mesh()?;
    let Some(uvs) = mesh.uvs.clone() else {
        return Err(BakeError::NoUvs {
            mesh: bundle.mesh_path(),
        });
    };
    let slots: Vec<Param> = Param::ALL
        .into_iter()
        .filter(|p| {
            positions
                .iter()
                .any(|pm| pm.position_maps.get(*p).is_some())
        })
        .collect();
    if slots.is_empty() {
        return Err(BakeError::NothingToBake {
            path: bundle.root.clone(),
            message: "no position has any parameter map to bake".into(),
        });
    }
    let channels: Vec<usize> = slots.iter().map(|p| p.channels()).collect();
    let caster = RayCaster::new(mesh);
    let manifest_path = bundle.manifest_path();
    let views = positions
        .iter()
        .map(|p| {
            let calibrated = calibration
                .and_then(|c| c.position(&p.position_maps.position))
                .map(|c| &c.maps);
            PositionView::prepare(
                &bundle.manifest,
                &manifest_path,
                &caster,
                p,
                &slots,
                calibrated,
            )
        })
        .collect::<Result<Vec<_>, _>>()?;
    let size = options.size;
    let atlas = Atlas::rasterize(&caster.mesh, &uvs, size, size, options.gutter);
    let fused = fuse(&atlas, &caster, &uvs, &views, &channels, &options.fuse);
    let n = size as usize;
    let coverage = MaskRaster {
        width: size,
        height: size,
        data: fused.coverage,
    };
    let mut textures = BakedTextures::new(coverage);
    let filled: Vec<(Param, Vec<f32>)> = {
        use rayon::prelude::*;
        slots
            .par_iter()
            .zip(
                fused
                    .sums
                    .into_par_iter()
                    .zip(fused.weights.into_par_iter()),
            )
            .map(|(&param, (mut sums, weights))| {
                let c = param.channels();
                for (texel, &w) in sums.chunks_mut(c).zip(&weights) {
                    if w > 0.0 {
                        texel.iter_mut().for_each(|v| *v /= w);
                    }
                }
                push_pull(&mut sums, &weights, n, n, c, &[0.0; 3][..c]);
                (param, sums)
            })
            .collect()
    };
    for (param, data) in filled {
        if param == Param::Basecolor {
            let data = data.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
            textures.set_basecolor(RgbRaster {
                width: size,
                height: size,
                data,
            })?;
        } else {
            textures.set_scalar(
                param,
                ScalarRaster {
                    width: size,
                    height: size,
                    data,
                },
            )?;
        }
    }
    Ok(textures)
}

/// Bakes the estimate in `estimate_dir` (normally `<scan>/estimate`): every
/// manifest position with at least one `<position>/<param>.exr`, with
/// `<param>_confidence.exr` where present and the position's
/// `views/<position>/mask.png` where the scan has one.
pub fn bake_scan(
    scan_dir: &Path,
    estimate_dir: &Path,
    options: &BakeOptions,
) -> Result<BakedTextures, BakeError> {
    bake_bundle(&Bundle::open(scan_dir)?, estimate_dir, None, options)
}

/// [`bake_scan`] of a bundle already open, with its calibration where the
/// caller has it (see [`bake_maps`]).
pub fn bake_bundle(
    bundle: &Bundle,
    estimate_dir: &Path,
    calibration: Option<&ScanCalibration>,
    options: &BakeOptions,
) -> Result<BakedTextures, BakeError> {
    if !estimate_dir.is_dir() {
        return Err(BakeError::NothingToBake {
            path: estimate_dir.to_path_buf(),
            message: "no estimate folder; run `matscan estimate` on the scan first".into(),
        });
    }
    let positions = read_estimate_maps(bundle, estimate_dir)?;
    if positions.is_empty() {
        return Err(BakeError::NothingToBake {
            path: estimate_dir.to_path_buf(),
            message: "no position folder holds parameter maps (<position>/<param>.exr); \
                      run `matscan estimate` on the scan first"
                .into(),
        });
    }
    bake_maps(bundle, &positions, calibration, options)
}

/// Reads every position's estimate maps from `estimate_dir`.
pub fn read_estimate_maps(
    bundle: &Bundle,
    estimate_dir: &Path,
) -> Result<Vec<BakeInput>, BakeError> {
    let mut out = Vec::new();
    for position in &bundle.manifest.positions {
        if let Some(position_maps) = read_position_maps(estimate_dir, &position.name)? {
            out.push(BakeInput {
                position_maps,
                mask: bundle.read_mask(&position.name)?,
            });
        }
    }
    Ok(out)
}

/// Reads every position's truth maps of a simulated scan (with the truth
/// mask); positions without truth are left out.
pub fn read_truth_maps(bundle: &Bundle) -> Result<Vec<BakeInput>, BakeError> {
    let mut out = Vec::new();
    for position in &bundle.manifest.positions {
        let name = &position.name;
        let mut maps = Vec::new();
        for param in Param::ALL {
            if let Some(values) = bundle.truth_param(name, param)? {
                maps.push(ParamMap::new(param, values)?);
            }
        }
        if maps.is_empty() {
            continue;
        }
        let mask = bundle.truth_mask(name)?;
        out.push(BakeInput {
            position_maps: PositionMaps {
                position: name.clone(),
                maps,
            },
            mask,
        });
    }
    Ok(out)
}

/// Bakes a simulated scan's truth maps exactly as an estimate would be
/// baked: the "true textures" to compare baked estimates against.
pub fn bake_truth(bundle: &Bundle, options: &BakeOptions) -> Result<BakedTextures, BakeError> {
    let positions = read_truth_maps(bundle)?;
    if positions.is_empty() {
        return Err(BakeError::NothingToBake {
            path: bundle.root.join("truth"),
            message: "no truth maps (simulated scans only)".into(),
        });
    }
    bake_maps(bundle, &positions, None, options)
}
