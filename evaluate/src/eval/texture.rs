//! The estimate judged in texture space (`matscan eval --textures [SIZE]`)
//! and by re-rendering, per scan and view configuration.
//!
//! For each estimated scan: the estimate's per-position maps and the scan's
//! truth maps are baked into UV textures of SIZE texels
//! (`matscan_bake::bake_scan`, `bake_truth`: the same fusion and hole
//! filling for both), then
//! - MAD, MSE and PSNR per parameter over the texels both bakes measured
//!   (coverage 255 in both; hole-filled texels are left out), basecolor
//!   averaged over its channels, as `matscan_estimate::pipeline::metrics` computes
//!   them;
//! - the object re-rendered with both materials ([`crate::rerender`]) in
//!   [`SHOTS`]: two novel lights from the reference view (`key-left`,
//!   `rim`) and two novel views 45 degrees to either side of it, lit by a
//!   light at the camera; [`IMAGE_WIDTH`] px, [`SAMPLES`] samples per
//!   pixel; PSNR and SSIM as [`crate::image_metrics`] defines them.
//!
//! The estimate bakes the positions eval's estimate has maps for: with
//! `--textures`, eval estimates with every position as reference
//! (`References::Every`), as `matscan export` needs, so its run times are
//! those of every-position estimates (one network pass per position).
//! Texels no position sees are hole-filled in both bakes and left out of
//! the texture MAD (measured in both).
//!
//! Beside each image's scores stand those of the true material against
//! itself rendered with other random numbers: the scale of sampling noise
//! (not a bound: estimated and true renders share their random numbers).
//!
//! "True" material is the baked truth (see [`crate::render`]), so these
//! figures measure the estimator, not the baker.
//!
//! Boundaries: scores and their tables; estimating is the module root's.

use super::tables::csv_number;
use crate::image_metrics::{compare, Similarity};
use crate::render::{true_textures, NOISE_SEED};
use crate::rerender::{
    material_from_textures, Framing, LightName, Lighting, RenderSettings, ScanObject, Shot,
};
use anyhow::{Context, Result};
use matscan_bake::{bake_bundle, BakeOptions, BakedTextures};
use matscan_estimate::pipeline::metrics::{error_metrics, ErrorMetrics};
use matscan_estimate::pipeline::run::PreparedScan;
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Width of the re-rendered images, px (small: eval runs over many scans).
pub const IMAGE_WIDTH: u32 = 64;
/// Samples per pixel of the re-renders.
pub const SAMPLES: u32 = 16;
/// Views on the orbit circle; views 1 and 7 are 45 degrees to either side
/// of the reference camera.
const ORBIT: usize = 8;
/// The four re-rendered images, by name (`<view>-<lighting>`).
pub const SHOTS: [&str; 4] = [
    "ref-key-left",
    "ref-rim",
    "orbit-01-camera",
    "orbit-07-camera",
];

/// One scan's texture-space and re-render scores.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureScore {
    /// Per parameter the estimate has, over texels measured in both bakes.
    pub params: BTreeMap<Param, ErrorMetrics>,
    /// Per shot of [`SHOTS`] (those with the object in view): estimated
    /// against true material, and the true material against itself with
    /// other random numbers (the scale of sampling noise; see [`crate::render`]).
    pub renders: Vec<(String, Similarity, Similarity)>,
}

/// The four shots of [`SHOTS`].
fn shots(framing: &Framing) -> Vec<Shot> {
    let reference = framing.reference_view();
    let orbit = framing.orbit(ORBIT);
    let light = |light| Lighting {
        light,
        environment: false,
    };
    let mut shots = vec![
        Shot {
            view: reference.clone(),
            lighting: light(LightName::KeyLeft),
        },
        Shot {
            view: reference,
            lighting: light(LightName::Rim),
        },
    ];
    for k in [1, ORBIT - 1] {
        shots.push(Shot {
            view: orbit[k].clone(),
            lighting: light(LightName::Camera),
        });
    }
    shots
}

/// Scores the estimate in `estimate_dir` of the simulated scan `prepared`
/// (reference position `reference`) with textures of `size` texels; both
/// bakes reuse the scan's calibration.
pub fn score_scan(
    prepared: &PreparedScan,
    estimate_dir: &Path,
    reference: &str,
    size: u32,
) -> Result<TextureScore> {
    let bundle = &prepared.bundle;
    let calibration = Some(&prepared.calibration);
    let scan = bundle.root.as_path();
    let options = BakeOptions {
        size,
        ..BakeOptions::default()
    };
    let estimated = bake_bundle(bundle, estimate_dir, calibration, &options)
        .with_context(|| format!("baking the estimate of {}", scan.display()))?;
    let truth = true_textures(bundle, &estimated, calibration)?
        .with_context(|| format!("{}: no truth maps to compare with", scan.display()))?;
    let params = texture_errors(&estimated, &truth);
    let object = ScanObject::new(bundle, reference)
        .with_context(|| format!("framing {}", scan.display()))?;
    let shots = shots(&object.framing);
    let settings = RenderSettings::new(IMAGE_WIDTH, SAMPLES);
    let true_material = material_from_textures(&truth);
    let est = object.render(&material_from_textures(&estimated), &shots, settings)?;
    let tru = object.render(&true_material, &shots, settings)?;
    let reseeded = RenderSettings {
        seed: settings.seed ^ NOISE_SEED,
        ..settings
    };
    let noise = object.render(&true_material, &shots, reseeded)?;
    let renders = shots
        .iter()
        .enumerate()
        .filter_map(|(i, shot)| {
            let t = &tru[i];
            Some((
                shot.name(),
                compare(&est[i].image, &t.image, &t.mask)?,
                compare(&noise[i].image, &t.image, &t.mask)?,
            ))
        })
        .collect();
    Ok(TextureScore { params, renders })
}

/// MAD, MSE and PSNR per parameter of `estimated` over the texels measured
/// in both sets.
pub fn texture_errors(
    estimated: &BakedTextures,
    truth: &BakedTextures,
) -> BTreeMap<Param, ErrorMetrics> {
    let mut out = BTreeMap::new();
    if (estimated.width(), estimated.height()) != (truth.width(), truth.height()) {
        return out;
    }
    let mask: Vec<bool> = estimated
        .coverage()
        .data
        .iter()
        .zip(&truth.coverage().data)
        .map(|(a, b)| *a && *b)
        .collect();
    for param in estimated.params() {
        let metrics = match param {
            Param::Basecolor => match (estimated.basecolor(), truth.basecolor()) {
                (Some(e), Some(t)) => {
                    error_metrics(e.data.as_flattened(), t.data.as_flattened(), &mask, 3)
                }
                _ => None,
            },
            p => match (estimated.scalar(p), truth.scalar(p)) {
                (Some(e), Some(t)) => error_metrics(&e.data, &t.data, &mask, 1),
                _ => None,
            },
        };
        if let Some(m) = metrics {
            out.insert(param, m);
        }
    }
    out
}

/// Means of the scores of one view configuration.
#[derive(Debug, Default, Clone)]
pub struct TextureTable {
    params: BTreeMap<Param, [f64; 4]>,
    /// Sums of MAD, MSE, PSNR, SSIM, noise PSNR, noise SSIM, count.
    renders: BTreeMap<String, [f64; 7]>,
    failures: Vec<String>,
}

impl TextureTable {
    /// Scores the estimate in `estimate_dir` and adds it; a scan that
    /// cannot be scored is counted and named instead of stopping the run.
    pub fn add_scan(
        &mut self,
        prepared: &PreparedScan,
        estimate_dir: &Path,
        reference: &str,
        size: u32,
    ) {
        match score_scan(prepared, estimate_dir, reference, size) {
            Ok(score) => self.add(&score),
            Err(e) => self.failures.push(format!("{e:#}")),
        }
    }

    pub fn add(&mut self, score: &TextureScore) {
        for (p, m) in &score.params {
            let s = self.params.entry(*p).or_default();
            s[0] += m.mad;
            s[1] += m.mse;
            s[2] += m.psnr;
            s[3] += 1.0;
        }
        for (name, sim, noise) in &score.renders {
            let s = self.renders.entry(name.clone()).or_default();
            let add = [
                sim.mad, sim.mse, sim.psnr, sim.ssim, noise.psnr, noise.ssim, 1.0,
            ];
            for (s, a) in s.iter_mut().zip(add) {
                *s += a;
            }
        }
    }

    /// The render sums in [`SHOTS`] order (any other name after them).
    fn ordered_renders(&self) -> Vec<(&String, &[f64; 7])> {
        let mut rows: Vec<_> = self.renders.iter().collect();
        rows.sort_by_key(|(name, _)| SHOTS.iter().position(|s| s == name).unwrap_or(SHOTS.len()));
        rows
    }

    /// Appends the two tables (texture error per parameter, re-render
    /// scores per image) to `table`.
    pub fn write_table(&self, table: &mut String, size: u32) {
        let _ = writeln!(
            table,
            "\ntextures ({size} texels, every position baked; run times above are every-position estimates), error on texels measured in both estimate and truth bakes"
        );
        let _ = writeln!(
            table,
            "{:<13} {:>5} {:>8} {:>9} {:>7}",
            "parameter", "scans", "MAD", "MSE", "PSNR"
        );
        for (p, [mad, mse, psnr, n]) in &self.params {
            let _ = writeln!(
                table,
                "{:<13} {:>5} {:>8.4} {:>9.5} {:>7.2}",
                p.name(),
                n,
                mad / n,
                mse / n,
                psnr / n
            );
        }
        let _ = writeln!(
            table,
            "re-renders, estimated vs true material ({IMAGE_WIDTH} px, {SAMPLES} spp, luminance of tone-mapped images over the object)"
        );
        let _ = writeln!(
            table,
            "(noise: the true material against itself with other random numbers)\n{:<17} {:>5} {:>8} {:>7}   {:>8} {:>7}",
            "image", "scans", "PSNR dB", "SSIM", "noise dB", "SSIM"
        );
        let mut mean = [0.0f64; 4];
        let mut k = 0.0;
        for (name, [_, _, p, s, zp, zs, n]) in self.ordered_renders() {
            let row = [p / n, s / n, zp / n, zs / n];
            let _ = writeln!(
                table,
                "{name:<17} {n:>5} {:>8.2} {:>7.4}   {:>8.2} {:>7.4}",
                row[0], row[1], row[2], row[3]
            );
            for (m, v) in mean.iter_mut().zip(row) {
                *m += v;
            }
            k += 1.0;
        }
        if k > 0.0 {
            let [p, s, zp, zs] = mean.map(|v| v / k);
            let _ = writeln!(
                table,
                "{:<17} {:>5} {p:>8.2} {s:>7.4}   {zp:>8.2} {zs:>7.4}",
                "mean", ""
            );
        }
        for f in self.failures.iter().take(5) {
            let _ = writeln!(table, "  texture scoring failed: {f}");
        }
    }

    /// Appends this configuration's rows to `matscan eval`'s CSV (columns
    /// of [`super::tables::CSV_HEADER`], group `ALL`): `texture` rows per
    /// parameter (MAD, MSE, PSNR over measured texels), `render` rows per
    /// image (MAD, MSE, PSNR and SSIM of the luminance), `render-noise`
    /// rows per image (PSNR and SSIM of the true material against itself
    /// with other random numbers).
    pub fn write_csv(&self, csv: &mut String, views: usize) {
        for (p, [mad, mse, psnr, n]) in &self.params {
            let _ = writeln!(
                csv,
                "texture,{views},ALL,,{},{n},{},{},{},,,,,,,",
                p.name(),
                csv_number(Some(mad / n)),
                csv_number(Some(mse / n)),
                csv_number(Some(psnr / n)),
            );
        }
        for (name, [mad, mse, psnr, ssim, zp, zs, n]) in self.ordered_renders() {
            let _ = writeln!(
                csv,
                "render,{views},ALL,,{name},{n},{},{},{},,,,,,{},",
                csv_number(Some(mad / n)),
                csv_number(Some(mse / n)),
                csv_number(Some(psnr / n)),
                csv_number(Some(ssim / n)),
            );
            let _ = writeln!(
                csv,
                "render-noise,{views},ALL,,{name},{n},,,{},,,,,,{},",
                csv_number(Some(zp / n)),
                csv_number(Some(zs / n)),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};

    #[test]
    fn the_four_shots_are_two_lights_and_two_views_45_degrees_apart() {
        use matscan_sim::scene::{generate, SceneOptions};
        let scene = generate(&SceneOptions {
            width: 16,
            height: 16,
            positions: 1,
            map_size: 8,
            ..SceneOptions::default()
        });
        let framing = Framing::new(&scene.mesh, scene.rig.positions[0].camera_to_world).unwrap();
        let shots = shots(&framing);
        let names: Vec<String> = shots.iter().map(Shot::name).collect();
        assert_eq!(names, SHOTS.map(String::from).to_vec());
        let eye = |s: &Shot| s.view.camera_to_world.w_axis.truncate() - framing.centre;
        let angle = |a: glam::DVec3, b: glam::DVec3| a.angle_between(b).to_degrees();
        assert!(angle(eye(&shots[0]), eye(&shots[2])) <= 45.0 + 1e-6);
        assert!(angle(eye(&shots[2]), eye(&shots[3])) > 45.0);
    }

    #[test]
    fn texture_errors_count_only_texels_measured_in_both() {
        let cov = |v: Vec<bool>| MaskRaster::from_vec(2, 2, v).unwrap();
        let mut est = BakedTextures::new(cov(vec![true, true, false, true]));
        let mut tru = BakedTextures::new(cov(vec![true, false, true, true]));
        let s = |v: Vec<f32>| ScalarRaster::from_vec(2, 2, v).unwrap();
        est.set_scalar(Param::Roughness, s(vec![0.5, 9.0, 9.0, 0.2]))
            .unwrap();
        tru.set_scalar(Param::Roughness, s(vec![0.4, 0.0, 0.0, 0.5]))
            .unwrap();
        let rgb = |v: f32| RgbRaster::filled(2, 2, [v; 3]);
        est.set_basecolor(rgb(0.3)).unwrap();
        tru.set_basecolor(rgb(0.5)).unwrap();
        let e = texture_errors(&est, &tru);
        let r = e[&Param::Roughness];
        // Texels 0 and 3: |0.1| and |0.3|.
        assert_eq!(r.pixels, 2);
        assert!((r.mad - 0.2).abs() < 1e-6, "{r:?}");
        assert!((e[&Param::Basecolor].mad - 0.2).abs() < 1e-6);
        assert!(!e.contains_key(&Param::Metallic));
    }

    #[test]
    fn table_means_and_csv_rows_follow_the_scores() {
        let mut t = TextureTable::default();
        let m = |mad| ErrorMetrics {
            mad,
            mse: mad * mad,
            psnr: 20.0,
            pixels: 10,
        };
        let sim = |ssim| Similarity {
            psnr: 30.0,
            ssim,
            mad: 0.01,
            mse: 0.001,
            pixels: 100,
        };
        for (mad, ssim) in [(0.1, 0.9), (0.3, 0.7)] {
            t.add(&TextureScore {
                params: [(Param::Metallic, m(mad))].into(),
                renders: vec![("ref-rim".into(), sim(ssim), sim(0.95))],
            });
        }
        let mut csv = format!("{}\n", crate::eval::tables::CSV_HEADER);
        t.write_csv(&mut csv, 3);
        let lines: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
        let header = &lines[0];
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        assert_eq!(lines.len(), 4);
        assert!(lines.iter().all(|l| l.len() == header.len()), "{csv}");
        let (tex, render, noise) = (&lines[1], &lines[2], &lines[3]);
        assert_eq!(
            (tex[col("table")], tex[col("param")]),
            ("texture", "metallic")
        );
        assert_eq!((tex[col("views")], tex[col("scans")]), ("3", "2"));
        assert!((tex[col("mad")].parse::<f64>().unwrap() - 0.2).abs() < 1e-12);
        assert_eq!(
            (render[col("table")], render[col("param")]),
            ("render", "ref-rim")
        );
        assert!((render[col("ssim")].parse::<f64>().unwrap() - 0.8).abs() < 1e-12);
        assert_eq!(noise[col("table")], "render-noise");
        assert!((noise[col("ssim")].parse::<f64>().unwrap() - 0.95).abs() < 1e-12);
        let mut text = String::new();
        t.write_table(&mut text, 256);
        assert!(
            text.contains("metallic") && text.contains("0.2000"),
            "{text}"
        );
        assert!(text.contains("0.8000"), "{text}");
    }
}
