//! The estimator's error (`matscan eval SCANS...`) against its run time over
//! simulated scans (truth maps included), as the thesis's tables 4.1 to 4.3
//! and section 4.6.
//!
//! Configurations: the first N views of each scan (reference position
//! first, in manifest order), for each N in `--views`; 0 means every view.
//! For each configuration it prints one row per parameter over every scan
//! (beside a trivial baseline, the constant map holding the mean truth value
//! of `--baseline-from` (the training set) or, without it, of the evaluated
//! set itself, which flatters the baseline, so the estimator's gain over it
//! is a lower bound; and the thesis's MAD), then MAD, MSE and PSNR per
//! parameter per scene group and overall (see [`tables`]), and with
//! `--per-scene` each scene's run time beside its errors. `--csv` writes
//! all of it as one tidy CSV whose `table` column says which table a row
//! belongs to (`overall`, `group`, `scene`).
//!
//! Run time is the estimate's own `total_s` (load, calibration, inputs,
//! weights, networks, metrics; writing excluded), as a median per scan.
//!
//! `--oracle SET` (repeatable) prints the error budget instead (see
//! [`budget`]): the chained estimate as it is and with each set of pieces
//! fed from the truth, at the last count of `--views`.
//!
//! `--dependencies truth` evaluates each network on its own, fed the truth
//! of what it reads, as the thesis's tables were measured (see
//! [`independent`]); the default runs the chained estimate a user gets.
//!
//! Boundaries: reads scans, calls `matscan_estimate::estimate` into a
//! scratch folder, returns the tables; changes no scan.

pub mod budget;
pub mod chained;
pub mod independent;
pub mod options;
pub mod report;
pub mod rig_error;
pub mod rig_from;
pub mod tables;
pub mod texture;
pub mod truth;

use crate::scans::{collect_scans, scans_in};
use anyhow::{bail, Context, Result};
use burn::tensor::Device;
use chained::{chained_configurations, Chained};
use matscan_estimate::net::weights::EMBEDDED;
use matscan_estimate::pipeline::oracle::Oracles;
use matscan_estimate::{cpu_device, Models};
use matscan_scan::Param;
pub use options::{DependencySource, EvalOptions, EvalReport};
use report::Configuration;
use report::{views_label, write_csv_rows, write_group_tables, write_overall, write_scene_table};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use tables::{family_rows, group_rows, CSV_HEADER};
use truth::mean_truth;

/// The thesis's Table 4.1 (ALL row): MAD per parameter.
pub const THESIS_MAD: [(Param, f64); 5] = [
    (Param::Basecolor, 0.0506),
    (Param::Roughness, 0.0570),
    (Param::Metallic, 0.0656),
    (Param::Transmission, 0.0461),
    (Param::Subsurface, 0.0212),
];

/// Runs the evaluation `args` describe.
pub fn run(args: &EvalOptions) -> Result<EvalReport> {
    let mut scans = collect_scans(&args.data)?;
    if let Some(limit) = args.limit {
        scans.truncate(limit);
    }
    if args.weights.is_none() && EMBEDDED.is_empty() {
        bail!("this build embeds no trained weights; pass --weights DIR");
    }
    if args.dependencies == DependencySource::Truth && args.textures.is_some() {
        bail!("--textures bakes the chained estimate; drop --dependencies truth");
    }
    if let (DependencySource::Truth, Some(method)) = (args.dependencies, args.method) {
        if method != matscan_estimate::pipeline::method::Method::Networks {
            bail!(
                "--dependencies truth measures each network alone; --method {method} applies \
                 to the chained estimate (drop one of them)"
            );
        }
    }
    if !args.oracles.is_empty() {
        if args.dependencies == DependencySource::Truth {
            bail!("--oracle feeds the chained estimate; drop --dependencies truth");
        }
        if args.textures.is_some() {
            bail!("--oracle scores the reference maps; drop --textures");
        }
    }
    let baseline_scans = match &args.baseline_from {
        Some(dir) => scans_in(dir)?,
        None => scans.clone(),
    };
    let baseline = mean_truth(&baseline_scans)?;
    let scratch = std::env::temp_dir().join(format!("matscan-eval-{}", std::process::id()));
    let device = cpu_device();
    let thesis: BTreeMap<Param, f64> = THESIS_MAD.into_iter().collect();
    let data_label = args
        .data
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ");

    let mut table = String::new();
    let mut csv = format!("{CSV_HEADER}\n");
    let _ = writeln!(
        table,
        "{} scans from {data_label}; baseline: mean truth of {}",
        scans.len(),
        args.baseline_from
            .as_ref()
            .map_or(data_label.clone(), |p| p.display().to_string())
    );
    let _ = writeln!(
        table,
        "dependencies: {}",
        match args.dependencies {
            DependencySource::Estimated => {
                "estimated (chained, as `matscan estimate`); the thesis's figures were \
                 measured with truth dependencies (--dependencies truth)"
            }
            DependencySource::Truth => {
                "truth (each network on its own, as the thesis's Tables 4.1 to 4.3)"
            }
        }
    );
    if !args.oracles.is_empty() {
        let budget = budget::run_budget(args, &scans, &baseline, &scratch, &device);
        table.push_str(&budget.table);
        return Ok(EvalReport {
            table,
            csv: budget.csv,
        });
    }
    let configurations = match args.dependencies {
        DependencySource::Estimated => {
            let runs: Vec<Chained> = args
                .views
                .iter()
                .map(|&views| Chained {
                    views,
                    oracle: Oracles::default(),
                })
                .collect();
            chained_configurations(args, &runs, &scans, &baseline, &scratch, &device)
        }
        DependencySource::Truth => {
            let models = match &args.weights {
                Some(dir) => Models::load_dir(dir, &matscan_estimate::PIPELINE_ORDER, &device),
                None => Models::load_embedded(&matscan_estimate::PIPELINE_ORDER, &device),
            }
            .context("loading the networks")?;
            independent_configurations(args, &scans, &models, &baseline, &device)
        }
    };
    let (what, done) = match args.dependencies {
        DependencySource::Estimated => ("per scan", "estimated"),
        DependencySource::Truth => ("of networks per scan, truth dependencies", "evaluated"),
    };
    for (count, c) in args.views.iter().copied().zip(configurations) {
        let rows = group_rows(&c.results);
        let label = views_label(count);
        let overall = rows.last().filter(|r| r.group == tables::ALL_GROUP);
        let _ = writeln!(
            table,
            "\n{label}: median {:.2} s {what} ({} {done}, {} failed)",
            overall.map_or(f64::NAN, |r| r.median_seconds),
            c.results.len(),
            c.failures.len()
        );
        if let Some(all) = overall {
            write_overall(&mut table, all, &thesis);
        }
        write_group_tables(&mut table, &rows, "scene group");
        let families = family_rows(&c.results);
        write_group_tables(&mut table, &families, "geometry family");
        if args.per_scene {
            write_scene_table(&mut table, &c.results);
        }
        for f in c.failures.iter().take(5) {
            let _ = writeln!(table, "  failed: {f}");
        }
        write_csv_rows(&mut csv, count, &rows, &families, &c.results, &thesis);
        if let Some(size) = args.textures {
            c.textures.write_table(&mut table, size);
            c.textures.write_csv(&mut csv, count);
        }
    }
    Ok(EvalReport { table, csv })
}

/// Every configuration of `views` with each network fed the truth
/// (see [`independent`]); each scan is prepared once for all of them.
fn independent_configurations(
    args: &EvalOptions,
    scans: &[PathBuf],
    models: &Models,
    baseline: &BTreeMap<Param, f64>,
    device: &Device,
) -> Vec<Configuration> {
    let mut out: Vec<Configuration> = args
        .views
        .iter()
        .map(|_| Configuration::default())
        .collect();
    for scan in scans {
        match independent::evaluate_scene_independent(
            scan,
            models,
            &args.views,
            device,
            args.group_by,
            baseline,
        ) {
            Ok(results) => {
                for (c, r) in out.iter_mut().zip(results) {
                    c.results.push(r);
                }
            }
            Err(e) => {
                for c in &mut out {
                    c.failures.push(format!("{e:#}"));
                }
            }
        }
    }
    out
}
