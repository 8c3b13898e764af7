//! The chained estimate a user gets (`matscan estimate`, every network fed
//! the estimates before it, the thesis's section 4.8), scored against the
//! truth scan by scan.

use super::options::EvalOptions;
use super::report::Configuration;
use super::tables::{geometry_family, scene_group, GroupBy, SceneResult};
use crate::scans::{usable_views, view_filter};
use anyhow::{Context, Result};
use burn::tensor::Device;
use matscan_estimate::pipeline::metrics::error_metrics;
use matscan_estimate::pipeline::oracle::Oracles;
use matscan_estimate::pipeline::run::{estimate_prepared, PreparedScan};
use matscan_estimate::{EstimateOptions, ModelSource, References};
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    baseline: Option<&BTreeMap<Param, f64>>,
) -> Result<SceneResult> {
    let prepared = PreparedScan::open(scan, &options.calib)
        .with_context(|| format!("estimating {}", scan.display()))?;
    evaluate_prepared(
        &prepared,
        models,
        options,
        device,
        group_by,
        baseline,
        &mut |_, _, _| {},
    )
}

/// [`evaluate_scene`] of a scan opened and calibrated once (with
/// `options.calib`) for every configuration, handing the prepared scan,
/// the estimate's folder and the reference position to `inspect` before
/// the folder is removed (`--textures` scores the estimate there).
pub fn evaluate_prepared(
    prepared: &PreparedScan,
    models: ModelSource,
    options: &EstimateOptions,
    device: &Device,
    group_by: GroupBy,
    baseline: Option<&BTreeMap<Param, f64>>,
    inspect: &mut dyn FnMut(&PreparedScan, &Path, &str),
) -> Result<SceneResult> {
    let bundle = &prepared.bundle;
    let scan = bundle.root.as_path();
    let report = estimate_prepared(prepared, models, options, device)
        .with_context(|| format!("estimating {}", scan.display()))?;
    let reference = report.result.reference_position.as_str();
    inspect(prepared, &report.out, reference);
    let _ = std::fs::remove_dir_all(&report.out);
    let mut result = SceneResult {
        scan: scan.to_path_buf(),
        group: scene_group(&bundle.manifest.name, group_by),
        family: geometry_family(&bundle.manifest.name),
        seconds: report.result.timings.total_s,
        measure_seconds: report.result.timings.backlight_s + report.result.timings.scattering_s,
        metrics: BTreeMap::new(),
        baseline: BTreeMap::new(),
    };
    // The truth mask is read once, and only when a baseline is compared.
    let mask = match baseline {
        Some(_) => bundle.truth_mask(reference)?.map(|m| m.data),
        None => None,
    };
    for kind in matscan_estimate::PIPELINE_ORDER {
        let Some(m) = report.result.metrics.get(kind.name()) else {
            continue;
        };
        result.metrics.insert(kind, *m);
        let (Some(mean), Some(mask)) = (baseline.and_then(|b| b.get(&kind)), mask.as_deref())
        else {
            continue;
        };
        let Some(truth) = bundle.truth_param(reference, kind)? else {
            continue;
        };
        let (values, channels) = truth.flat();
        let constant = vec![*mean as f32; values.len()];
        if let Some(b) = error_metrics(&constant, values, mask, channels) {
            result.baseline.insert(kind, b);
        }
    }
    Ok(result)
}

/// One configuration of the chained estimate: the first `views` views of
/// each scan (0: every view), fed `oracle`'s pieces of the truth.
#[derive(Clone, Debug)]
pub(super) struct Chained {
    pub views: usize,
    pub oracle: Oracles,
}

/// Every configuration of `runs` through the chained estimate; each scan
/// is opened and calibrated once for listing its views and for every
/// configuration.
pub(super) fn chained_configurations(
    args: &EvalOptions,
    runs: &[Chained],
    scans: &[PathBuf],
    baseline: &BTreeMap<Param, f64>,
    scratch: &Path,
    device: &Device,
) -> Vec<Configuration> {
    let mut out: Vec<Configuration> = runs.iter().map(|_| Configuration::default()).collect();
    let lists_views = runs.iter().any(|r| r.views > 0);
    // Every configuration estimates with these calibration options, so the
    // one calibration serves them all.
    let calib = EstimateOptions::default().calib;
    for (i, scan) in scans.iter().enumerate() {
        let adjust = |m: &mut matscan_scan::Manifest| {
            if let Some(from) = &args.rig_from {
                let file = super::rig_from::rig_file_for(from, scan);
                let (rig, _) = matscan_scan::Manifest::read_rig(&file)?;
                m.adopt_rig(&rig, &file)?;
            }
            if let Some(e) = args.rig_error {
                e.apply(m);
            }
            Ok(())
        };
        let prepared = match PreparedScan::open_adjusted(scan, &calib, &adjust) {
            Ok(p) => p,
            Err(e) => {
                for c in &mut out {
                    c.failures
                        .push(format!("estimating {}: {e}", scan.display()));
                }
                continue;
            }
        };
        let all = if lists_views {
            usable_views(&prepared)
        } else {
            None
        };
        for (k, (c, run)) in out.iter_mut().zip(runs).enumerate() {
            let options = EstimateOptions {
                // Texture scores bake what `matscan export` bakes: maps of
                // every position (one network pass per position).
                references: if args.textures.is_some() {
                    References::Every
                } else {
                    References::First
                },
                calib,
                oracle: run.oracle.clone(),
                ..args.estimate_options(
                    scratch.join(format!("{k}-{i}")),
                    view_filter(run.views, all.as_deref()),
                )
            };
            let textures = &mut c.textures;
            match evaluate_prepared(
                &prepared,
                args.models(),
                &options,
                device,
                args.group_by,
                Some(baseline),
                &mut |prepared, out, reference| {
                    if let Some(size) = args.textures {
                        textures.add_scan(prepared, out, reference, size);
                    }
                },
            ) {
                Ok(r) => c.results.push(r),
                Err(e) => c.failures.push(format!("{e:#}")),
            }
        }
    }
    let _ = std::fs::remove_dir_all(scratch);
    out
}
