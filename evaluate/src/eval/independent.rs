//! Every network evaluated on its own (`matscan eval --dependencies truth`),
//! fed the truth of the parameters it depends on, as the thesis measured its
//! Tables 4.1 to 4.3 (section 4.5: "we evaluated them independently").
//!
//! The default `--dependencies estimated` runs the product's chained path
//! (`matscan_estimate::estimate`, the thesis's section 4.8), where each
//! network reads the estimates before it and their errors add up; only the
//! truth-fed figures are comparable with the thesis's table.
//!
//! Run time here is the networks' forward passes only (no calibration or
//! input assembly, which the scene loader does once per scan for every
//! network and view count).
//!
//! Boundaries: reads scans; the inputs come from
//! `matscan_estimate::pipeline::truth_fed::load_scenes` (built on the inference
//! code's input assembly, as training uses it), predictions from
//! `truth_fed::predict`; tables are the module root's.

use super::tables::{geometry_family, scene_group, GroupBy, SceneResult};
use anyhow::{Context, Result};
use burn::tensor::Device;
use matscan_estimate::pipeline::metrics::error_metrics;
use matscan_estimate::pipeline::truth_fed::{load_scenes, predict};
use matscan_estimate::Models;
use matscan_scan::Bundle;
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

/// One scan evaluated network by network for each of `counts` (0 = every
/// view): a result per count, in `counts` order. A network whose inputs
/// the scan lacks (transmission without a backlit capture) is left out of
/// the metrics, as the chained path skips it. An `Err` is a scan that could
/// not be prepared (the caller counts it as failed).
pub fn evaluate_scene_independent(
    scan: &Path,
    models: &Models,
    counts: &[usize],
    device: &Device,
    group_by: GroupBy,
    baseline: &BTreeMap<Param, f64>,
) -> Result<Vec<SceneResult>> {
    let bundle = Bundle::open(scan)?;
    let group = scene_group(&bundle.manifest.name, group_by);
    let family = geometry_family(&bundle.manifest.name);
    let mut results: Vec<SceneResult> = counts
        .iter()
        .map(|_| SceneResult {
            scan: scan.to_path_buf(),
            group: group.clone(),
            family: family.clone(),
            seconds: 0.0,
            measure_seconds: 0.0,
            metrics: BTreeMap::new(),
            baseline: BTreeMap::new(),
        })
        .collect();
    let scenes = load_scenes(scan, &matscan_estimate::PIPELINE_ORDER)
        .with_context(|| format!("preparing {} for the networks", scan.display()))?;
    // Every network's scene is in the same reference image.
    let Some(reference) = scenes.iter().flatten().next().map(|s| s.reference.clone()) else {
        return Ok(results);
    };
    // The loader has required the truth mask already.
    let mask = bundle
        .truth_mask(&reference)?
        .map(|m| m.data)
        .with_context(|| format!("{}: no truth mask at {reference}", scan.display()))?;
    for (kind, scene) in matscan_estimate::PIPELINE_ORDER.into_iter().zip(scenes) {
        let Some(scene) = scene else {
            continue;
        };
        let model = models
            .get(kind)
            .with_context(|| format!("no {kind} network loaded"))?;
        let Some(truth) = bundle.truth_param(&reference, kind)? else {
            continue;
        };
        let (truth, channels) = truth.flat();
        // The baseline does not depend on the views.
        let base = baseline.get(&kind).and_then(|mean| {
            error_metrics(&vec![*mean as f32; truth.len()], truth, &mask, channels)
        });
        for (result, &count) in results.iter_mut().zip(counts) {
            let t = Instant::now();
            let map = predict(&model.net, &scene, count, device)
                .with_context(|| format!("running the {kind} network on {}", scan.display()))?;
            result.seconds += t.elapsed().as_secs_f64();
            if map.channels != channels {
                continue;
            }
            if let Some(m) = error_metrics(&map.data, truth, &mask, channels) {
                result.metrics.insert(kind, m);
            }
            if let Some(b) = base {
                result.baseline.insert(kind, b);
            }
        }
    }
    Ok(results)
}
