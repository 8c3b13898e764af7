//! `matscan eval DATA`: the estimator's error against its run time over a
//! set of simulated scans (truth maps included), one row per parameter and
//! view configuration, as the thesis's tables 4.1 to 4.3 and section 4.6.
//!
//! Configurations: the first N views of each scan (reference position
//! first, in manifest order), for each N in `--views`; 0 means every view.
//! Beside each figure stands a trivial baseline, the constant map holding
//! the mean truth value of `--baseline-from` (the training set) or, without
//! it, of the evaluated set itself (which flatters the baseline, so the
//! estimator's gain over it is a lower bound), and the thesis's MAD.
//!
//! Run time is the estimate's own `total_s` (load, calibration, inputs,
//! weights, networks, metrics; writing excluded), as a median per scan.
//!
//! Boundaries: reads scans, calls `matscan_estimate::estimate` into a
//! scratch folder, prints; changes no scan.

use anyhow::{bail, Context, Result};
use clap::Args;
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_estimate::metrics::{error_metrics, ErrorMetrics};
use matscan_estimate::views::select_views;
use matscan_estimate::weights::EMBEDDED;
use matscan_estimate::{cpu_device, estimate, EstimateOptions, ModelSource, ParamKind, ViewFilter};
use matscan_scan::{Bundle, Param, TruthImage, TruthMap};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The thesis's Table 4.1 (ALL row): MAD per parameter.
pub const THESIS_MAD: [(ParamKind, f64); 5] = [
    (ParamKind::Basecolor, 0.0506),
    (ParamKind::Roughness, 0.0570),
    (ParamKind::Metallic, 0.0656),
    (ParamKind::Transmission, 0.0461),
    (ParamKind::Subsurface, 0.0212),
];

/// The flags of `matscan eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// A folder of simulated scans with truth maps (as `matscan simulate
    /// --dataset` writes).
    pub data: PathBuf,
    /// Folder with `<param>.weights` per network (default: the weights
    /// built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
    /// View counts to compare, comma-separated; 0 = every view.
    #[arg(long, value_delimiter = ',', default_value = "1,3,0")]
    pub views: Vec<usize>,
    /// A training set whose mean truth per parameter is the trivial
    /// baseline (default: the evaluated set's own mean).
    #[arg(long, value_name = "DIR")]
    pub baseline_from: Option<PathBuf>,
    /// Evaluate at most this many scans (in name order).
    #[arg(long)]
    pub limit: Option<usize>,
    /// Also write the table as CSV here.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
}

/// The scan folders under `dir` and its subfolders (one level, so a set
/// grouped by kind works), in path order.
pub fn scans_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let children = |d: &Path| -> Result<Vec<PathBuf>> {
        Ok(std::fs::read_dir(d)
            .with_context(|| format!("reading {}", d.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir())
            .collect())
    };
    let mut scans = Vec::new();
    for child in children(dir)? {
        if child.join("scan.toml").is_file() {
            scans.push(child);
        } else {
            scans.extend(
                children(&child)?
                    .into_iter()
                    .filter(|p| p.join("scan.toml").is_file()),
            );
        }
    }
    scans.sort();
    if scans.is_empty() {
        bail!(
            "{}: no scan folders (folders holding scan.toml) found, nor one level down",
            dir.display()
        );
    }
    Ok(scans)
}

/// One parameter's truth at one position: values (pixel-major, `channels`
/// per pixel) and the object mask.
struct Truth {
    values: Vec<f32>,
    mask: Vec<bool>,
    channels: usize,
}

fn truth_of(bundle: &Bundle, position: &str, kind: ParamKind) -> Result<Option<Truth>> {
    let Ok(param) = kind.name().parse::<Param>() else {
        return Ok(None);
    };
    let mask = match bundle.read_truth(position, &TruthMap::Mask)? {
        Some(m) => m.into_mask().map(|m| m.data),
        None => None,
    };
    let Some(mask) = mask else { return Ok(None) };
    let (values, channels) = match bundle.read_truth(position, &TruthMap::Param(param))? {
        Some(TruthImage::Rgb(r)) => (r.data.as_flattened().to_vec(), 3),
        Some(TruthImage::Scalar(r)) => (r.data, 1),
        _ => return Ok(None),
    };
    Ok(Some(Truth {
        values,
        mask,
        channels,
    }))
}

/// Mean masked truth value per parameter over every position of `scans`.
fn mean_truth(scans: &[PathBuf]) -> Result<BTreeMap<ParamKind, f64>> {
    let mut sums: BTreeMap<ParamKind, (f64, usize)> = BTreeMap::new();
    for scan in scans {
        let bundle = Bundle::open(scan)?;
        for position in &bundle.manifest.positions {
            for kind in ParamKind::ALL {
                let Some(Truth {
                    values,
                    mask,
                    channels,
                }) = truth_of(&bundle, &position.name, kind)?
                else {
                    continue;
                };
                let entry = sums.entry(kind).or_default();
                for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
                    for v in &values[i * channels..(i + 1) * channels] {
                        if v.is_finite() {
                            entry.0 += f64::from(*v);
                            entry.1 += 1;
                        }
                    }
                }
            }
        }
    }
    Ok(sums
        .into_iter()
        .filter(|(_, (_, n))| *n > 0)
        .map(|(k, (s, n))| (k, s / n as f64))
        .collect())
}

/// The usable views of `scan` (`position/capture`), reference position
/// first; `None` when none is usable.
fn all_views(scan: &Path) -> Result<Option<Vec<String>>> {
    let bundle = Bundle::open(scan)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())
        .with_context(|| format!("calibrating {}", scan.display()))?;
    Ok(
        select_views(&bundle.manifest, &calibration, &ViewFilter::default())
            .ok()
            .map(|set| set.views.iter().map(|v| v.to_string()).collect()),
    )
}

/// Sums of metrics for averaging.
#[derive(Default, Clone, Copy)]
struct Sum {
    mad: f64,
    mse: f64,
    psnr: f64,
    n: usize,
}

impl Sum {
    fn add(&mut self, m: &ErrorMetrics) {
        self.mad += m.mad;
        self.mse += m.mse;
        self.psnr += m.psnr;
        self.n += 1;
    }

    fn mean(&self) -> Option<(f64, f64, f64)> {
        (self.n > 0).then(|| {
            let n = self.n as f64;
            (self.mad / n, self.mse / n, self.psnr / n)
        })
    }
}

/// Runs `matscan eval`.
pub fn run(args: &EvalArgs) -> Result<()> {
    let mut scans = scans_in(&args.data)?;
    if let Some(limit) = args.limit {
        scans.truncate(limit);
    }
    let models = || match &args.weights {
        Some(dir) => ModelSource::Dir(dir.clone()),
        None => ModelSource::Embedded,
    };
    if args.weights.is_none() && EMBEDDED.is_empty() {
        bail!("this build embeds no trained weights; pass --weights DIR");
    }
    let baseline_scans = match &args.baseline_from {
        Some(dir) => scans_in(dir)?,
        None => scans.clone(),
    };
    let baseline = mean_truth(&baseline_scans)?;
    let scratch = std::env::temp_dir().join(format!("matscan-eval-{}", std::process::id()));
    let device = cpu_device();
    let thesis: BTreeMap<ParamKind, f64> = THESIS_MAD.into_iter().collect();

    let mut table = String::new();
    let mut csv = String::from("views,param,scans,mad,mse,psnr,baseline_mad,baseline_mse,baseline_psnr,thesis_mad,median_seconds\n");
    let _ = writeln!(
        table,
        "{} scans from {}; baseline: mean truth of {}",
        scans.len(),
        args.data.display(),
        args.baseline_from
            .as_deref()
            .unwrap_or(&args.data)
            .display()
    );
    // Every scan's usable views in order, calibrated once for all
    // configurations (`None` where the estimate itself will report why it
    // has none).
    let views_of: Vec<Option<Vec<String>>> = if args.views.iter().any(|&c| c > 0) {
        scans
            .iter()
            .map(|scan| all_views(scan))
            .collect::<Result<_>>()?
    } else {
        vec![None; scans.len()]
    };
    for &count in &args.views {
        let mut est: BTreeMap<ParamKind, Sum> = BTreeMap::new();
        let mut base: BTreeMap<ParamKind, Sum> = BTreeMap::new();
        let mut seconds = Vec::new();
        let mut failures = Vec::new();
        for (i, scan) in scans.iter().enumerate() {
            let filter = match (count, &views_of[i]) {
                (0, _) | (_, None) => ViewFilter::default(),
                (_, Some(all)) => ViewFilter {
                    positions: Vec::new(),
                    views: all.iter().take(count).cloned().collect(),
                },
            };
            let options = EstimateOptions {
                out: Some(scratch.join(format!("{count}-{i}"))),
                filter,
                ..EstimateOptions::default()
            };
            let report = match estimate(scan, models(), &options, &device) {
                Ok(r) => r,
                Err(e) => {
                    failures.push(format!("{}: {e}", scan.display()));
                    continue;
                }
            };
            let _ = std::fs::remove_dir_all(&report.out);
            seconds.push(report.result.timings.total_s);
            let bundle = Bundle::open(scan)?;
            for kind in ParamKind::ALL {
                if let Some(m) = report.result.metrics.get(kind.name()) {
                    est.entry(kind).or_default().add(m);
                    if let (Some(mean), Some(t)) = (
                        baseline.get(&kind),
                        truth_of(&bundle, &report.result.reference_position, kind)?,
                    ) {
                        let constant = vec![*mean as f32; t.values.len()];
                        if let Some(b) = error_metrics(&constant, &t.values, &t.mask, t.channels) {
                            base.entry(kind).or_default().add(&b);
                        }
                    }
                }
            }
        }
        let _ = std::fs::remove_dir_all(&scratch);
        seconds.sort_by(f64::total_cmp);
        let median = seconds.get(seconds.len() / 2).copied().unwrap_or(f64::NAN);
        let label = if count == 0 {
            "all views".to_string()
        } else {
            format!("{count} view{}", if count == 1 { "" } else { "s" })
        };
        let _ = writeln!(
            table,
            "\n{label}: median {median:.2} s per scan ({} estimated, {} failed)",
            seconds.len(),
            failures.len()
        );
        let _ = writeln!(
            table,
            "{:<13} {:>5} {:>8} {:>9} {:>7}   {:>8} {:>9} {:>7}   {:>8}",
            "parameter", "scans", "MAD", "MSE", "PSNR", "base MAD", "base MSE", "b PSNR", "thesis"
        );
        for kind in ParamKind::ALL {
            let Some((mad, mse, psnr)) = est.get(&kind).and_then(Sum::mean) else {
                let _ = writeln!(
                    table,
                    "{:<13} {:>5}   (not estimated on any scan)",
                    kind.name(),
                    0
                );
                continue;
            };
            let (bmad, bmse, bpsnr) =
                base.get(&kind)
                    .and_then(Sum::mean)
                    .unwrap_or((f64::NAN, f64::NAN, f64::NAN));
            let n = est[&kind].n;
            let _ = writeln!(
                table,
                "{:<13} {:>5} {:>8.4} {:>9.5} {:>7.2}   {:>8.4} {:>9.5} {:>7.2}   {:>8.4}",
                kind.name(),
                n,
                mad,
                mse,
                psnr,
                bmad,
                bmse,
                bpsnr,
                thesis[&kind]
            );
            let _ = writeln!(
                csv,
                "{count},{},{n},{mad},{mse},{psnr},{bmad},{bmse},{bpsnr},{},{median}",
                kind.name(),
                thesis[&kind]
            );
        }
        for f in failures.iter().take(5) {
            let _ = writeln!(table, "  failed: {f}");
        }
    }
    print!("{table}");
    if let Some(path) = &args.csv {
        matscan_scan::atomic::write_atomic(path, csv.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
