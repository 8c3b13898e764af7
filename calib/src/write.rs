//! Writes a calibration's maps as float EXR files, one folder per position,
//! plus `calib.json` (the [`crate::summary::CalibSummary`]) at the top:
//!
//! ```text
//! <out>/calib.json
//! <out>/<position>/mask.exr            1 on the object, 0 elsewhere
//! <out>/<position>/position.exr        world xyz
//! <out>/<position>/normal.exr          camera frame
//! <out>/<position>/depth.exr           camera z
//! <out>/<position>/view.exr            camera frame, to the camera
//! <out>/<position>/cos_nv.exr
//! <out>/<position>/uv.exr              u, v, 0 (where the mesh has UVs)
//! <out>/<position>/light_<light>.exr   camera frame, to the light
//! <out>/<position>/distance_<light>.exr
//! <out>/<position>/cos_nl_<light>.exr
//! <out>/<position>/cos_vl_<light>.exr
//! <out>/<position>/shadow_<light>.exr  1 where an object pixel is not lit
//! <out>/<position>/projector_pixel_<light>.exr  column, row, 0
//! <out>/<position>/pattern_<capture>.exr        expected sharp checker
//! <out>/<position>/match_<other>.exr   column, row in <other>, valid (1/0)
//! ```
//!
//! Single-channel maps are stored in `R`, vectors in `R G B`. Each file is
//! written atomically; names from the manifest keep only ASCII letters,
//! digits, `-`, `_` and `.` (anything else becomes `_`).

use crate::calibrate::ScanCalibration;
use crate::error::CalibError;
use matscan_scan::image_io::{write_rgb_exr, write_scalar_exr, Precision};
use matscan_scan::raster::{RgbRaster, ScalarRaster};
use matscan_scan::Raster;
use std::path::{Path, PathBuf};

fn safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect::<String>()
        .trim_start_matches('.')
        .to_string()
}

fn rg(r: &Raster<[f32; 2]>) -> RgbRaster {
    r.map(|p| [p[0], p[1], 0.0])
}

fn scalar(dir: &Path, name: &str, r: &ScalarRaster) -> Result<(), CalibError> {
    Ok(write_scalar_exr(&dir.join(name), r, Precision::Float)?)
}

fn rgb(dir: &Path, name: &str, r: &RgbRaster) -> Result<(), CalibError> {
    Ok(write_rgb_exr(&dir.join(name), r, Precision::Float)?)
}

/// Writes every map of `calibration` under `out` (created if needed) and
/// returns the folder of each position, in manifest order.
pub fn write_maps(calibration: &ScanCalibration, out: &Path) -> Result<Vec<PathBuf>, CalibError> {
    let mkdir = |d: &Path| {
        std::fs::create_dir_all(d).map_err(|source| CalibError::Io {
            path: d.to_path_buf(),
            source,
        })
    };
    mkdir(out)?;
    let json = serde_json::to_vec_pretty(&calibration.summary()).map_err(|e| CalibError::Io {
        path: out.join("calib.json"),
        source: e.into(),
    })?;
    matscan_scan::atomic::write_atomic(&out.join("calib.json"), &json)?;
    let mut dirs = Vec::new();
    for p in &calibration.positions {
        let m = &p.maps;
        let g = &m.geometry;
        let dir = out.join(safe(&m.position));
        mkdir(&dir)?;
        scalar(&dir, "mask.exr", &g.mask.map(|&v| f32::from(u8::from(v))))?;
        rgb(&dir, "position.exr", &g.position)?;
        rgb(&dir, "normal.exr", &g.normal)?;
        scalar(&dir, "depth.exr", &g.depth)?;
        rgb(&dir, "view.exr", &g.view)?;
        scalar(&dir, "cos_nv.exr", &g.cos_nv)?;
        if let Some(uv) = &g.uv {
            rgb(&dir, "uv.exr", &rg(uv))?;
        }
        for l in &m.lights {
            let n = safe(&l.light);
            rgb(&dir, &format!("light_{n}.exr"), &l.direction)?;
            scalar(&dir, &format!("distance_{n}.exr"), &l.distance)?;
            scalar(&dir, &format!("cos_nl_{n}.exr"), &l.cos_nl)?;
            scalar(&dir, &format!("cos_vl_{n}.exr"), &l.cos_vl)?;
            scalar(&dir, &format!("shadow_{n}.exr"), &l.shadow(&g.mask))?;
        }
        for pm in &m.projectors {
            rgb(
                &dir,
                &format!("projector_pixel_{}.exr", safe(&pm.light)),
                &rg(&pm.pixel),
            )?;
            for (capture, values) in &pm.patterns {
                scalar(&dir, &format!("pattern_{}.exr", safe(capture)), values)?;
            }
        }
        for c in calibration
            .correspondences
            .iter()
            .filter(|c| c.reference == m.position)
        {
            let mut r = rg(&c.coords);
            for (px, &v) in r.data.iter_mut().zip(&c.valid.data) {
                px[2] = f32::from(u8::from(v));
            }
            rgb(&dir, &format!("match_{}.exr", safe(&c.other)), &r)?;
        }
        dirs.push(dir);
    }
    Ok(dirs)
}
