//! `matscan eval --dependencies truth`: every network evaluated on its own,
//! fed the truth of the parameters it depends on, as the thesis measured its
//! Tables 4.1 to 4.3 (section 4.5: "we evaluated them independently").
//!
//! The default `--dependencies estimated` runs the product's chained path
//! (`matscan_estimate::estimate`, the thesis's section 4.8), where each
//! network reads the estimates before it and their errors add up; only the
//! truth-fed figures are comparable with the thesis's table.
//!
//! Run time here is the networks' forward passes only (no calibration or
//! input assembly, which the scene loader does once per network for every
//! view count).
//!
//! Boundaries: reads scans; the inputs come from
//! `matscan_estimate::train::data::load_scene` (the training path, built on
//! the inference code's input assembly), predictions from
//! `train::independent::predict`; tables are `eval_cmd`'s.

use crate::eval_cmd::{truth_mask, truth_values};
use crate::eval_tables::{scene_group, GroupBy, SceneResult};
use anyhow::{Context, Result};
use burn::tensor::Device;
use matscan_estimate::metrics::error_metrics;
use matscan_estimate::train::data::load_scene;
use matscan_estimate::train::independent::predict;
use matscan_estimate::{Models, ParamKind};
use matscan_scan::Bundle;
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
    baseline: &BTreeMap<ParamKind, f64>,
) -> Result<Vec<SceneResult>> {
    let bundle = Bundle::open(scan)?;
    let group = scene_group(&bundle.manifest.name, group_by);
    let mut results: Vec<SceneResult> = counts
        .iter()
        .map(|_| SceneResult {
            scan: scan.to_path_buf(),
            group: group.clone(),
            seconds: 0.0,
            metrics: BTreeMap::new(),
            baseline: BTreeMap::new(),
        })
        .collect();
    for kind in ParamKind::ALL {
        let model = models
            .get(kind)
            .with_context(|| format!("no {kind} network loaded"))?;
        let Some(scene) = load_scene(scan, kind)
            .with_context(|| format!("preparing {} for the {kind} network", scan.display()))?
        else {
            continue;
        };
        let Some((truth, channels)) = truth_values(&bundle, &scene.reference, kind)? else {
            continue;
        };
        let mask = match truth_mask(&bundle, &scene.reference)? {
            Some(m) => m,
            None => scene.mask.iter().map(|m| *m > 0.5).collect(),
        };
        let constant = baseline
            .get(&kind)
            .map(|mean| vec![*mean as f32; truth.len()]);
        for (result, &count) in results.iter_mut().zip(counts) {
            let t = Instant::now();
            let map = predict(&model.net, &scene, count, device)
                .with_context(|| format!("running the {kind} network on {}", scan.display()))?;
            result.seconds += t.elapsed().as_secs_f64();
            if map.channels != channels {
                continue;
            }
            if let Some(m) = error_metrics(&map.data, &truth, &mask, channels) {
                result.metrics.insert(kind, m);
            }
            if let Some(b) = constant
                .as_deref()
                .and_then(|c| error_metrics(c, &truth, &mask, channels))
            {
                result.baseline.insert(kind, b);
            }
        }
    }
    Ok(results)
}
