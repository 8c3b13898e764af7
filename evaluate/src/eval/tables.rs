//! Aggregation of per-scene evaluation results into the thesis's tables
//! 4.1 to 4.3 (mean MAD, MSE and PSNR per parameter, one row per scene
//! group and an `ALL` row over every scene), and the CSV field quoting that
//! `matscan eval` and `matscan bench` share.
//!
//! Scene groups: simulated scans carry their scene kind in the manifest's
//! `name` (`<kind>-<geometry>-<seed>`, as `matscan_sim::scene::generate`
//! names them), so the group is read from there rather than from a new
//! manifest key, which keeps every existing scan folder readable as it is.
//! Names that match no scene kind (real captures, renamed scans) form the
//! group `other`.
//!
//! Boundaries: arithmetic and naming only; running estimates and printing
//! belong to the evaluation (the module root) and `crate::bench`.

use matscan_estimate::pipeline::metrics::ErrorMetrics;
use matscan_scan::Param;
use matscan_sim::scene::SceneKind;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Header of the CSV `--csv` writes.
pub const CSV_HEADER: &str = "table,views,group,scan,param,scans,mad,mse,psnr,baseline_mad,baseline_mse,baseline_psnr,thesis_mad,seconds,ssim,measure_seconds";

/// The name of the row over every scene.
pub const ALL_GROUP: &str = "ALL";
/// The group of scans whose name names no scene kind.
pub const OTHER_GROUP: &str = "other";

/// How scans are grouped into table rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GroupBy {
    /// The scene kind (`2mat`, `multimat`, `3mat`, ...).
    #[default]
    Kind,
    /// Scene kind and geometry (`2mat-torus`), as the thesis's datasets
    /// ("ape 3mat").
    Dataset,
}

impl std::str::FromStr for GroupBy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "kind" => Ok(GroupBy::Kind),
            "dataset" => Ok(GroupBy::Dataset),
            other => Err(format!(
                "unknown grouping `{other}`: expected kind or dataset"
            )),
        }
    }
}

/// The group of a scan named `name` (the manifest's `name`).
pub fn scene_group(name: &str, by: GroupBy) -> String {
    match by {
        GroupBy::Kind => SceneKind::ALL
            .iter()
            .map(|k| k.name())
            .filter(|k| {
                name.strip_prefix(k)
                    .is_some_and(|rest| rest.is_empty() || rest.starts_with('-'))
            })
            // "multimat-noenv" before "multimat", "2mat-transmission"
            // before "2mat".
            .max_by_key(|k| k.len())
            .unwrap_or(OTHER_GROUP)
            .to_string(),
        GroupBy::Dataset => {
            let stem = match name.rsplit_once('-') {
                Some((stem, seed))
                    if !seed.is_empty() && seed.bytes().all(|b| b.is_ascii_digit()) =>
                {
                    stem
                }
                _ => name,
            };
            if scene_group(stem, GroupBy::Kind) == OTHER_GROUP {
                OTHER_GROUP.to_string()
            } else {
                stem.to_string()
            }
        }
    }
}

/// The geometry family of a scan named `name` (`<kind>-<geometry>-<seed>`,
/// as simulated scans are named): `torus`, `vase`, ...; `other` for names
/// of another form.
pub fn geometry_family(name: &str) -> String {
    let kind = scene_group(name, GroupBy::Kind);
    if kind == OTHER_GROUP {
        return OTHER_GROUP.to_string();
    }
    let rest = name[kind.len()..].trim_start_matches('-');
    match rest.rsplit_once('-') {
        Some((geometry, seed))
            if !geometry.is_empty() && seed.bytes().all(|b| b.is_ascii_digit()) =>
        {
            geometry.to_string()
        }
        _ => OTHER_GROUP.to_string(),
    }
}

/// One scan's estimate under one configuration.
#[derive(Clone, Debug)]
pub struct SceneResult {
    /// The scan folder.
    pub scan: PathBuf,
    /// Its group (see [`scene_group`]).
    pub group: String,
    /// Its geometry family (see [`geometry_family`]).
    pub family: String,
    /// The estimate's own run time (`total_s`: writing excluded).
    pub seconds: f64,
    /// Of `seconds`, the backlight's and the checkers' measurements
    /// (`backlight_s + scattering_s`: 0 where neither ran).
    pub measure_seconds: f64,
    /// Error of each estimated parameter against the truth.
    pub metrics: BTreeMap<Param, ErrorMetrics>,
    /// Error of the trivial baseline (a constant map) on the same pixels.
    pub baseline: BTreeMap<Param, ErrorMetrics>,
}

/// Means of per-scene metrics over `n` scenes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Means {
    pub mad: f64,
    pub mse: f64,
    pub psnr: f64,
    pub n: usize,
}

impl Means {
    /// The means of `metrics`; `None` when there are none. Non-finite
    /// values (none should reach here) are left out rather than poisoning
    /// the row.
    pub fn of<'a>(metrics: impl IntoIterator<Item = &'a ErrorMetrics>) -> Option<Means> {
        let (mut mad, mut mse, mut psnr, mut n) = (0.0, 0.0, 0.0, 0usize);
        for m in metrics {
            if m.mad.is_finite() && m.mse.is_finite() && m.psnr.is_finite() {
                mad += m.mad;
                mse += m.mse;
                psnr += m.psnr;
                n += 1;
            }
        }
        (n > 0).then(|| {
            let k = n as f64;
            Means {
                mad: mad / k,
                mse: mse / k,
                psnr: psnr / k,
                n,
            }
        })
    }
}

/// One row of the thesis's tables: a group (or `ALL`).
#[derive(Clone, Debug, PartialEq)]
pub struct GroupRow {
    pub group: String,
    /// Scenes estimated in this group.
    pub scenes: usize,
    /// Median run time over those scenes.
    pub median_seconds: f64,
    /// Median over those scenes of [`SceneResult::measure_seconds`].
    pub median_measure_seconds: f64,
    /// Mean error per parameter (parameters estimated on no scene absent).
    pub estimate: BTreeMap<Param, Means>,
    /// Mean baseline error per parameter.
    pub baseline: BTreeMap<Param, Means>,
}

/// The median of `values` (mean of the middle two for an even count);
/// NaN when empty, which prints as "NaN" rather than a made-up time.
pub fn median(values: &[f64]) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

fn row(group: &str, scenes: &[&SceneResult]) -> GroupRow {
    let per_param = |pick: fn(&SceneResult) -> &BTreeMap<Param, ErrorMetrics>| {
        matscan_estimate::PIPELINE_ORDER
            .into_iter()
            .filter_map(|kind| {
                Means::of(scenes.iter().filter_map(|s| pick(s).get(&kind))).map(|m| (kind, m))
            })
            .collect()
    };
    let seconds: Vec<f64> = scenes.iter().map(|s| s.seconds).collect();
    let measure: Vec<f64> = scenes.iter().map(|s| s.measure_seconds).collect();
    GroupRow {
        group: group.to_string(),
        scenes: scenes.len(),
        median_seconds: median(&seconds),
        median_measure_seconds: median(&measure),
        estimate: per_param(|s| &s.metrics),
        baseline: per_param(|s| &s.baseline),
    }
}

/// One row per group (in name order), then the `ALL` row. `ALL` weighs
/// every scene equally, as the thesis's ALL row does (it is not the mean
/// of the group means).
pub fn group_rows(results: &[SceneResult]) -> Vec<GroupRow> {
    rows_by(results, |r| &r.group)
}

/// [`group_rows`] with one row per geometry family instead.
pub fn family_rows(results: &[SceneResult]) -> Vec<GroupRow> {
    rows_by(results, |r| &r.family)
}

fn rows_by(results: &[SceneResult], key: fn(&SceneResult) -> &String) -> Vec<GroupRow> {
    let mut groups: BTreeMap<&str, Vec<&SceneResult>> = BTreeMap::new();
    for r in results {
        groups.entry(key(r).as_str()).or_default().push(r);
    }
    let all: Vec<&SceneResult> = results.iter().collect();
    groups
        .iter()
        .map(|(g, scenes)| row(g, scenes))
        .chain(std::iter::once(row(ALL_GROUP, &all)))
        .collect()
}

/// `field` as one CSV field: quoted when it holds a comma, quote or line
/// break (paths may).
pub fn csv_field(field: &str) -> String {
    if field.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_string()
    }
}

/// A number as a CSV field: empty when absent or not finite, so a reader
/// never parses "NaN" as a measurement.
pub fn csv_number(value: Option<f64>) -> String {
    match value {
        Some(v) if v.is_finite() => format!("{v}"),
        _ => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn metrics(mad: f64, mse: f64, psnr: f64) -> ErrorMetrics {
        ErrorMetrics {
            mad,
            mse,
            psnr,
            pixels: 10,
        }
    }

    fn scene(group: &str, seconds: f64, roughness_mad: f64) -> SceneResult {
        SceneResult {
            scan: PathBuf::from(format!("{group}-{seconds}")),
            group: group.into(),
            family: "sphere".into(),
            seconds,
            measure_seconds: seconds / 10.0,
            metrics: [(
                Param::Roughness,
                metrics(roughness_mad, roughness_mad * 0.1, 20.0),
            )]
            .into_iter()
            .collect(),
            baseline: [(Param::Roughness, metrics(0.5, 0.25, 6.0))]
                .into_iter()
                .collect(),
        }
    }

    #[test]
    fn the_geometry_family_is_the_names_middle_part() {
        assert_eq!(geometry_family("2mat-torus-0003"), "torus");
        assert_eq!(geometry_family("multimat-noenv-box-30320"), "box");
        assert_eq!(geometry_family("2mat-transmission-leaves-0007"), "leaves");
        assert_eq!(geometry_family("realworld-figurine-30633"), "figurine");
        assert_eq!(geometry_family("my-real-scan"), OTHER_GROUP);
        assert_eq!(geometry_family("2mat-0003"), OTHER_GROUP);
        assert_eq!(geometry_family("3mat-vase-x"), OTHER_GROUP);
    }

    #[test]
    fn groups_come_from_the_longest_matching_scene_kind() {
        let kind = |n| scene_group(n, GroupBy::Kind);
        assert_eq!(kind("2mat-torus-20000"), "2mat");
        assert_eq!(kind("2mat-transmission-leaves-0007"), "2mat-transmission");
        assert_eq!(kind("multimat-noenv-blob-0007"), "multimat-noenv");
        assert_eq!(kind("multimat-sphere-9000"), "multimat");
        assert_eq!(kind("3mat-mesh-0003"), "3mat");
        // A prefix that is not followed by '-' is not the kind.
        assert_eq!(kind("2matte-sphere-1"), OTHER_GROUP);
        assert_eq!(kind("bench-capture"), OTHER_GROUP);
        let dataset = |n| scene_group(n, GroupBy::Dataset);
        assert_eq!(dataset("2mat-torus-20000"), "2mat-torus");
        assert_eq!(dataset("multimat-noenv-blob-0007"), "multimat-noenv-blob");
        assert_eq!(dataset("my-scan"), OTHER_GROUP);
    }

    #[test]
    fn group_rows_average_per_group_and_weigh_all_scenes_equally_overall() {
        let results = vec![
            scene("2mat", 1.0, 0.1),
            scene("2mat", 3.0, 0.3),
            scene("multimat", 10.0, 0.9),
        ];
        let rows = group_rows(&results);
        let names: Vec<&str> = rows.iter().map(|r| r.group.as_str()).collect();
        assert_eq!(names, ["2mat", "multimat", "ALL"]);

        let two = &rows[0];
        assert_eq!(two.scenes, 2);
        assert!((two.median_seconds - 2.0).abs() < 1e-12);
        assert!((two.median_measure_seconds - 0.2).abs() < 1e-12);
        let r = two.estimate[&Param::Roughness];
        assert_eq!(r.n, 2);
        assert!((r.mad - 0.2).abs() < 1e-12);
        assert!((r.mse - 0.02).abs() < 1e-12);
        assert!((r.psnr - 20.0).abs() < 1e-12);
        assert!(!two.estimate.contains_key(&Param::Metallic));

        // ALL: (0.1 + 0.3 + 0.9) / 3, not the mean of the group means (0.55).
        let all = &rows[2];
        assert_eq!(all.scenes, 3);
        assert!((all.estimate[&Param::Roughness].mad - 1.3 / 3.0).abs() < 1e-12);
        assert!((all.median_seconds - 3.0).abs() < 1e-12);
        assert!((all.median_measure_seconds - 0.3).abs() < 1e-12);
        assert!((all.baseline[&Param::Roughness].mad - 0.5).abs() < 1e-12);
    }

    #[test]
    fn means_skip_non_finite_metrics_and_are_none_when_empty() {
        let m = Means::of(&[metrics(0.2, 0.04, 14.0), metrics(f64::NAN, 0.1, 10.0)]).unwrap();
        assert_eq!(m.n, 1);
        assert!((m.mad - 0.2).abs() < 1e-12);
        assert!(Means::of(&[]).is_none());
        assert!(median(&[]).is_nan());
        assert_eq!(median(&[5.0, 1.0, 3.0]), 3.0);
    }

    #[test]
    fn csv_fields_quote_commas_and_quotes_and_blank_missing_numbers() {
        assert_eq!(csv_field("/data/a"), "/data/a");
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("say \"x\""), "\"say \"\"x\"\"\"");
        assert_eq!(csv_number(Some(0.5)), "0.5");
        assert_eq!(csv_number(Some(f64::INFINITY)), "");
        assert_eq!(csv_number(None), "");
    }
}
