//! An exported glTF loads and draws in a real viewer: three.js's
//! GLTFLoader in headless Chromium (WebGL through SwiftShader) renders the
//! object framed on its bounding box, and the frame shows a lit, textured
//! object rather than an empty or black one. Node, `puppeteer-core`,
//! `three` and `@sparticuz/chromium` (whose npm package ships the browser
//! itself) are installed into the target dir on first use; without node,
//! npm or a browser that starts, the test says it skipped.

use matscan_bake::{bake_scan, export_gltf, BakeOptions, GltfFormat};
use matscan_scan::bundle::TruthMap;
use matscan_scan::image_io::{write_rgb_exr, write_scalar_exr, Precision};
use matscan_scan::Param;
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const PACKAGES: [&str; 3] = ["puppeteer-core", "three", "@sparticuz/chromium"];

/// A 32x32 two-position scan of a torus, its truth copied as the estimate,
/// baked at 64x64 and exported as .gltf with separate .bin and PNGs.
fn export_small_gltf(dir: &Path) -> PathBuf {
    let scene = generate(&SceneOptions {
        seed: 11,
        kind: SceneKind::TwoMatTransmission,
        geometry: GeometrySource::Kind(GeometryKind::Torus),
        width: 32,
        height: 32,
        positions: 2,
        map_size: 16,
    });
    let scan = dir.join("scan");
    let options = SimOptions {
        samples: 1,
        threads: Some(2),
        ..SimOptions::default()
    };
    let bundle = write_scan_bundle(&scene, &options, &scan).unwrap();
    let estimate = scan.join("estimate");
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
    let textures = bake_scan(
        &scan,
        &estimate,
        &BakeOptions {
            size: 64,
            ..BakeOptions::default()
        },
    )
    .unwrap();
    let mesh = bundle.read_mesh().unwrap();
    export_gltf(&mesh, &textures, &estimate, GltfFormat::Separate, 1.0).unwrap()
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target"))
}

/// `node_modules` with the viewer's packages, installed on first use;
/// `Err` says why the check has to be skipped.
fn viewer_modules() -> Result<PathBuf, String> {
    let dir = target_dir().join("gltf-viewer");
    let modules = dir.join("node_modules");
    let installed = || {
        PACKAGES
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
    std::fs::create_dir_all(&dir).unwrap();
    let out = Command::new("npm")
        .args(["install", "--no-audit", "--no-fund", "--prefix"])
        .arg(&dir)
        .args(PACKAGES)
        .output()
        .map_err(|e| format!("no npm ({e})"))?;
    if !out.status.success() || !installed() {
        return Err(format!(
            "npm install {} failed (offline?): {}",
            PACKAGES.join(" "),
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ));
    }
    Ok(modules)
}

#[test]
fn exported_gltf_renders_textured_in_headless_chromium_with_three_js() {
    let modules = match viewer_modules() {
        Ok(m) => m,
        Err(why) => {
            eprintln!("skipped: headless glTF viewer not available: {why}");
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let gltf = export_small_gltf(dir.path());
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/viewer/render.mjs");
    let screenshot = target_dir().join("gltf-viewer/last-render.png");
    let start = Instant::now();
    let out = match Command::new("node")
        .arg(&script)
        .arg(&modules)
        .arg(&gltf)
        .arg(&screenshot)
        .output()
    {
        Ok(out) => out,
        Err(e) => {
            eprintln!("skipped: headless glTF viewer not available: no node ({e})");
            return;
        }
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    if out.status.code() == Some(3) {
        eprintln!("skipped: headless Chromium with WebGL not available: {stderr}");
        return;
    }
    assert!(out.status.success(), "render.mjs failed: {stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout.lines().last().unwrap_or_default();
    let frame: serde_json::Value = serde_json::from_str(line).unwrap();
    eprintln!(
        "rendered in {:.1} s ({}): {frame}",
        start.elapsed().as_secs_f64(),
        screenshot.display()
    );
    let textures = frame["textures"].as_u64().unwrap();
    assert!(textures >= 2, "material has {textures} textures: {frame}");
    assert_eq!(frame["texturesWithImages"], textures, "{frame}\n{stderr}");
    let fraction = frame["fraction"].as_f64().unwrap();
    assert!(
        (0.02..0.95).contains(&fraction),
        "object covers {fraction} of the frame: {frame}\n{stderr}"
    );
    let mean: Vec<f64> = frame["mean"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_f64().unwrap())
        .collect();
    let luminance = 0.2126 * mean[0] + 0.7152 * mean[1] + 0.0722 * mean[2];
    assert!(
        luminance > 0.05,
        "object pixels are nearly black (mean {mean:?}): {frame}\n{stderr}"
    );
}
