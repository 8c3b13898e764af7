//! Measures the refinement stage on simulated scans with truth: each scan
//! is estimated twice through the pipeline, network-only and with
//! `EstimateOptions::refine`, and the MAD per parameter (from
//! `result.toml`'s metrics, over the truth mask of the reference) and the
//! total estimate time of both are compared. Prints one row per scan, then
//! medians and means.
//!
//! ```text
//! cargo run --release -p matscan-evaluate --example refine_eval -- \
//!     data/heldout-64 [iterations=10] [calibration|network] [limit]
//! ```
//!
//! `REFINE_PRIOR=basecolor,ln_roughness,metallic` (prior sigmas) and
//! `REFINE_NOISE=abs,rel,huber_k` override the defaults, for tuning.

use matscan_estimate::refine::{IlluminationSource, RefineOptions};
use matscan_estimate::{cpu_device, estimate, EstimateOptions, ModelSource};
use std::path::{Path, PathBuf};

/// Network-only total seconds, refined total seconds, refinement seconds,
/// and per parameter the network-only and refined MAD.
type Row = (f64, f64, f64, Vec<(f64, f64)>);

fn scans(root: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        if dir.join("scan.toml").exists() {
            out.push(dir);
            continue;
        }
        if let Ok(entries) = std::fs::read_dir(&dir) {
            for e in entries.flatten() {
                if e.path().is_dir() {
                    stack.push(e.path());
                }
            }
        }
    }
    out.sort();
    out
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn triple(var: &str) -> Option<[f64; 3]> {
    let s = std::env::var(var).ok()?;
    let v: Vec<f64> = s.split(',').filter_map(|x| x.parse().ok()).collect();
    (v.len() == 3).then(|| [v[0], v[1], v[2]])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root = PathBuf::from(args.get(1).map_or("data/heldout-64", String::as_str));
    let iterations: u32 = args.get(2).map_or(Ok(10), |s| s.parse())?;
    let illumination = match args.get(3).map(String::as_str) {
        Some("network") => IlluminationSource::Network,
        _ => IlluminationSource::Calibration,
    };
    let limit: usize = args.get(4).map_or(Ok(usize::MAX), |s| s.parse())?;
    let mut refine = RefineOptions {
        iterations,
        illumination,
        ..RefineOptions::default()
    };
    if let Some([b, r, m]) = triple("REFINE_PRIOR") {
        refine.prior_sigma.basecolor = b;
        refine.prior_sigma.ln_roughness = r;
        refine.prior_sigma.metallic = m;
    }
    if let Some([a, r, k]) = triple("REFINE_NOISE") {
        refine.noise_abs = a;
        refine.noise_rel = r;
        refine.huber_k = k;
    }
    eprintln!("{refine:?}");
    let device = cpu_device();
    let tmp = std::env::temp_dir().join(format!("refine_eval_{}", std::process::id()));
    let names: Vec<&str> = matscan_estimate::PIPELINE_ORDER
        .iter()
        .map(|k| k.name())
        .collect();
    println!(
        "scan,net_total_s,refined_total_s,refine_s,{}",
        names
            .iter()
            .map(|n| format!("{n}_net,{n}_refined"))
            .collect::<Vec<_>>()
            .join(",")
    );
    let mut rows: Vec<Row> = Vec::new();
    for scan in scans(&root).into_iter().take(limit) {
        let out = tmp.join("estimate");
        let run = |refine: RefineOptions| {
            estimate(
                &scan,
                ModelSource::Embedded,
                &EstimateOptions {
                    out: Some(out.clone()),
                    refine,
                    ..EstimateOptions::default()
                },
                &device,
            )
        };
        let net = run(RefineOptions::default())?.result;
        let refined = run(refine)?.result;
        let mad = |r: &matscan_estimate::ResultFile, n: &str| {
            r.metrics.get(n).map_or(f64::NAN, |m| m.mad)
        };
        let per: Vec<(f64, f64)> = names
            .iter()
            .map(|n| (mad(&net, n), mad(&refined, n)))
            .collect();
        println!(
            "{},{:.3},{:.3},{:.3},{}",
            scan.display(),
            net.timings.total_s,
            refined.timings.total_s,
            refined.timings.refine_s,
            per.iter()
                .map(|(a, b)| format!("{a:.4},{b:.4}"))
                .collect::<Vec<_>>()
                .join(",")
        );
        if let Some(s) = &refined.refine {
            eprintln!("  stops {:?}", s.stops);
        }
        rows.push((
            net.timings.total_s,
            refined.timings.total_s,
            refined.timings.refine_s,
            per,
        ));
    }
    let _ = std::fs::remove_dir_all(&tmp);
    println!("\nparameter,median_net,median_refined,mean_net,mean_refined");
    let mut fitted_net = Vec::new();
    let mut fitted_refined = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let a: Vec<f64> = rows
            .iter()
            .map(|r| r.3[k].0)
            .filter(|v| v.is_finite())
            .collect();
        let b: Vec<f64> = rows
            .iter()
            .map(|r| r.3[k].1)
            .filter(|v| v.is_finite())
            .collect();
        println!(
            "{name},{:.4},{:.4},{:.4},{:.4}",
            median(a.clone()),
            median(b.clone()),
            mean(&a),
            mean(&b)
        );
        if ["basecolor", "roughness", "metallic"].contains(name) {
            fitted_net.push(mean(&a));
            fitted_refined.push(mean(&b));
        }
    }
    println!(
        "mean MAD over basecolor, roughness, metallic: network {:.4}, refined {:.4}",
        mean(&fitted_net),
        mean(&fitted_refined)
    );
    let col = |f: fn(&Row) -> f64| rows.iter().map(f).collect();
    println!(
        "median total estimate time: network-only {:.3} s, refined {:.3} s (refinement {:.3} s, \
         {iterations} iterations, {illumination:?} light), {} scans",
        median(col(|r| r.0)),
        median(col(|r| r.1)),
        median(col(|r| r.2)),
        rows.len()
    );
    Ok(())
}
