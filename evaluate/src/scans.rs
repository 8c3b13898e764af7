//! Which scans a set holds and which views each offers: scan folders
//! given directly or found one or two levels down (as `matscan simulate
//! --dataset` and `--recipe` write them), and each scan's usable views.

use anyhow::{bail, Context, Result};
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_estimate::pipeline::views::select_views;
use matscan_estimate::ViewFilter;
use matscan_scan::Bundle;
use std::path::{Path, PathBuf};

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
    let scans = matscan_scan::bundle::find_bundles(dir)?;
    if scans.is_empty() {
        bail!(
            "{}: no scan folders (folders holding scan.toml) found, nor one level down",
            dir.display()
        );
    }
    Ok(scans)
}

/// The usable views of `scan` (`position/capture`), reference position
/// first; `None` when none is usable.
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
