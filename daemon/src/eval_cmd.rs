//! `matscan eval SCANS...`: the estimator's error against its run time over
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
//! parameter per scene group and overall (see `eval_tables`), and with
//! `--per-scene` each scene's run time beside its errors. `--csv` writes
//! all of it as one tidy CSV whose `table` column says which table a row
//! belongs to (`overall`, `group`, `scene`).
//!
//! Run time is the estimate's own `total_s` (load, calibration, inputs,
//! weights, networks, metrics; writing excluded), as a median per scan.
//!
//! `--dependencies truth` evaluates each network on its own, fed the truth
//! of what it reads, as the thesis's tables were measured (see
//! `eval_independent`); the default runs the chained estimate a user gets.
//!
//! Boundaries: reads scans, calls `matscan_estimate::estimate` into a
//! scratch folder, prints; changes no scan.

use crate::eval_tables::{
    csv_field, csv_number, group_rows, scene_group, GroupBy, GroupRow, SceneResult,
};
use anyhow::{bail, Context, Result};
use burn::tensor::Device;
use clap::Args;
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_estimate::metrics::error_metrics;
use matscan_estimate::views::select_views;
use matscan_estimate::weights::EMBEDDED;
use matscan_estimate::{
    cpu_device, estimate, EstimateOptions, ModelSource, Models, ParamKind, References, ViewFilter,
};
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
    /// Simulated scans with truth maps: scan folders, or folders of them
    /// (as `matscan simulate --dataset` writes, also one level deeper).
    #[arg(required = true, value_name = "SCANS")]
    pub data: Vec<PathBuf>,
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
    /// Also write every table as one CSV here (column `table`: overall,
    /// group or scene).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Rows of the per-group tables: the scene kind, or kind and geometry.
    #[arg(long, value_enum, default_value_t = GroupBy::Kind)]
    pub group_by: GroupBy,
    /// Also print each scene's run time beside its errors (the CSV always
    /// has them).
    #[arg(long)]
    pub per_scene: bool,
    /// Where each network's dependencies come from.
    #[arg(long, value_enum, default_value_t = DependencySource::Estimated)]
    pub dependencies: DependencySource,
    #[command(flatten)]
    pub textures: crate::eval_texture::TextureArgs,
}

/// What the networks that read other parameters are fed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum DependencySource {
    /// The other networks' estimates: the product's chained path (what
    /// `matscan estimate` does; the thesis's section 4.8).
    #[default]
    Estimated,
    /// The truth: each network on its own, as the thesis measured its
    /// Tables 4.1 to 4.3 (section 4.5); run time is the networks' alone.
    Truth,
}

/// The scans named by `paths`: each a scan folder itself, or a folder of
/// scans (see [`scans_in`]); in order, without repeats.
pub fn collect_scans(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut scans = Vec::new();
    for path in paths {
        if path.join("scan.toml").is_file() {
            scans.push(path.clone());
        } else {
            scans.extend(scans_in(path)?);
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    scans.retain(|s| seen.insert(s.clone()));
    Ok(scans)
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

/// The object mask of `position`'s truth; `None` without one.
pub(crate) fn truth_mask(bundle: &Bundle, position: &str) -> Result<Option<Vec<bool>>> {
    Ok(match bundle.read_truth(position, &TruthMap::Mask)? {
        Some(m) => m.into_mask().map(|m| m.data),
        None => None,
    })
}

/// One parameter's truth at one position: values (pixel-major) and
/// channels per pixel; `None` without a truth map for it.
pub(crate) fn truth_values(
    bundle: &Bundle,
    position: &str,
    kind: ParamKind,
) -> Result<Option<(Vec<f32>, usize)>> {
    let Ok(param) = kind.name().parse::<Param>() else {
        return Ok(None);
    };
    Ok(
        match bundle.read_truth(position, &TruthMap::Param(param))? {
            Some(TruthImage::Rgb(r)) => Some((r.data.as_flattened().to_vec(), 3)),
            Some(TruthImage::Scalar(r)) => Some((r.data, 1)),
            _ => None,
        },
    )
}

/// Mean masked truth value per parameter over every position of `scans`
/// (each position's mask read once for all parameters).
fn mean_truth(scans: &[PathBuf]) -> Result<BTreeMap<ParamKind, f64>> {
    let mut sums: BTreeMap<ParamKind, (f64, usize)> = BTreeMap::new();
    for scan in scans {
        let bundle = Bundle::open(scan)?;
        for position in &bundle.manifest.positions {
            let Some(mask) = truth_mask(&bundle, &position.name)? else {
                continue;
            };
            for kind in ParamKind::ALL {
                let Some((values, channels)) = truth_values(&bundle, &position.name, kind)? else {
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
/// first; `None` when none is usable. `matscan bench` uses it too.
pub fn all_views(scan: &Path) -> Result<Option<Vec<String>>> {
    let bundle = Bundle::open(scan)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())
        .with_context(|| format!("calibrating {}", scan.display()))?;
    Ok(
        select_views(&bundle.manifest, &calibration, &ViewFilter::default())
            .ok()
            .map(|set| set.views.iter().map(|v| v.to_string()).collect()),
    )
}

/// The view filter of configuration `count` (0 = every view) for a scan
/// whose usable views are `all` (`None`: let the estimate pick and report).
pub fn view_filter(count: usize, all: Option<&[String]>) -> ViewFilter {
    match (count, all) {
        (0, _) | (_, None) => ViewFilter::default(),
        (_, Some(all)) => ViewFilter {
            positions: Vec::new(),
            views: all.iter().take(count).cloned().collect(),
        },
    }
}

/// The usable views of each of `scans` when any of `counts` needs them.
pub fn views_of_scans(scans: &[PathBuf], counts: &[usize]) -> Result<Vec<Option<Vec<String>>>> {
    if counts.iter().any(|&c| c > 0) {
        scans.iter().map(|scan| all_views(scan)).collect()
    } else {
        Ok(vec![None; scans.len()])
    }
}

/// Estimates `scan` with `options` and compares with its truth; the
/// baseline (a constant map per parameter) is compared too where given.
/// The estimate's folder is removed again. An `Err` is a scan that could
/// not be estimated (the caller counts it as failed).
pub fn evaluate_scene(
    scan: &Path,
    models: ModelSource,
    options: &EstimateOptions,
    device: &Device,
    group_by: GroupBy,
    baseline: Option<&BTreeMap<ParamKind, f64>>,
) -> Result<SceneResult> {
    evaluate_scene_with(
        scan,
        models,
        options,
        device,
        group_by,
        baseline,
        &mut |_, _, _| {},
    )
}

/// [`evaluate_scene`], handing the opened scan, the estimate's folder and
/// the reference position to `inspect` before the folder is removed
/// (`--textures` scores the estimate there).
pub fn evaluate_scene_with(
    scan: &Path,
    models: ModelSource,
    options: &EstimateOptions,
    device: &Device,
    group_by: GroupBy,
    baseline: Option<&BTreeMap<ParamKind, f64>>,
    inspect: &mut dyn FnMut(&Bundle, &Path, &str),
) -> Result<SceneResult> {
    let bundle = Bundle::open(scan)?;
    let report = estimate(scan, models, options, device)
        .with_context(|| format!("estimating {}", scan.display()))?;
    let reference = report.result.reference_position.as_str();
    inspect(&bundle, &report.out, reference);
    let _ = std::fs::remove_dir_all(&report.out);
    let mut result = SceneResult {
        scan: scan.to_path_buf(),
        group: scene_group(&bundle.manifest.name, group_by),
        seconds: report.result.timings.total_s,
        metrics: BTreeMap::new(),
        baseline: BTreeMap::new(),
    };
    // The truth mask is read once, and only when a baseline is compared.
    let mask = match baseline {
        Some(_) => truth_mask(&bundle, reference)?,
        None => None,
    };
    for kind in ParamKind::ALL {
        let Some(m) = report.result.metrics.get(kind.name()) else {
            continue;
        };
        result.metrics.insert(kind, *m);
        let (Some(mean), Some(mask)) = (baseline.and_then(|b| b.get(&kind)), mask.as_deref())
        else {
            continue;
        };
        let Some((values, channels)) = truth_values(&bundle, reference, kind)? else {
            continue;
        };
        let constant = vec![*mean as f32; values.len()];
        if let Some(b) = error_metrics(&constant, &values, mask, channels) {
            result.baseline.insert(kind, b);
        }
    }
    Ok(result)
}

/// "1 view", "3 views", "all views".
pub fn views_label(count: usize) -> String {
    match count {
        0 => "all views".to_string(),
        1 => "1 view".to_string(),
        n => format!("{n} views"),
    }
}

/// Header of the CSV `--csv` writes.
pub const CSV_HEADER: &str = "table,views,group,scan,param,scans,mad,mse,psnr,baseline_mad,baseline_mse,baseline_psnr,thesis_mad,seconds,ssim";

/// Runs `matscan eval`.
pub fn run(args: &EvalArgs) -> Result<()> {
    let mut scans = collect_scans(&args.data)?;
    if let Some(limit) = args.limit {
        scans.truncate(limit);
    }
    if args.weights.is_none() && EMBEDDED.is_empty() {
        bail!("this build embeds no trained weights; pass --weights DIR");
    }
    if args.dependencies == DependencySource::Truth && args.textures.textures.is_some() {
        bail!("--textures bakes the chained estimate; drop --dependencies truth");
    }
    let baseline_scans = match &args.baseline_from {
        Some(dir) => scans_in(dir)?,
        None => scans.clone(),
    };
    let baseline = mean_truth(&baseline_scans)?;
    let scratch = std::env::temp_dir().join(format!("matscan-eval-{}", std::process::id()));
    let device = cpu_device();
    let thesis: BTreeMap<ParamKind, f64> = THESIS_MAD.into_iter().collect();
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
    let configurations = match args.dependencies {
        DependencySource::Estimated => {
            // Every scan's usable views in order, calibrated once for all
            // configurations.
            let views_of = views_of_scans(&scans, &args.views)?;
            chained_configurations(args, &scans, &views_of, &baseline, &scratch, &device)
        }
        DependencySource::Truth => {
            let models = match &args.weights {
                Some(dir) => Models::load_dir(dir, &ParamKind::ALL, &device),
                None => Models::load_embedded(&ParamKind::ALL, &device),
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
        let overall = rows
            .last()
            .filter(|r| r.group == crate::eval_tables::ALL_GROUP);
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
        write_group_tables(&mut table, &rows);
        if args.per_scene {
            write_scene_table(&mut table, &c.results);
        }
        for f in c.failures.iter().take(5) {
            let _ = writeln!(table, "  failed: {f}");
        }
        write_csv_rows(&mut csv, count, &rows, &c.results, &thesis);
        if let Some(size) = args.textures.textures {
            c.textures.write_table(&mut table, size);
            c.textures.write_csv(&mut csv, count);
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

/// One view-count configuration's scene results, failures and texture
/// scores.
#[derive(Default)]
struct Configuration {
    results: Vec<SceneResult>,
    failures: Vec<String>,
    textures: crate::eval_texture::TextureTable,
}

/// Every configuration of `args.views` through the chained estimate.
fn chained_configurations(
    args: &EvalArgs,
    scans: &[PathBuf],
    views_of: &[Option<Vec<String>>],
    baseline: &BTreeMap<ParamKind, f64>,
    scratch: &Path,
    device: &Device,
) -> Vec<Configuration> {
    let models = || match &args.weights {
        Some(dir) => ModelSource::Dir(dir.clone()),
        None => ModelSource::Embedded,
    };
    let mut out = Vec::with_capacity(args.views.len());
    for &count in &args.views {
        let mut c = Configuration::default();
        for (i, scan) in scans.iter().enumerate() {
            let options = EstimateOptions {
                out: Some(scratch.join(format!("{count}-{i}"))),
                filter: view_filter(count, views_of[i].as_deref()),
                // Texture scores bake what `matscan export` bakes: maps of
                // every position (one network pass per position).
                references: if args.textures.textures.is_some() {
                    References::Every
                } else {
                    References::First
                },
                ..EstimateOptions::default()
            };
            let textures = &mut c.textures;
            match evaluate_scene_with(
                scan,
                models(),
                &options,
                device,
                args.group_by,
                Some(baseline),
                &mut |bundle, out, reference| {
                    if let Some(size) = args.textures.textures {
                        textures.add_scan(bundle, out, reference, size);
                    }
                },
            ) {
                Ok(r) => c.results.push(r),
                Err(e) => c.failures.push(format!("{e:#}")),
            }
        }
        let _ = std::fs::remove_dir_all(scratch);
        out.push(c);
    }
    out
}

/// Every configuration of `args.views` with each network fed the truth
/// (see `eval_independent`); each scan is prepared once for all of them.
fn independent_configurations(
    args: &EvalArgs,
    scans: &[PathBuf],
    models: &Models,
    baseline: &BTreeMap<ParamKind, f64>,
    device: &Device,
) -> Vec<Configuration> {
    let mut out: Vec<Configuration> = args
        .views
        .iter()
        .map(|_| Configuration::default())
        .collect();
    for scan in scans {
        match crate::eval_independent::evaluate_scene_independent(
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

/// The `ALL` row per parameter beside the baseline and the thesis.
fn write_overall(table: &mut String, all: &GroupRow, thesis: &BTreeMap<ParamKind, f64>) {
    let _ = writeln!(
        table,
        "{:<13} {:>5} {:>8} {:>9} {:>7}   {:>8} {:>9} {:>7}   {:>8}",
        "parameter", "scans", "MAD", "MSE", "PSNR", "base MAD", "base MSE", "b PSNR", "thesis"
    );
    for kind in ParamKind::ALL {
        let Some(m) = all.estimate.get(&kind) else {
            let _ = writeln!(
                table,
                "{:<13} {:>5}   (not estimated on any scan)",
                kind.name(),
                0
            );
            continue;
        };
        let (bmad, bmse, bpsnr) = all
            .baseline
            .get(&kind)
            .map_or((f64::NAN, f64::NAN, f64::NAN), |b| (b.mad, b.mse, b.psnr));
        let _ = writeln!(
            table,
            "{:<13} {:>5} {:>8.4} {:>9.5} {:>7.2}   {:>8.4} {:>9.5} {:>7.2}   {:>8.4}",
            kind.name(),
            m.n,
            m.mad,
            m.mse,
            m.psnr,
            bmad,
            bmse,
            bpsnr,
            thesis.get(&kind).copied().unwrap_or(f64::NAN)
        );
    }
}

/// Tables 4.1 to 4.3: one per metric, a row per group and `ALL`, a column
/// per parameter, and the group's median run time.
fn write_group_tables(table: &mut String, rows: &[GroupRow]) {
    let width = rows.iter().map(|r| r.group.len()).max().unwrap_or(0).max(7);
    type Pick = fn(&crate::eval_tables::Means) -> f64;
    let metrics: [(&str, Pick, usize); 3] = [
        ("MAD", |m| m.mad, 4),
        ("MSE", |m| m.mse, 5),
        ("PSNR", |m| m.psnr, 2),
    ];
    for (name, pick, decimals) in metrics {
        let _ = write!(
            table,
            "\n{name} by scene group\n{:<width$} {:>3}",
            "group", "#"
        );
        for kind in ParamKind::ALL {
            let _ = write!(table, " {:>12}", kind.name());
        }
        let _ = writeln!(table, " {:>9}", "median s");
        for row in rows {
            let _ = write!(table, "{:<width$} {:>3}", row.group, row.scenes);
            for kind in ParamKind::ALL {
                match row.estimate.get(&kind) {
                    Some(m) => {
                        let _ = write!(table, " {:>12.decimals$}", pick(m));
                    }
                    None => {
                        let _ = write!(table, " {:>12}", "-");
                    }
                }
            }
            let _ = writeln!(table, " {:>9.2}", row.median_seconds);
        }
    }
}

/// Each scene's run time beside its MAD per parameter.
fn write_scene_table(table: &mut String, results: &[SceneResult]) {
    let name = |r: &SceneResult| {
        r.scan
            .file_name()
            .map_or(r.scan.display().to_string(), |n| {
                n.to_string_lossy().into_owned()
            })
    };
    let width = results
        .iter()
        .map(|r| name(r).len())
        .max()
        .unwrap_or(0)
        .max(5);
    let _ = write!(
        table,
        "\nper scene: run time and MAD\n{:<width$} {:<18} {:>8}",
        "scene", "group", "seconds"
    );
    for kind in ParamKind::ALL {
        let _ = write!(table, " {:>12}", kind.name());
    }
    let _ = writeln!(table);
    for r in results {
        let _ = write!(
            table,
            "{:<width$} {:<18} {:>8.2}",
            name(r),
            r.group,
            r.seconds
        );
        for kind in ParamKind::ALL {
            match r.metrics.get(&kind) {
                Some(m) => {
                    let _ = write!(table, " {:>12.4}", m.mad);
                }
                None => {
                    let _ = write!(table, " {:>12}", "-");
                }
            }
        }
        let _ = writeln!(table);
    }
}

/// The tidy CSV rows of one view configuration: `overall` (the ALL row with
/// baseline and thesis), `group` (each group) and `scene` (each scene).
fn write_csv_rows(
    csv: &mut String,
    count: usize,
    rows: &[GroupRow],
    results: &[SceneResult],
    thesis: &BTreeMap<ParamKind, f64>,
) {
    for row in rows {
        let table = if row.group == crate::eval_tables::ALL_GROUP {
            "overall"
        } else {
            "group"
        };
        for kind in ParamKind::ALL {
            let Some(m) = row.estimate.get(&kind) else {
                continue;
            };
            let b = row.baseline.get(&kind);
            let _ = writeln!(
                csv,
                "{table},{count},{},,{},{},{},{},{},{},{},{},{},{},",
                csv_field(&row.group),
                kind.name(),
                m.n,
                csv_number(Some(m.mad)),
                csv_number(Some(m.mse)),
                csv_number(Some(m.psnr)),
                csv_number(b.map(|b| b.mad)),
                csv_number(b.map(|b| b.mse)),
                csv_number(b.map(|b| b.psnr)),
                csv_number(thesis.get(&kind).copied()),
                csv_number(Some(row.median_seconds)),
            );
        }
    }
    for r in results {
        for (kind, m) in &r.metrics {
            let b = r.baseline.get(kind);
            let _ = writeln!(
                csv,
                "scene,{count},{},{},{},1,{},{},{},{},{},{},{},{},",
                csv_field(&r.group),
                csv_field(&r.scan.display().to_string()),
                kind.name(),
                csv_number(Some(m.mad)),
                csv_number(Some(m.mse)),
                csv_number(Some(m.psnr)),
                csv_number(b.map(|b| b.mad)),
                csv_number(b.map(|b| b.mse)),
                csv_number(b.map(|b| b.psnr)),
                csv_number(thesis.get(kind).copied()),
                csv_number(Some(r.seconds)),
            );
        }
    }
}
