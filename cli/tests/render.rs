//! `matscan render` and `matscan eval --textures` end to end on a tiny
//! simulated scan (32 px, two positions) estimated with small random
//! networks: what files they write and what they report.

use crate::daemon_support;

use daemon_support::{matscan, matscan_ok, simulate_sphere, weights_dir};
use std::path::{Path, PathBuf};

/// A 32 px sphere scan with two positions and its estimate (random
/// networks: the material is wrong, which the scores must show).
fn estimated_scan(dir: &Path) -> (PathBuf, PathBuf) {
    let scan = dir.join("scan");
    simulate_sphere(
        32,
        2,
        2,
        &["--out", scan.to_str().unwrap(), "--kind", "2mat"],
    );
    let weights = weights_dir(dir, 5);
    matscan_ok(&[
        "estimate",
        scan.to_str().unwrap(),
        "--weights",
        weights.to_str().unwrap(),
    ]);
    (scan, weights)
}

fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text
        .lines()
        .map(|l| l.split(',').map(String::from).collect::<Vec<_>>());
    let header = lines.next().unwrap();
    (header, lines.collect())
}

#[test]
fn render_writes_estimate_and_truth_images_and_scores_them() {
    let tmp = tempfile::tempdir().unwrap();
    let (scan, _) = estimated_scan(tmp.path());
    let out = tmp.path().join("renders");
    let stdout = matscan_ok(&[
        "render",
        scan.to_str().unwrap(),
        "--light",
        "key-left,top+env",
        "--out",
        out.to_str().unwrap(),
        "--size",
        "32",
        "--samples",
        "4",
        "--texture-size",
        "64",
    ]);
    assert!(stdout.contains("baked the estimate in memory"), "{stdout}");
    for stem in ["ref-key-left", "ref-top+env"] {
        for ext in ["exr", "png"] {
            assert!(out.join(format!("{stem}.{ext}")).is_file(), "{stem}.{ext}");
            assert!(out.join("truth").join(format!("{stem}.{ext}")).is_file());
        }
    }
    let exr = matscan_scan::image_io::read_rgb_exr(&out.join("ref-key-left.exr")).unwrap();
    assert_eq!((exr.width, exr.height), (32, 32));
    assert!(exr.data.iter().flatten().any(|v| *v > 0.0));

    let (header, rows) = csv_rows(&out.join("metrics.csv"));
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 3, "two images and the mean");
    assert_eq!(rows[0][col("image")], "ref-key-left");
    assert_eq!(rows[2][col("image")], "mean");
    for r in &rows[..2] {
        let psnr: f64 = r[col("psnr")].parse().unwrap();
        let ssim: f64 = r[col("ssim")].parse().unwrap();
        let noise_psnr: f64 = r[col("noise_psnr")].parse().unwrap();
        // Random networks: a different material, so the images differ
        // (PSNR below the 100 dB cap of identical images); the noise
        // floor is the truth against itself with other random numbers.
        assert!(psnr.is_finite() && psnr < 60.0, "{r:?}");
        assert!(noise_psnr.is_finite() && noise_psnr < 60.0, "{r:?}");
        assert!((-1.0..1.0).contains(&ssim), "{r:?}");
        assert!(r[col("pixels")].parse::<usize>().unwrap() > 30);
    }

    // Orbit views, lit by a light at each camera.
    let orbit = tmp.path().join("orbit");
    matscan_ok(&[
        "render",
        scan.to_str().unwrap(),
        "--orbit",
        "3",
        "--out",
        orbit.to_str().unwrap(),
        "--size",
        "16",
        "--samples",
        "2",
        "--texture-size",
        "32",
    ]);
    for k in 0..3 {
        assert!(orbit.join(format!("orbit-{k:02}-camera.png")).is_file());
    }
}

#[test]
fn render_without_an_estimate_says_what_to_run_and_rejects_unknown_lights() {
    let tmp = tempfile::tempdir().unwrap();
    let scan = tmp.path().join("scan");
    simulate_sphere(16, 1, 1, &["--out", scan.to_str().unwrap()]);
    let out = tmp.path().join("r");
    let o = matscan(&[
        "render",
        scan.to_str().unwrap(),
        "--light",
        "top",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("matscan estimate"), "{err}");

    let o = matscan(&[
        "render",
        scan.to_str().unwrap(),
        "--light",
        "sideways",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("sideways") && err.contains("key-left"),
        "{err}"
    );
}

#[test]
fn eval_textures_adds_texture_and_render_rows() {
    let tmp = tempfile::tempdir().unwrap();
    let (scan, weights) = estimated_scan(tmp.path());
    let csv = tmp.path().join("eval.csv");
    let stdout = matscan_ok(&[
        "eval",
        scan.to_str().unwrap(),
        "--weights",
        weights.to_str().unwrap(),
        "--views",
        "0",
        "--textures",
        "64",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    assert!(
        stdout.contains("textures (64 texels, every position baked"),
        "{stdout}"
    );
    assert!(stdout.contains("orbit-07-camera"), "{stdout}");
    let (header, rows) = csv_rows(&csv);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    assert!(rows.iter().all(|r| r.len() == header.len()));
    let texture: Vec<_> = rows
        .iter()
        .filter(|r| r[col("table")] == "texture")
        .collect();
    let params: Vec<&str> = texture.iter().map(|r| r[col("param")].as_str()).collect();
    assert!(
        params.contains(&"basecolor") && params.contains(&"roughness"),
        "{params:?}"
    );
    for r in &texture {
        let mad: f64 = r[col("mad")].parse().unwrap();
        assert!((0.0..=1.0).contains(&mad), "{r:?}");
    }
    let renders: Vec<_> = rows
        .iter()
        .filter(|r| r[col("table")] == "render")
        .collect();
    assert_eq!(renders.len(), 4, "two lights and two views");
    for r in renders {
        let ssim: f64 = r[col("ssim")].parse().unwrap();
        let psnr: f64 = r[col("psnr")].parse().unwrap();
        assert!(ssim.is_finite() && psnr.is_finite(), "{r:?}");
    }
}
