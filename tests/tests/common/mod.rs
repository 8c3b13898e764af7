//! Shared by the scan-level stability tests: one tiny simulated scan per
//! test binary, and copies of it whose photos are replaced by extreme ones.

#![allow(dead_code)]

use matscan_calib::CalibOptions;
use matscan_scan::image_io::{write_rgb_exr, Precision};
use matscan_scan::raster::RgbRaster;
use matscan_scan::Bundle;
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use tempfile::TempDir;

/// Image size of the fixture scan: small enough for a fast suite, large
/// enough that the sphere and the white panel both cover pixels.
pub const SIZE: u32 = 24;

/// A 24x24, two-position scan with a white-reference mask, rendered once
/// per test binary with one path per pixel.
pub fn fixture() -> &'static Path {
    static FIXTURE: OnceLock<(TempDir, PathBuf)> = OnceLock::new();
    &FIXTURE
        .get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let scan = dir.path().join("scan");
            let scene = generate(&SceneOptions {
                seed: 11,
                kind: SceneKind::MultimatNoEnv,
                geometry: GeometrySource::Kind(GeometryKind::Sphere),
                width: SIZE,
                height: SIZE,
                positions: 2,
                map_size: 16,
            });
            let options = SimOptions {
                samples: 1,
                seed: 5,
                threads: Some(2),
                white_reference: true,
                ..SimOptions::default()
            };
            write_scan_bundle(&scene, &options, &scan).unwrap();
            (dir, scan)
        })
        .1
}

/// A private copy of the fixture in `into`.
pub fn copy(into: &Path) -> PathBuf {
    let target = into.join("scan");
    copy_dir(fixture(), &target);
    target
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let dest = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &dest);
        } else {
            std::fs::copy(entry.path(), dest).unwrap();
        }
    }
}

/// Rewrites every photo of the scan at `scan` with `f(position index,
/// capture index, original photo)`, in float precision (so values beyond
/// the half-float range survive).
pub fn rewrite_photos(scan: &Path, mut f: impl FnMut(usize, usize, &RgbRaster) -> RgbRaster) {
    let bundle = Bundle::open(scan).unwrap();
    for (pi, p) in bundle.manifest.positions.iter().enumerate() {
        for (ci, c) in p.captures.iter().enumerate() {
            let photo = bundle.read_photo(&p.name, &c.name).unwrap();
            let new = f(pi, ci, &photo);
            write_rgb_exr(&scan.join(&c.file), &new, Precision::Float).unwrap();
        }
    }
}

/// Every photo replaced by the constant `value`.
pub fn constant_photos(scan: &Path, value: f32) {
    rewrite_photos(scan, |_, _, p| {
        RgbRaster::filled(p.width, p.height, [value; 3])
    });
}

/// Calibration options that keep every position: a black or constant scan
/// fails the thesis's bad-light check (rightly: its lit photos carry
/// nothing), but the stages after it must still be numerically sound when
/// a user overrides the check.
pub fn no_bad_light_check() -> CalibOptions {
    let mut options = CalibOptions::default();
    options.bad_light.threshold = f32::NEG_INFINITY;
    options
}
