//! Our renderer against Mitsuba 3 on a tiny scene, inside the bound of
//! docs/renderers.md ("Bounds for a test"), through
//! `tools/mitsuba/test_tiny.py`. The scene is the renderer comparison's
//! opaque dielectric (`realworld-box-0` of `renderer-samples.toml`): where
//! both renderers implement the same lobes, so the bound is tight and a
//! convention error (a flipped image, a shifted pattern, a lost pi) fails it.
//!
//! Runs where Python can import `mitsuba` (the script's virtual
//! environment `tools/mitsuba/.venv` if present, else `python3`); elsewhere
//! the script answers `skipped: mitsuba not importable` and the test says so.

use crate::common::rewrite_photos;
use matscan_scan::raster::RgbRaster;
use matscan_sim::render::describe::write_description;
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the tests crate lives in the workspace root")
        .to_path_buf()
}

/// The venv's interpreter where it was made, else the system's.
fn python() -> PathBuf {
    let venv = repo_root().join("tools/mitsuba/.venv/bin/python");
    if venv.exists() {
        venv
    } else {
        PathBuf::from("python3")
    }
}

/// The comparison's opaque box at the samples' size (64 px, 2 positions,
/// 32 samples), with its description beside it.
fn render_box(dir: &Path) -> (PathBuf, PathBuf) {
    let scan = dir.join("scene-000000");
    let scene = generate(&SceneOptions {
        seed: 0,
        kind: SceneKind::RealWorld,
        geometry: GeometrySource::Kind(GeometryKind::Box),
        width: 64,
        height: 64,
        positions: 2,
        map_size: 64,
    });
    let sim = SimOptions {
        samples: 32,
        seed: 1,
        threads: Some(2),
        ..SimOptions::default()
    };
    let bundle = write_scan_bundle(&scene, &sim, &scan).unwrap();
    write_description(&scene, &sim, &bundle, &scan).unwrap();
    let desc = dir.join("scene-000000.scene");
    assert!(desc.join("scene.json").exists(), "description written");
    (scan, desc)
}

/// Runs the script; `None` where Python or Mitsuba is missing.
fn test_tiny(desc: &Path) -> Option<Output> {
    let script = repo_root().join("tools/mitsuba/test_tiny.py");
    let out = match Command::new(python()).arg(&script).arg(desc).output() {
        Ok(out) => out,
        Err(e) => {
            eprintln!("skipped: no python interpreter ({e})");
            return None;
        }
    };
    if String::from_utf8_lossy(&out.stdout).contains("skipped: mitsuba not importable") {
        eprintln!("skipped: mitsuba not importable by {}", python().display());
        return None;
    }
    Some(out)
}

fn report(out: &Output) -> String {
    format!(
        "exit {:?}\n{}\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

#[test]
fn mitsuba_and_matscan_agree_on_an_opaque_box_and_a_mirrored_copy_fails() {
    let tmp = tempfile::tempdir().unwrap();
    let (scan, desc) = render_box(tmp.path());
    let Some(out) = test_tiny(&desc) else {
        return;
    };
    assert_eq!(out.status.code(), Some(0), "{}", report(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("inside the opaque-dielectric bound"),
        "{}",
        report(&out)
    );

    // The same photos mirrored left to right: a convention error the bound
    // exists to catch (docs/renderers.md measures 17 of 24 checks out).
    rewrite_photos(&scan, |_, _, photo| {
        RgbRaster::from_fn(photo.width, photo.height, |x, y| {
            *photo.get(photo.width - 1 - x, y)
        })
    });
    let out = test_tiny(&desc).expect("mitsuba was importable a moment ago");
    assert_eq!(out.status.code(), Some(1), "{}", report(&out));
    assert!(
        String::from_utf8_lossy(&out.stdout).contains("outside the opaque-dielectric bound"),
        "{}",
        report(&out)
    );
}
