//! The error budget (`matscan eval --oracle SET...`): the chained estimate
//! run once as it is and once per set of oracle pieces (truth fed in place
//! of one measurement, see `matscan_estimate::pipeline::oracle`), so that
//! each piece's row shows how much of every other parameter's error that
//! piece costs, per scene kind and over all scans.
//!
//! Every scan is opened and calibrated once for all sets; a scan that fails
//! under any set is left out of every set's rows (the rows compare the same
//! scans), and reported.

use super::chained::{chained_configurations, Chained};
use super::options::EvalOptions;
use super::report::views_label;
use super::tables::{csv_field, csv_number, group_rows, GroupRow, SceneResult, ALL_GROUP};
use burn::tensor::Device;
use matscan_estimate::pipeline::oracle::Oracles;
use matscan_estimate::PIPELINE_ORDER;
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Header of the budget's CSV: one row per view count, oracle set (its
/// pieces joined by `+`), group and parameter; `delta_mad` is the change
/// against the set `none`.
pub const BUDGET_CSV_HEADER: &str = "views,oracle,group,param,scans,mad,delta_mad,median_seconds";

/// The budget's printed table and CSV.
pub struct Budget {
    pub table: String,
    pub csv: String,
}

/// Runs the budget `args` describe over `scans` at the last view count of
/// `args.views`.
pub fn run_budget(
    args: &EvalOptions,
    scans: &[PathBuf],
    baseline: &BTreeMap<Param, f64>,
    scratch: &Path,
    device: &Device,
) -> Budget {
    let count = args.views.last().copied().unwrap_or(0);
    let mut sets = vec![Oracles::default()];
    sets.extend(args.oracles.iter().filter(|s| !s.is_empty()).cloned());
    let runs: Vec<Chained> = sets
        .iter()
        .map(|oracle| Chained {
            views: count,
            oracle: oracle.clone(),
        })
        .collect();
    let configurations = chained_configurations(args, &runs, scans, baseline, scratch, device);
    let failures: Vec<String> = sets
        .iter()
        .zip(&configurations)
        .flat_map(|(set, c)| c.failures.iter().map(move |f| format!("oracle {set}: {f}")))
        .collect();
    // The rows compare the same scans: those every set estimated.
    let everywhere: Vec<PathBuf> = configurations
        .iter()
        .take(1)
        .flat_map(|c| c.results.iter().map(|r| r.scan.clone()))
        .filter(|scan| {
            configurations
                .iter()
                .all(|c| c.results.iter().any(|r| &r.scan == scan))
        })
        .collect();
    let results: Vec<Vec<SceneResult>> = configurations
        .into_iter()
        .map(|c| {
            c.results
                .into_iter()
                .filter(|r| everywhere.contains(&r.scan))
                .collect()
        })
        .collect();
    let rows: Vec<Vec<GroupRow>> = results.iter().map(|r| group_rows(r)).collect();
    let mut table = String::new();
    let _ = writeln!(
        table,
        "\nerror budget, {}, method {}: MAD with each set of pieces fed from the truth \
         ({} scans, {} failed)",
        views_label(count),
        args.method.unwrap_or_default(),
        results.first().map_or(0, Vec::len),
        failures.len()
    );
    let mut csv = format!("{BUDGET_CSV_HEADER}\n");
    let groups: Vec<&str> = rows
        .first()
        .map(|r| r.iter().map(|g| g.group.as_str()).collect())
        .unwrap_or_default();
    let width = sets
        .iter()
        .map(|s| s.to_string().len())
        .max()
        .unwrap_or(0)
        .max(6);
    for group in groups {
        let scenes = rows[0]
            .iter()
            .find(|g| g.group == group)
            .map_or(0, |g| g.scenes);
        let _ = write!(table, "\n{group} ({scenes} scans)\n{:<width$}", "oracle");
        for kind in PIPELINE_ORDER {
            let _ = write!(table, " {:>12}", kind.name());
        }
        let _ = writeln!(table, " {:>9}", "median s");
        let none = rows[0].iter().find(|g| g.group == group);
        for (set, set_rows) in sets.iter().zip(&rows) {
            let Some(row) = set_rows.iter().find(|g| g.group == group) else {
                continue;
            };
            let _ = write!(table, "{:<width$}", set.to_string());
            for kind in PIPELINE_ORDER {
                let fed = set.iter().any(|o| o.param() == Some(kind));
                let mad = row.estimate.get(&kind).map(|m| m.mad);
                let base = none.and_then(|n| n.estimate.get(&kind)).map(|m| m.mad);
                let cell = match (fed, mad) {
                    (true, _) => "truth".to_string(),
                    (false, Some(m)) => format!("{m:.4}"),
                    (false, None) => "-".to_string(),
                };
                let _ = write!(table, " {cell:>12}");
                if let Some(m) = mad.filter(|_| !fed) {
                    let delta = base.map(|b| m - b);
                    let _ = writeln!(
                        csv,
                        "{count},{},{},{},{},{},{},{}",
                        csv_field(&set.to_string().replace(',', "+")),
                        csv_field(group),
                        kind.name(),
                        row.scenes,
                        csv_number(Some(m)),
                        csv_number(delta),
                        csv_number(Some(row.median_seconds))
                    );
                }
            }
            let _ = writeln!(table, " {:>9.2}", row.median_seconds);
        }
    }
    if rows
        .first()
        .is_some_and(|r| r.iter().any(|g| g.group == ALL_GROUP))
    {
        let _ = writeln!(
            table,
            "\n`truth`: the piece was fed; each other cell is that parameter's MAD with the \
             row's pieces fed (the row `none` is the estimate as it is)."
        );
    }
    for f in failures.iter().take(5) {
        let _ = writeln!(table, "  failed: {f}");
    }
    Budget { table, csv }
}
