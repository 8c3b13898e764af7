//! Held-out evaluation of a set of weights through the inference path:
//! `cargo run --release -p matscan-estimate --example evaluate --
//! --weights DIR|embedded --heldout DIR --train DIR`.
//!
//! For every bundle under `--heldout` (two levels deep) it runs
//! [`matscan_estimate::estimate`] (calibration, view selection, all five
//! networks fed by each other's estimates, exactly as `matscan estimate`)
//! and reads the MAD / MSE / PSNR it reports against the truth. The
//! baseline predicts, for every pixel, the training set's mean of the
//! parameter (over the truth masks of every position of every bundle under
//! `--train`), scored with the same metric over the same pixels. Figures are
//! means over scenes. Prints a Markdown table.

use matscan_estimate::metrics::error_metrics;
use matscan_estimate::{cpu_device, estimate, EstimateOptions, ModelSource, ParamKind};
use matscan_scan::{Bundle, Param, TruthImage, TruthMap};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn bundles(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) {
    if dir.join("scan.toml").is_file() {
        out.push(dir.to_path_buf());
        return;
    }
    if depth == 0 {
        return;
    }
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            if e.path().is_dir() {
                bundles(&e.path(), depth - 1, out);
            }
        }
    }
}

fn truth(bundle: &Bundle, position: &str, kind: ParamKind) -> Option<(Vec<f32>, usize)> {
    let param: Param = kind.name().parse().ok()?;
    match bundle
        .read_truth(position, &TruthMap::Param(param))
        .ok()??
    {
        TruthImage::Rgb(r) => Some((r.data.as_flattened().to_vec(), 3)),
        TruthImage::Scalar(s) => Some((s.data, 1)),
        TruthImage::Mask(_) => None,
    }
}

fn mask(bundle: &Bundle, position: &str) -> Option<Vec<bool>> {
    bundle
        .read_truth(position, &TruthMap::Mask)
        .ok()??
        .into_mask()
        .map(|m| m.data)
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |key: &str| {
        args.iter()
            .position(|a| a == key)
            .and_then(|i| args.get(i + 1))
            .cloned()
            .ok_or_else(|| format!("{key} is required"))
    };
    let weights = get("--weights")?;
    let mut heldout = Vec::new();
    bundles(Path::new(&get("--heldout")?), 2, &mut heldout);
    heldout.sort();
    let mut train = Vec::new();
    bundles(Path::new(&get("--train")?), 2, &mut train);

    // Training-set means (per channel for basecolor).
    let mut sums: BTreeMap<ParamKind, (Vec<f64>, f64)> = BTreeMap::new();
    for path in &train {
        let bundle = Bundle::open(path)?;
        for position in &bundle.manifest.positions {
            let Some(m) = mask(&bundle, &position.name) else {
                continue;
            };
            for kind in ParamKind::ALL {
                let Some((t, c)) = truth(&bundle, &position.name, kind) else {
                    continue;
                };
                let entry = sums.entry(kind).or_insert((vec![0.0; c], 0.0));
                for (i, _) in m.iter().enumerate().filter(|(_, m)| **m) {
                    for ch in 0..c {
                        entry.0[ch] += f64::from(t[i * c + ch]);
                    }
                    entry.1 += 1.0;
                }
            }
        }
    }
    let means: BTreeMap<ParamKind, Vec<f32>> = sums
        .iter()
        .map(|(k, (s, n))| (*k, s.iter().map(|v| (v / n.max(1.0)) as f32).collect()))
        .collect();
    eprintln!("training means over {} bundles: {means:?}", train.len());

    let device = cpu_device();
    let out_root = tempfile_dir()?;
    // kind -> (model [mad, mse, psnr] sums, baseline sums, count)
    let mut model: BTreeMap<ParamKind, ([f64; 3], usize)> = BTreeMap::new();
    let mut base: BTreeMap<ParamKind, ([f64; 3], usize)> = BTreeMap::new();
    let mut seconds = 0.0;
    for (i, path) in heldout.iter().enumerate() {
        let source = if weights == "embedded" {
            ModelSource::Embedded
        } else {
            ModelSource::Dir(PathBuf::from(&weights))
        };
        let options = EstimateOptions {
            out: Some(out_root.join(format!("e{i}"))),
            ..EstimateOptions::default()
        };
        let report = match estimate(path, source, &options, &device) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{}: {e}", path.display());
                continue;
            }
        };
        seconds += report.result.timings.total_s;
        let bundle = Bundle::open(path)?;
        let reference = &report.result.reference_position;
        let m = mask(&bundle, reference).ok_or("held-out bundle without a truth mask")?;
        for kind in ParamKind::ALL {
            if let Some(e) = report.result.metrics.get(kind.name()) {
                let entry = model.entry(kind).or_insert(([0.0; 3], 0));
                entry.0[0] += e.mad;
                entry.0[1] += e.mse;
                entry.0[2] += e.psnr;
                entry.1 += 1;
            }
            if let (Some((t, c)), Some(mean)) = (truth(&bundle, reference, kind), means.get(&kind))
            {
                let constant: Vec<f32> = (0..t.len()).map(|j| mean[j % c]).collect();
                if let Some(e) = error_metrics(&constant, &t, &m, c) {
                    let entry = base.entry(kind).or_insert(([0.0; 3], 0));
                    entry.0[0] += e.mad;
                    entry.0[1] += e.mse;
                    entry.0[2] += e.psnr;
                    entry.1 += 1;
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&out_root);
    let thesis = |k: ParamKind| match k {
        ParamKind::Basecolor => "0.0506",
        ParamKind::Roughness => "0.0570",
        ParamKind::Metallic => "0.0656",
        ParamKind::Transmission => "0.0461",
        ParamKind::Subsurface => "0.0212",
    };
    println!(
        "{} held-out scenes, {:.2} s per estimate on average\n",
        heldout.len(),
        seconds / heldout.len().max(1) as f64
    );
    println!("| parameter | scenes | MAD | MSE | PSNR dB | baseline MAD | baseline MSE | baseline PSNR dB | thesis MAD |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    for kind in ParamKind::ALL {
        let (m, n) = model.get(&kind).copied().unwrap_or(([f64::NAN; 3], 0));
        let (b, nb) = base.get(&kind).copied().unwrap_or(([f64::NAN; 3], 0));
        let (n, nb) = (n.max(1) as f64, nb.max(1) as f64);
        println!(
            "| {kind} | {} | {:.4} | {:.4} | {:.1} | {:.4} | {:.4} | {:.1} | {} |",
            model.get(&kind).map_or(0, |v| v.1),
            m[0] / n,
            m[1] / n,
            m[2] / n,
            b[0] / nb,
            b[1] / nb,
            b[2] / nb,
            thesis(kind)
        );
    }
    Ok(())
}

fn tempfile_dir() -> Result<PathBuf, std::io::Error> {
    let dir = std::env::temp_dir().join(format!("matscan-evaluate-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}
