//! The scanned object re-rendered (`matscan render SCAN (--light L,... |
//! --orbit N) --out DIR`) with its estimated material under novel lights and
//! from novel views (see [`crate::rerender`] for the lights, views and
//! material conversion), and, for simulated scans, beside the same images
//! with the true material and their PSNR and SSIM
//! ([`crate::image_metrics`]).
//!
//! Estimated material: the UV textures in `ESTIMATE/texture/` (written by
//! `matscan export`); where there are none, the estimate's per-position
//! maps are baked in memory (`matscan_bake::bake_scan`, `--texture-size`).
//!
//! True material: the scene's own textures are not in the bundle, so "true"
//! here is the scan's per-position truth maps (`truth/<position>/*.exr`,
//! every position that has them) baked into the same UV atlas, at the same
//! size and with the same fusion and hole filling as the estimate
//! (`matscan_bake::read_truth_maps` then `bake_maps`, as `bake_truth`
//! does). It therefore differs from the scene as simulated where no camera
//! saw the surface (hole-filled), in detail finer than a camera pixel, and
//! in the subsurface radius (the renderer's default for both). The comparison isolates the estimator's error from
//! the baking's.
//!
//! Noise: the table's `noise` columns compare the true material with
//! itself rendered with other random numbers, the scale of sampling noise
//! at `--samples` (estimated and true renders share their random numbers,
//! so an estimate can score above it).
//!
//! Output: `DIR/<view>-<lighting>.exr` (linear float, exposure 1) and
//! `.png` (8-bit, the tone mapping of `image_metrics`), truth renders under
//! `DIR/truth/`, and `DIR/metrics.csv`; every file written atomically.
//!
//! Boundaries: writes the images and the metrics file; rendering is
//! [`crate::rerender`]'s, baking `matscan_bake`'s.

use crate::image_metrics::{compare, reinhard, Similarity};
use crate::rerender::{
    material_from_textures, LightName, Lighting, RenderSettings, Rendered, ScanObject,
};
use anyhow::{bail, Context, Result};
use matscan_bake::{
    bake_bundle, bake_maps, read_textures, read_truth_maps, texture_dir, BakeOptions, BakedTextures,
};
use matscan_calib::ScanCalibration;
use matscan_estimate::pipeline::output::ResultFile;
use matscan_scan::atomic::write_atomic;
use matscan_scan::image_io::{write_preview_png, write_rgb_exr};
use matscan_scan::{Bundle, Precision};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What `matscan render` renders, and where.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// The scan bundle folder.
    pub scan: PathBuf,
    /// Lightings; empty: a light at the camera.
    pub light: Vec<Lighting>,
    /// Views on a circle around the object instead of the reference view.
    pub orbit: Option<usize>,
    /// Output folder (created; files in it are replaced).
    pub out: PathBuf,
    /// Image width in pixels (the height follows the camera's aspect).
    pub size: u32,
    /// Path-tracing samples per pixel.
    pub samples: u32,
    /// The estimate folder; `None`: SCAN/estimate.
    pub estimate: Option<PathBuf>,
    /// Texture side when the estimate has no baked textures and is baked
    /// in memory (and for the truth when it has).
    pub texture_size: u32,
}

/// The estimate's textures: the baked files where there are some, else the
/// per-position maps baked in memory at `bake_size` (the flag says which),
/// with the scan's `calibration` where the caller has it.
pub fn estimated_textures(
    bundle: &Bundle,
    estimate_dir: &Path,
    bake_size: u32,
    calibration: Option<&ScanCalibration>,
) -> Result<(BakedTextures, bool)> {
    let dir = texture_dir(estimate_dir);
    if dir.join(matscan_bake::textures::COVERAGE_FILE).is_file() {
        let t = read_textures(&dir).with_context(|| format!("reading {}", dir.display()))?;
        return Ok((t, false));
    }
    let options = BakeOptions {
        size: bake_size,
        ..BakeOptions::default()
    };
    let t = bake_bundle(bundle, estimate_dir, calibration, &options)
        .with_context(|| format!("baking the estimate in {}", estimate_dir.display()))?;
    Ok((t, true))
}

/// The true textures of a simulated scan, baked as `like` was (same size)
/// and as `matscan_bake::bake_truth` bakes them; `None` for a scan without
/// truth maps. Each truth file is read once; `calibration`, where the
/// caller has the scan's, spares computing its position maps again.
pub fn true_textures(
    bundle: &Bundle,
    like: &BakedTextures,
    calibration: Option<&ScanCalibration>,
) -> Result<Option<BakedTextures>> {
    let context = || format!("baking the truth maps of {}", bundle.root.display());
    let positions = read_truth_maps(bundle).with_context(context)?;
    if positions.is_empty() {
        return Ok(None);
    }
    let options = BakeOptions {
        size: like.width(),
        ..BakeOptions::default()
    };
    let t = bake_maps(bundle, &positions, calibration, &options).with_context(context)?;
    Ok(Some(t))
}

/// The estimate's reference position (from `result.toml`), else the
/// manifest's first position.
pub fn reference_position(bundle: &Bundle, estimate_dir: &Path) -> Result<String> {
    let path = estimate_dir.join(matscan_estimate::pipeline::output::RESULT_FILE);
    if let Ok(text) = std::fs::read_to_string(&path) {
        let result =
            ResultFile::parse(&text).with_context(|| format!("parsing {}", path.display()))?;
        return Ok(result.reference_position);
    }
    match bundle.manifest.positions.first() {
        Some(p) => Ok(p.name.clone()),
        None => bail!(
            "{}: the manifest has no positions",
            bundle.manifest_path().display()
        ),
    }
}

/// Writes one render as `<stem>.exr` and `<stem>.png` in `dir`.
fn write_render(dir: &Path, stem: &str, r: &Rendered) -> Result<()> {
    let exr = dir.join(format!("{stem}.exr"));
    write_rgb_exr(&exr, &r.image, Precision::Float)
        .with_context(|| format!("writing {}", exr.display()))?;
    let png = dir.join(format!("{stem}.png"));
    // The preview writer applies the sRGB curve: hand it the Reinhard half.
    let display = r.image.map(|p| p.map(reinhard));
    write_preview_png(&png, &display).with_context(|| format!("writing {}", png.display()))?;
    Ok(())
}

/// Renders what `args` describe; returns the report (the score table and
/// what was written).
pub fn run(args: &RenderOptions) -> Result<String> {
    let mut report = String::new();
    if args.orbit == Some(0) {
        bail!("--orbit 0: expected at least one view");
    }
    let bundle = Bundle::open(&args.scan)?;
    let estimate_dir = args.estimate.clone().unwrap_or_else(|| {
        args.scan
            .join(matscan_estimate::pipeline::output::ESTIMATE_DIR)
    });
    let reference = reference_position(&bundle, &estimate_dir)?;
    let object = ScanObject::new(&bundle, &reference)
        .with_context(|| format!("framing {}", args.scan.display()))?;
    let lightings = if args.light.is_empty() {
        vec![Lighting {
            light: LightName::Camera,
            environment: false,
        }]
    } else {
        args.light.clone()
    };
    let shots = object.shots(&lightings, args.orbit);
    let settings = RenderSettings::new(args.size, args.samples);
    let (estimated, baked_now) =
        estimated_textures(&bundle, &estimate_dir, args.texture_size, None)?;
    if baked_now {
        let _ = writeln!(
            report,
            "no textures in {}; baked the estimate in memory at {} texels (`matscan export` keeps them)",
            texture_dir(&estimate_dir).display(),
            estimated.width()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let renders = object
        .render(&material_from_textures(&estimated), &shots, settings)
        .context("rendering the estimated material")?;
    for (shot, r) in shots.iter().zip(&renders) {
        write_render(&args.out, &shot.name(), r)?;
    }
    let Some(truth) = true_textures(&bundle, &estimated, None)? else {
        let _ = writeln!(
            report,
            "{} images in {} (no truth: not a simulated scan)",
            renders.len(),
            args.out.display()
        );
        return Ok(report);
    };
    let truth_dir = args.out.join("truth");
    std::fs::create_dir_all(&truth_dir)
        .with_context(|| format!("creating {}", truth_dir.display()))?;
    let true_material = material_from_textures(&truth);
    let true_renders = object
        .render(&true_material, &shots, settings)
        .context("rendering the true material")?;
    for (shot, r) in shots.iter().zip(&true_renders) {
        write_render(&truth_dir, &shot.name(), r)?;
    }
    // The truth again with other random numbers: how far sampling noise
    // alone moves the scores at this many samples. Estimated and true
    // renders share their random numbers (correlated noise), so an
    // estimate can score above this; it is a scale, not a bound.
    let reseeded = RenderSettings {
        seed: settings.seed ^ NOISE_SEED,
        ..settings
    };
    let noise_renders = object
        .render(&true_material, &shots, reseeded)
        .context("rendering the true material with another seed")?;
    let scores: Vec<Score> = shots
        .iter()
        .enumerate()
        .map(|(i, shot)| {
            let t = &true_renders[i];
            Score {
                name: shot.name(),
                estimate: compare(&renders[i].image, &t.image, &t.mask),
                noise: compare(&noise_renders[i].image, &t.image, &t.mask),
            }
        })
        .collect();
    let (table, csv) = score_table(&scores);
    report.push_str(&table);
    let csv_path = args.out.join("metrics.csv");
    write_atomic(&csv_path, csv.as_bytes())
        .with_context(|| format!("writing {}", csv_path.display()))?;
    let _ = writeln!(
        report,
        "{} images and their truth in {}",
        renders.len(),
        args.out.display()
    );
    Ok(report)
}

/// Mixed into the render seed for the noise-floor renders.
pub const NOISE_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// One image's scores: estimated against true material, and the true
/// material against itself rendered with other random numbers.
pub struct Score {
    pub name: String,
    pub estimate: Option<Similarity>,
    pub noise: Option<Similarity>,
}

/// The printed table and the CSV of per-image scores plus their mean.
fn score_table(scores: &[Score]) -> (String, String) {
    let mut table = format!(
        "estimated vs true material, luminance of tone-mapped renders over the object\n\
         (noise: the true material against itself with other random numbers: the scale of sampling noise;\n\
          estimated and true renders share their random numbers, so they can score above it):\n\
         {:<28} {:>8} {:>7}   {:>8} {:>7} {:>8}\n",
        "image", "PSNR dB", "SSIM", "noise dB", "SSIM", "pixels"
    );
    let mut csv = String::from("image,psnr,ssim,mad,mse,pixels,noise_psnr,noise_ssim\n");
    let mut sums = [0.0f64; 4];
    let mut n = 0usize;
    for score in scores {
        let name = &score.name;
        match (&score.estimate, &score.noise) {
            (Some(s), Some(z)) => {
                let _ = writeln!(
                    table,
                    "{name:<28} {:>8.2} {:>7.4}   {:>8.2} {:>7.4} {:>8}",
                    s.psnr, s.ssim, z.psnr, z.ssim, s.pixels
                );
                let _ = writeln!(
                    csv,
                    "{name},{},{},{},{},{},{},{}",
                    s.psnr, s.ssim, s.mad, s.mse, s.pixels, z.psnr, z.ssim
                );
                for (sum, v) in sums.iter_mut().zip([s.psnr, s.ssim, z.psnr, z.ssim]) {
                    *sum += v;
                }
                n += 1;
            }
            _ => {
                let _ = writeln!(table, "{name:<28}  (the object is not in view)");
                let _ = writeln!(csv, "{name},,,,,0,,");
            }
        }
    }
    if n > 0 {
        let [p, s, zp, zs] = sums.map(|v| v / n as f64);
        let _ = writeln!(
            table,
            "{:<28} {p:>8.2} {s:>7.4}   {zp:>8.2} {zs:>7.4}",
            "mean"
        );
        let _ = writeln!(csv, "mean,{p},{s},,,,{zp},{zs}");
    }
    (table, csv)
}
