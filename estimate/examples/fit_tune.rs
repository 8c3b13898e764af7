//! The physical fit alone on every simulated scan under a folder, against
//! the truth: per scan the MAD of basecolor, roughness and metallic over
//! the object, and per fitted material its answer beside the truth of its
//! pixels (median). Transmission is fed its truth, so the numbers are the
//! fit's own. A development probe for tuning the fit on the `tune` set,
//! not part of the product (`matscan eval --method fit` is the measure).
//!
//!   cargo run --release -p matscan-estimate --example fit_tune -- DIR [--quiet]
//!       [--basecolor-pull P] [--saturation S] [--direct]

use matscan_estimate::fit::{fit_scene, FitLight, FitOptions, Known};
use matscan_scan::Param;
use std::path::Path;

mod support;
use support::median;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root =
        Path::new(args.get(1).ok_or(
            "usage: fit_tune DIR [--quiet] [--basecolor-pull P] [--saturation S] [--direct]",
        )?);
    let quiet = args.iter().any(|a| a == "--quiet");
    let list = matscan_scan::bundle::find_bundles(root)?;
    let mut options = FitOptions::default();
    let value = |flag: &str| -> Option<f64> {
        let k = args.iter().position(|a| a == flag)?;
        args.get(k + 1)?.parse().ok()
    };
    if let Some(v) = value("--basecolor-pull") {
        options.basecolor_pull = v;
    }
    if args.iter().any(|a| a == "--direct") {
        options.light = FitLight::Direct;
    }
    if let Some(v) = value("--saturation") {
        options.saturation = v as f32;
    }
    let mut table: Vec<(String, [f64; 3], f64)> = Vec::new();
    for scan in &list {
        let opened = support::open(scan)?;
        let (bundle, calibration, inputs) = (&opened.bundle, &opened.calibration, &opened.inputs);
        let truth = |k: Param| opened.truth(k);
        let (bc, r, m, t) = (
            truth(Param::Basecolor)?,
            truth(Param::Roughness)?,
            truth(Param::Metallic)?,
            truth(Param::Transmission)?,
        );
        let fitted = fit_scene(
            bundle,
            calibration,
            inputs,
            &t,
            Known::default(),
            None,
            &options,
        )?;
        let mask = &inputs.mask.data;
        let count = mask.iter().filter(|&&v| v).count().max(1) as f64;
        let mut mad = [0.0f64; 3];
        for i in (0..mask.len()).filter(|&i| mask[i]) {
            let b: f32 = (0..3)
                .map(|c| (fitted.basecolor[i][c] - bc[3 * i + c]).abs())
                .sum::<f32>()
                / 3.0;
            mad[0] += f64::from(b);
            mad[1] += f64::from((fitted.roughness[i] - r[i]).abs());
            mad[2] += f64::from((fitted.metallic[i] - m[i]).abs());
        }
        let mad = mad.map(|v| v / count);
        let name = scan
            .strip_prefix(root)
            .unwrap_or(scan)
            .display()
            .to_string();
        println!(
            "{name:40} basecolor {:.3} roughness {:.3} metallic {:.3}  {:.2} s",
            mad[0], mad[1], mad[2], fitted.seconds
        );
        if !quiet {
            for (j, mat) in fitted.materials.iter().enumerate() {
                let members: Vec<usize> = (0..mask.len())
                    .filter(|&i| fitted.labels[i] == Some(j))
                    .collect();
                let tr = median(members.iter().map(|&i| r[i]).collect());
                let tm = median(members.iter().map(|&i| m[i]).collect());
                let tb: [f32; 3] = std::array::from_fn(|c| {
                    median(members.iter().map(|&i| bc[3 * i + c]).collect())
                });
                println!(
                    "    material {j}: {:5} px{}  roughness {:.3} (truth {:.3}{})  metallic {} (truth {})  basecolor {:.2?} (truth {:.2?})",
                    mat.pixels,
                    if mat.scattering { " scattering" } else { "" },
                    mat.roughness,
                    tr,
                    if mat.roughness_pinned { "" } else { ", unpinned" },
                    mat.metallic,
                    tm,
                    mat.basecolor,
                    tb
                );
            }
        }
        table.push((name, mad, fitted.seconds));
    }
    let n = table.len().max(1) as f64;
    let mean: [f64; 3] = std::array::from_fn(|k| table.iter().map(|t| t.1[k]).sum::<f64>() / n);
    println!(
        "MEAN over {} scans: basecolor {:.4} roughness {:.4} metallic {:.4}  median {:.2} s",
        table.len(),
        mean[0],
        mean[1],
        mean[2],
        median(table.iter().map(|t| t.2 as f32).collect())
    );
    Ok(())
}
