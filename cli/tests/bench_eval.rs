//! `matscan bench` and `matscan eval`'s tables end to end on tiny simulated
//! sets (32 px, one or two scenes), with the embedded weights.

use crate::daemon_support;

use daemon_support::{matscan_ok, simulate_sphere};
use std::path::Path;

/// Splits a CSV line written by matscan (no quoted fields in these tests).
fn fields(line: &str) -> Vec<&str> {
    line.split(',').collect()
}

#[test]
fn bench_quick_writes_a_row_per_setting_with_finite_figures_and_a_png() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("set");
    let out = tmp.path().join("out");
    let recipe = tmp.path().join("tiny.toml");
    std::fs::write(
        &recipe,
        "description = \"tiny\"\nsize = 32\npositions = 2\nsamples = 2\n\
         [[set]]\nkind = \"2mat\"\ngeometry = \"sphere\"\ncount = 1\nseed = 40000\n",
    )
    .unwrap();
    let stdout = matscan_ok(&[
        "bench",
        "--quick",
        "--data",
        data.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--base-size",
        "32",
        "--recipe",
        recipe.to_str().unwrap(),
        "--skip",
        "width",
    ]);
    if !cfg!(feature = "vulkan") {
        assert!(
            stdout.contains("not built (no GPU backend in this build; --features vulkan)"),
            "{stdout}"
        );
    }
    assert!(data
        .join("32px")
        .join("2mat-sphere")
        .join("scene-040000")
        .join("scan.toml")
        .is_file());
    assert!(data.join("bench-recipe.toml").is_file());

    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let header = fields(lines[0]);
    assert_eq!(header[0], "knob");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| fields(l)).collect();
    let keys: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(
        keys,
        [
            ("method", "networks"),
            ("method", "fit"),
            ("method", "hybrid"),
            ("method", "fit-metallic"),
            ("method", "fit-specular"),
            ("method", "fit-dielectric"),
            ("views", "1 view"),
            ("views", "all views"),
            ("resolution", "32 px"),
            ("backend", "cpu flex"),
            ("backend", "cpu ndarray"),
            ("backend", "gpu"),
            ("refine", "networks only"),
            ("refine", "refine 3"),
        ]
    );
    let refined = &rows[rows.len() - 1];
    assert_eq!(refined[col("refine_iterations")], "3");
    assert_eq!(refined[col("status")], "measured", "{refined:?}");
    let mads = [
        "basecolor_mad",
        "roughness_mad",
        "metallic_mad",
        "transmission_mad",
        "subsurface_mad",
    ];
    for r in &rows {
        if r[col("status")] != "measured" {
            continue;
        }
        let seconds: f64 = r[col("median_seconds")].parse().unwrap();
        assert!(seconds.is_finite() && seconds > 0.0, "{r:?}");
        assert_eq!(r[col("scenes")], "1");
        for m in mads {
            let v: f64 = r[col(m)].parse().unwrap();
            assert!((0.0..=1.0).contains(&v), "{m} = {v} in {r:?}");
        }
    }
    // Every view and 32 px are both the base configuration, measured once.
    let row = |knob: &str, setting: &str| {
        let k = keys.iter().position(|k| *k == (knob, setting)).unwrap();
        &rows[k]
    };
    assert_eq!(
        row("views", "all views")[col("median_seconds")],
        row("resolution", "32 px")[col("median_seconds")]
    );
    assert_eq!(row("resolution", "32 px")[col("status")], "measured");
    assert!(row("backend", "gpu")[col("status")].starts_with("not built"));
    assert_eq!(row("backend", "gpu")[col("median_seconds")], "");

    let png = image::open(out.join("bench.png")).unwrap().to_rgb8();
    assert!(png.width() >= 800 && png.height() >= 400);
    // The views knob's line (two measured points) is drawn in its colour.
    assert!(png.pixels().any(|p| p.0 == [31, 119, 180]));
}

fn simulate(out: &Path, kind: &str, seed: &str) {
    let out = out.to_str().unwrap();
    simulate_sphere(32, 2, 2, &["--out", out, "--kind", kind, "--seed", seed]);
}

#[test]
fn eval_tables_group_scans_by_kind_and_overall_weighs_every_scene() {
    let tmp = tempfile::tempdir().unwrap();
    let a = tmp.path().join("a");
    let b = tmp.path().join("b");
    let c = tmp.path().join("set").join("c");
    simulate(&a, "2mat", "3");
    simulate(&b, "multimat", "4");
    std::fs::create_dir_all(c.parent().unwrap()).unwrap();
    simulate(&c, "2mat", "5");
    let csv_path = tmp.path().join("eval.csv");
    // Two scan folders and a folder of scans in one call.
    let stdout = matscan_ok(&[
        "eval",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        c.parent().unwrap().to_str().unwrap(),
        "--views",
        "0",
        "--per-scene",
        "--csv",
        csv_path.to_str().unwrap(),
    ]);
    assert!(stdout.contains("MAD by scene group"), "{stdout}");
    assert!(stdout.contains("per scene: run time and MAD"), "{stdout}");

    let csv = std::fs::read_to_string(&csv_path).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let header = fields(lines[0]);
    assert_eq!(header[0], "table");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| fields(l)).collect();
    let find = |table: &str, group: &str, param: &str| -> Vec<Vec<&str>> {
        rows.iter()
            .filter(|r| r[col("table")] == table && r[col("group")] == group)
            .filter(|r| r[col("param")] == param)
            .cloned()
            .collect()
    };
    let num = |r: &Vec<&str>, c: &str| -> f64 { r[col(c)].parse().unwrap() };
    for param in ["basecolor", "roughness"] {
        let scenes2 = find("scene", "2mat", param);
        let scenes_multi = find("scene", "multimat", param);
        assert_eq!((scenes2.len(), scenes_multi.len()), (2, 1));
        for s in scenes2.iter().chain(&scenes_multi) {
            assert!(num(s, "seconds") > 0.0);
            // The measurements are part of the scan's time.
            let measure = num(s, "measure_seconds");
            assert!((0.0..=num(s, "seconds")).contains(&measure), "{s:?}");
        }
        let g2 = &find("group", "2mat", param)[0];
        assert_eq!(g2[col("scans")], "2");
        let mean2 = (num(&scenes2[0], "mad") + num(&scenes2[1], "mad")) / 2.0;
        assert!((num(g2, "mad") - mean2).abs() < 1e-9);
        let all = &find("overall", "ALL", param)[0];
        assert_eq!(all[col("scans")], "3");
        let mean_all =
            (num(&scenes2[0], "mad") + num(&scenes2[1], "mad") + num(&scenes_multi[0], "mad"))
                / 3.0;
        assert!((num(all, "mad") - mean_all).abs() < 1e-9);
        assert!(num(all, "baseline_mad").is_finite());
    }
}

#[test]
fn truth_fed_eval_matches_the_chained_one_for_networks_without_dependencies() {
    let tmp = tempfile::tempdir().unwrap();
    let scan = tmp.path().join("multimat");
    simulate(&scan, "multimat", "6");
    let run = |deps: &str| -> Vec<(String, f64)> {
        let csv_path = tmp.path().join(format!("{deps}.csv"));
        let stdout = matscan_ok(&[
            "eval",
            scan.to_str().unwrap(),
            "--views",
            "0",
            "--dependencies",
            deps,
            // The networks' own chain (the default method lets the fit
            // decide metallic); the truth-fed protocol is the networks'.
            "--method",
            "networks",
            "--csv",
            csv_path.to_str().unwrap(),
        ]);
        assert!(
            stdout.contains(&format!("dependencies: {deps}")),
            "{stdout}"
        );
        let csv = std::fs::read_to_string(&csv_path).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        let header = fields(lines[0]);
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        lines[1..]
            .iter()
            .map(|l| fields(l))
            .filter(|r| r[col("table")] == "scene")
            .map(|r| (r[col("param")].to_string(), r[col("mad")].parse().unwrap()))
            .collect()
    };
    let chained = run("estimated");
    let truth = run("truth");
    let mad = |rows: &[(String, f64)], p: &str| -> f64 {
        rows.iter()
            .find(|(q, _)| q == p)
            .unwrap_or_else(|| panic!("no {p} row in {rows:?}"))
            .1
    };
    for p in [
        "basecolor",
        "roughness",
        "metallic",
        "transmission",
        "subsurface",
    ] {
        let v = mad(&truth, p);
        assert!((0.0..=1.0).contains(&v), "{p}: {v}");
    }
    // Metallic and transmission read no other parameter: the same inputs,
    // the same network, the same error, whichever way dependencies come.
    for p in ["metallic", "transmission"] {
        assert!((mad(&chained, p) - mad(&truth, p)).abs() < 1e-9, "{p}");
    }
    // Basecolor reads four estimated parameters and the illumination.
    assert!((mad(&chained, "basecolor") - mad(&truth, "basecolor")).abs() > 1e-6);

    let refused = daemon_support::matscan(&[
        "eval",
        scan.to_str().unwrap(),
        "--dependencies",
        "truth",
        "--textures",
    ]);
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("--textures"), "{stderr}");
}

#[test]
fn the_error_budget_feeds_each_set_of_truth_pieces_and_scores_the_rest_against_the_estimate_as_it_is(
) {
    let tmp = tempfile::tempdir().unwrap();
    let scan = tmp.path().join("2mat");
    simulate(&scan, "2mat", "3");
    let csv_path = tmp.path().join("budget.csv");
    let stdout = matscan_ok(&[
        "eval",
        scan.to_str().unwrap(),
        "--views",
        "0",
        "--method",
        "fit",
        "--oracle",
        "roughness,metallic",
        "--oracle",
        "segmentation",
        "--csv",
        csv_path.to_str().unwrap(),
    ]);
    assert!(
        stdout.contains("error budget, all views, method fit"),
        "{stdout}"
    );
    assert!(stdout.contains("truth"), "{stdout}");
    let csv = std::fs::read_to_string(&csv_path).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let header = fields(lines[0]);
    assert_eq!(header[..4], ["views", "oracle", "group", "param"]);
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines[1..].iter().map(|l| fields(l)).collect();
    let cell = |oracle: &str, param: &str, c: &str| -> Option<f64> {
        rows.iter()
            .find(|r| {
                r[col("oracle")] == oracle && r[col("group")] == "ALL" && r[col("param")] == param
            })
            .map(|r| r[col(c)].parse().unwrap())
    };
    // The estimate as it is: every parameter, no change against itself.
    for p in matscan_scan::Param::ALL.map(matscan_scan::Param::name) {
        let mad = cell("none", p, "mad").unwrap_or_else(|| panic!("no none row for {p}"));
        assert!((0.0..=1.0).contains(&mad), "{p}: {mad}");
        assert_eq!(cell("none", p, "delta_mad"), Some(0.0), "{p}");
    }
    // Fed pieces are not scored; the rest are, with their change.
    assert_eq!(cell("roughness+metallic", "roughness", "mad"), None);
    assert_eq!(cell("roughness+metallic", "metallic", "mad"), None);
    let fed = cell("roughness+metallic", "basecolor", "mad").unwrap();
    let delta = cell("roughness+metallic", "basecolor", "delta_mad").unwrap();
    let none = cell("none", "basecolor", "mad").unwrap();
    assert!((fed - none - delta).abs() < 1e-3, "{fed} {none} {delta}");
    assert!(cell("segmentation", "roughness", "mad").is_some());

    // A scan without truth maps cannot be fed them, and says which map.
    std::fs::remove_file(scan.join("truth").join("p0").join("roughness.exr")).unwrap();
    let stdout = matscan_ok(&[
        "eval",
        scan.to_str().unwrap(),
        "--views",
        "0",
        "--oracle",
        "roughness",
    ]);
    assert!(stdout.contains("failed: oracle roughness"), "{stdout}");
    assert!(stdout.contains("roughness.exr"), "{stdout}");
}
