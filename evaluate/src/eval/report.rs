//! The printed tables and the tidy CSV of `matscan eval`.

use super::tables::{csv_field, csv_number, GroupRow, SceneResult};
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// "1 view", "3 views", "all views".
pub fn views_label(count: usize) -> String {
    match count {
        0 => "all views".to_string(),
        1 => "1 view".to_string(),
        n => format!("{n} views"),
    }
}

/// The `ALL` row per parameter beside the baseline and the thesis.
pub(super) fn write_overall(table: &mut String, all: &GroupRow, thesis: &BTreeMap<Param, f64>) {
    let _ = writeln!(
        table,
        "{:<13} {:>5} {:>8} {:>9} {:>7}   {:>8} {:>9} {:>7}   {:>8}",
        "parameter", "scans", "MAD", "MSE", "PSNR", "base MAD", "base MSE", "b PSNR", "thesis"
    );
    for kind in matscan_estimate::PIPELINE_ORDER {
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
/// per parameter, and the group's median run time and median time of the
/// backlight and checker measurements in it; `by` names the grouping
/// ("scene group", "geometry family").
pub(super) fn write_group_tables(table: &mut String, rows: &[GroupRow], by: &str) {
    let width = rows.iter().map(|r| r.group.len()).max().unwrap_or(0).max(7);
    type Pick = fn(&super::tables::Means) -> f64;
    let metrics: [(&str, Pick, usize); 3] = [
        ("MAD", |m| m.mad, 4),
        ("MSE", |m| m.mse, 5),
        ("PSNR", |m| m.psnr, 2),
    ];
    for (name, pick, decimals) in metrics {
        let _ = write!(table, "\n{name} by {by}\n{:<width$} {:>3}", "group", "#");
        for kind in matscan_estimate::PIPELINE_ORDER {
            let _ = write!(table, " {:>12}", kind.name());
        }
        let _ = writeln!(table, " {:>9} {:>9}", "median s", "measure s");
        for row in rows {
            let _ = write!(table, "{:<width$} {:>3}", row.group, row.scenes);
            for kind in matscan_estimate::PIPELINE_ORDER {
                match row.estimate.get(&kind) {
                    Some(m) => {
                        let _ = write!(table, " {:>12.decimals$}", pick(m));
                    }
                    None => {
                        let _ = write!(table, " {:>12}", "-");
                    }
                }
            }
            let _ = writeln!(
                table,
                " {:>9.2} {:>9.2}",
                row.median_seconds, row.median_measure_seconds
            );
        }
    }
}

/// Each scene's run time beside its MAD per parameter.
pub(super) fn write_scene_table(table: &mut String, results: &[SceneResult]) {
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
        "\nper scene: run time and MAD\n{:<width$} {:<18} {:>8} {:>9}",
        "scene", "group", "seconds", "measure s"
    );
    for kind in matscan_estimate::PIPELINE_ORDER {
        let _ = write!(table, " {:>12}", kind.name());
    }
    let _ = writeln!(table);
    for r in results {
        let _ = write!(
            table,
            "{:<width$} {:<18} {:>8.2} {:>9.2}",
            name(r),
            r.group,
            r.seconds,
            r.measure_seconds
        );
        for kind in matscan_estimate::PIPELINE_ORDER {
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
/// baseline and thesis), `group` (each group), `family` (each geometry
/// family) and `scene` (each scene).
pub(super) fn write_csv_rows(
    csv: &mut String,
    count: usize,
    rows: &[GroupRow],
    families: &[GroupRow],
    results: &[SceneResult],
    thesis: &BTreeMap<Param, f64>,
) {
    let families = families
        .iter()
        .filter(|r| r.group != super::tables::ALL_GROUP)
        .map(|r| ("family", r));
    let groups = rows.iter().map(|row| {
        let table = if row.group == super::tables::ALL_GROUP {
            "overall"
        } else {
            "group"
        };
        (table, row)
    });
    for (table, row) in groups.chain(families) {
        for kind in matscan_estimate::PIPELINE_ORDER {
            let Some(m) = row.estimate.get(&kind) else {
                continue;
            };
            let b = row.baseline.get(&kind);
            let _ = writeln!(
                csv,
                "{table},{count},{},,{},{},{},{},{},{},{},{},{},{},,{}",
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
                csv_number(Some(row.median_measure_seconds)),
            );
        }
    }
    for r in results {
        for (kind, m) in &r.metrics {
            let b = r.baseline.get(kind);
            let _ = writeln!(
                csv,
                "scene,{count},{},{},{},1,{},{},{},{},{},{},{},{},,{}",
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
                csv_number(Some(r.measure_seconds)),
            );
        }
    }
}

/// One view-count configuration's scene results, failures and texture
/// scores.
#[derive(Default)]
pub(super) struct Configuration {
    pub results: Vec<SceneResult>,
    pub failures: Vec<String>,
    pub textures: super::texture::TextureTable,
}
