//! Which scans a set holds and which views each offers: scan folders
//! given directly or found one or two levels down (as `matscan simulate
//! --dataset` and `--recipe` write them), and each scan's usable views.

use anyhow::{bail, Context, Result};
use matscan_calib::CalibOptions;
use matscan_estimate::pipeline::run::PreparedScan;
use matscan_estimate::pipeline::views::select_views;
use matscan_estimate::ViewFilter;
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
    let prepared = PreparedScan::open(scan, &CalibOptions::default())
        .with_context(|| format!("calibrating {}", scan.display()))?;
    Ok(usable_views(&prepared))
}

/// The usable views of a scan already opened and calibrated, as
/// [`all_views`].
pub fn usable_views(prepared: &PreparedScan) -> Option<Vec<String>> {
    select_views(
        &prepared.bundle.manifest,
        &prepared.calibration,
        &ViewFilter::default(),
    )
    .ok()
    .map(|set| set.views.iter().map(|v| v.to_string()).collect())
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
