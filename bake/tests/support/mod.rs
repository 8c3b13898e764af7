//! Fixture code shared by the export tests: a small simulated scan whose
//! "estimate" is its truth maps, baked; and the node packages the
//! viewer and validator checks install on first use.
#![allow(dead_code)] // each test binary uses its own part

use matscan_bake::{bake_scan, BakeOptions, BakedTextures};
use matscan_scan::bundle::TruthMap;
use matscan_scan::image_io::{write_rgb_exr, write_scalar_exr, Precision};
use matscan_scan::{Bundle, Param};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Side of the textures [`bake_small_scan`] bakes.
pub const TEXTURE: u32 = 64;

/// A 32x32 two-position scan of a torus written to `scan`, its truth
/// copied as the estimate of every position into `<scan>/estimate`, baked
/// at [`TEXTURE`]x[`TEXTURE`].
pub fn bake_small_scan(scan: &Path) -> (Bundle, BakedTextures) {
    let scene = generate(&SceneOptions {
        seed: 11,
        kind: SceneKind::TwoMatTransmission,
        geometry: GeometrySource::Kind(GeometryKind::Torus),
        width: 32,
        height: 32,
        positions: 2,
        map_size: 16,
    });
    let options = SimOptions {
        samples: 1,
        threads: Some(2),
        ..SimOptions::default()
    };
    let bundle = write_scan_bundle(&scene, &options, scan).unwrap();
    let estimate = scan.join("estimate");
    copy_truth_as_estimate(&bundle, &estimate);
    let textures = bake_scan(
        scan,
        &estimate,
        &BakeOptions {
            size: TEXTURE,
            ..BakeOptions::default()
        },
    )
    .unwrap();
    (bundle, textures)
}

/// Writes every position's truth maps as `estimate/<position>/<param>.exr`.
pub fn copy_truth_as_estimate(bundle: &Bundle, estimate: &Path) {
    for p in &bundle.manifest.positions {
        let dir = estimate.join(&p.name);
        std::fs::create_dir_all(&dir).unwrap();
        for param in Param::ALL {
            let image = bundle
                .read_truth(&p.name, &TruthMap::Param(param))
                .unwrap()
                .unwrap();
            let path = dir.join(format!("{param}.exr"));
            match param {
                Param::Basecolor => {
                    write_rgb_exr(&path, &image.into_rgb().unwrap(), Precision::Float)
                }
                _ => write_scalar_exr(&path, &image.into_scalar().unwrap(), Precision::Float),
            }
            .unwrap();
        }
    }
}

pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"))
}

/// `node_modules` of `<target>/<folder>` with `packages`, installed on
/// first use; `Err` says why the check has to be skipped.
pub fn node_modules(folder: &str, packages: &[&str]) -> Result<PathBuf, String> {
    let dir = target_dir().join(folder);
    let modules = dir.join("node_modules");
    let installed = || {
        packages
            .iter()
            .all(|p| modules.join(p).join("package.json").is_file())
    };
    if installed() {
        return Ok(modules);
    }
    Command::new("node")
        .arg("--version")
        .output()
        .map_err(|e| format!("no node ({e})"))?;
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let out = Command::new("npm")
        .args(["install", "--no-audit", "--no-fund", "--prefix"])
        .arg(&dir)
        .args(packages)
        .output()
        .map_err(|e| format!("no npm ({e})"))?;
    if !out.status.success() || !installed() {
        return Err(format!(
            "npm install {} failed (offline?): {}",
            packages.join(" "),
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ));
    }
    Ok(modules)
}
