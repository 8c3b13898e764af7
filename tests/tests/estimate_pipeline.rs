//! The estimation pipeline end to end on small simulated scans with tiny
//! random networks: what it writes, what it runs, what it skips and why.

use matscan_estimate::fit::scattering::ScatteringOptions;
use matscan_estimate::fit::{FitLight, FitOptions};
use matscan_estimate::net::models::weights_file_name;
use matscan_estimate::pipeline::method::Method;
use matscan_estimate::pipeline::metrics::PSNR_CAP;
use matscan_estimate::pipeline::output::ResultFile;
use matscan_estimate::pipeline::plan::Given;
use matscan_estimate::{
    cpu_device, estimate, EstimateError, EstimateOptions, ModelSource, Models, References, Status,
    ViewFilter,
};
use matscan_scan::image_io::read_scalar_exr;
use matscan_scan::{Bundle, CaptureRole, Manifest, Param, TruthMap};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use tempfile::TempDir;

/// One simulated scan and one set of tiny weights, made once per test binary.
fn fixture() -> &'static (TempDir, PathBuf, PathBuf) {
    static FIXTURE: OnceLock<(TempDir, PathBuf, PathBuf)> = OnceLock::new();
    FIXTURE.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let scan = simulated_sphere(dir.path(), SceneKind::MultimatNoEnv, 4, 32, 1);
        let weights = dir.path().join("weights");
        let models =
            Models::seeded(&matscan_estimate::PIPELINE_ORDER, 8, 17, &cpu_device()).unwrap();
        models.save_dir(&weights).unwrap();
        (dir, scan, weights)
    })
}

/// A two-position sphere of `kind` and `seed`, `size` pixels square,
/// rendered with `samples` paths per pixel into `into/scan`.
fn simulated_sphere(into: &Path, kind: SceneKind, seed: u64, size: u32, samples: u32) -> PathBuf {
    let scan = into.join("scan");
    let scene = generate(&SceneOptions {
        seed,
        kind,
        geometry: GeometrySource::Kind(GeometryKind::Sphere),
        width: size,
        height: size,
        positions: 2,
        map_size: 16,
    });
    let options = SimOptions {
        samples,
        seed: 3,
        threads: Some(2),
        ..SimOptions::default()
    };
    write_scan_bundle(&scene, &options, &scan).unwrap();
    scan
}

/// A private copy of the fixture scan (tests edit or write into it).
fn scan_copy(into: &Path) -> PathBuf {
    let target = into.join("scan");
    copy_dir(&fixture().1, &target);
    target
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let dest = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &dest);
        } else {
            std::fs::copy(entry.path(), dest).unwrap();
        }
    }
}

fn weights() -> ModelSource {
    ModelSource::Dir(fixture().2.clone())
}

fn run(scan: &Path, options: &EstimateOptions) -> Result<ResultFile, EstimateError> {
    let report = estimate(scan, weights(), options, &cpu_device())?;
    let text = std::fs::read_to_string(report.out.join("result.toml")).unwrap();
    let parsed = ResultFile::parse(&text).unwrap();
    assert_eq!(parsed, report.result);
    Ok(parsed)
}

fn ran(result: &ResultFile) -> Vec<String> {
    result.timings.networks.keys().cloned().collect()
}

/// Estimates `scan` by `method` into `dir/out`.
fn run_method(scan: &Path, dir: &Path, method: Method, out: &str) -> ResultFile {
    let options = EstimateOptions {
        method,
        out: Some(dir.join(out)),
        ..EstimateOptions::default()
    };
    run(scan, &options).unwrap()
}

/// The reference position's map of `param` that a run wrote into `dir/out`.
fn map_in(dir: &Path, out: &str, param: &str) -> Vec<f32> {
    read_scalar_exr(&dir.join(out).join("p0").join(format!("{param}.exr")))
        .unwrap()
        .data
}

/// Removes every capture of `role` from the manifest.
fn drop_captures(scan: &Path, unwanted: impl Fn(&CaptureRole) -> bool) {
    let path = scan.join("scan.toml");
    let (mut manifest, _) = Manifest::read(&path).unwrap();
    for position in &mut manifest.positions {
        let lights = position.lights.clone();
        position.captures.retain(|c| !unwanted(&c.role(&lights)));
    }
    std::fs::write(&path, manifest.to_toml()).unwrap();
}

#[test]
fn a_full_run_writes_every_contract_file_and_a_parsable_result() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let result = run(&scan, &EstimateOptions::default()).unwrap();
    let reference = &result.reference_position;
    assert_eq!(reference, "p0");
    for kind in matscan_estimate::PIPELINE_ORDER {
        let name = kind.name();
        for ext in ["exr", "png"] {
            let file = scan.join(format!("estimate/{reference}/{name}.{ext}"));
            assert!(file.is_file(), "{}", file.display());
        }
        let entry = result.param(kind).unwrap();
        assert_eq!(entry.status, Status::Estimated, "{name}");
        assert!(
            entry
                .model
                .as_deref()
                .unwrap()
                .starts_with(&format!("{name}-w8-")),
            "{entry:?}"
        );
        let m = result.metrics[name];
        assert!(
            m.mad.is_finite() && m.mse.is_finite() && m.psnr.is_finite(),
            "{m:?}"
        );
        assert!(m.pixels > 0);
    }
    assert_eq!(ran(&result).len(), 5);
    assert_eq!(result.models.len(), 5);
    // Two positions, each with two flashes and the uniformly lit projector.
    assert_eq!(result.views.len(), 6, "{:?}", result.views);
    let t = &result.timings;
    for s in [
        t.load_s,
        t.calibration_s,
        t.inputs_s,
        t.weights_s,
        t.total_s,
    ] {
        assert!(s >= 0.0 && s.is_finite());
    }
    assert!(t.networks.values().all(|s| *s > 0.0));
    let roughness = read_scalar_exr(&scan.join("estimate/p0/roughness.exr")).unwrap();
    assert!(roughness.data.iter().all(|v| (0.0..=1.0).contains(v)));
    // A second run replaces the first whole.
    std::fs::write(scan.join("estimate/stale.txt"), "old").unwrap();
    run(&scan, &EstimateOptions::default()).unwrap();
    assert!(!scan.join("estimate/stale.txt").exists());
    assert!(scan.join("estimate/result.toml").is_file());
}

#[test]
fn a_given_transmission_is_recorded_and_its_network_does_not_run() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let options = EstimateOptions {
        given: vec![(Param::Transmission, Given::Constant(0.0))],
        out: Some(dir.path().join("out")),
        ..EstimateOptions::default()
    };
    let result = run(&scan, &options).unwrap();
    let entry = result.param(Param::Transmission).unwrap();
    assert_eq!(entry.status, Status::Given);
    assert_eq!(entry.source.as_deref(), Some("0"));
    assert_eq!(
        ran(&result),
        vec!["basecolor", "metallic", "roughness", "subsurface"]
    );
    assert!(!result.models.contains_key("transmission"));
    let map = read_scalar_exr(&dir.path().join("out/p0/transmission.exr")).unwrap();
    assert!(map.data.iter().all(|&v| v == 0.0));
}

#[test]
fn without_a_backlit_capture_transmission_is_skipped_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    drop_captures(&scan, |r| *r == CaptureRole::Backlit);
    let result = run(&scan, &EstimateOptions::default()).unwrap();
    let entry = result.param(Param::Transmission).unwrap();
    assert_eq!(entry.status, Status::Skipped);
    assert!(
        entry
            .reason
            .as_deref()
            .unwrap()
            .contains("no backlit capture"),
        "{entry:?}"
    );
    assert_eq!(entry.default, Some(0.0));
    assert!(!ran(&result).contains(&"transmission".to_string()));
    assert_eq!(
        result.param(Param::Subsurface).unwrap().status,
        Status::Estimated
    );
    assert!(!scan.join("estimate/p0/transmission.exr").exists());
}

#[test]
fn without_checker_captures_subsurface_is_skipped_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    drop_captures(&scan, |r| matches!(r, CaptureRole::Pattern { .. }));
    let result = run(&scan, &EstimateOptions::default()).unwrap();
    let entry = result.param(Param::Subsurface).unwrap();
    assert_eq!(entry.status, Status::Skipped);
    assert!(
        entry
            .reason
            .as_deref()
            .unwrap()
            .contains("no checker capture"),
        "{entry:?}"
    );
    assert_eq!(
        ran(&result),
        vec!["basecolor", "metallic", "roughness", "transmission"]
    );
}

#[test]
fn only_roughness_runs_just_what_roughness_needs() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let options = EstimateOptions {
        only: Some(vec![Param::Roughness]),
        ..EstimateOptions::default()
    };
    let result = run(&scan, &options).unwrap();
    assert_eq!(
        ran(&result),
        vec!["metallic", "roughness", "subsurface", "transmission"]
    );
    let basecolor = result.param(Param::Basecolor).unwrap();
    assert_eq!(basecolor.status, Status::Skipped);
    assert!(basecolor
        .reason
        .as_deref()
        .unwrap()
        .contains("not requested"));
    assert!(!scan.join("estimate/p0/basecolor.exr").exists());
    assert!(scan.join("estimate/p0/roughness.exr").is_file());
}

#[test]
fn metrics_of_a_given_constant_equal_the_hand_computed_values() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let options = EstimateOptions {
        only: Some(vec![Param::Roughness]),
        given: vec![(Param::Roughness, Given::Constant(0.25))],
        ..EstimateOptions::default()
    };
    // Nothing to run, so no weights are needed.
    let report = estimate(
        &scan,
        ModelSource::Loaded(Models::new()),
        &options,
        &cpu_device(),
    )
    .unwrap();
    assert!(report.result.timings.networks.is_empty());
    let bundle = Bundle::open(&scan).unwrap();
    let truth = bundle
        .read_truth("p0", &TruthMap::Param(Param::Roughness))
        .unwrap()
        .unwrap()
        .into_scalar()
        .unwrap();
    let mask = bundle
        .read_truth("p0", &TruthMap::Mask)
        .unwrap()
        .unwrap()
        .into_mask()
        .unwrap();
    let diffs: Vec<f64> = truth
        .data
        .iter()
        .zip(&mask.data)
        .filter(|(_, m)| **m)
        .map(|(t, _)| 0.25 - f64::from(*t))
        .collect();
    let n = diffs.len() as f64;
    let mad = diffs.iter().map(|d| d.abs()).sum::<f64>() / n;
    let mse = diffs.iter().map(|d| d * d).sum::<f64>() / n;
    let psnr = (10.0 * (1.0 / mse).log10()).min(PSNR_CAP);
    let m = report.result.metrics["roughness"];
    assert_eq!(m.pixels, diffs.len());
    assert!((m.mad - mad).abs() < 1e-9, "{} vs {mad}", m.mad);
    assert!((m.mse - mse).abs() < 1e-9, "{} vs {mse}", m.mse);
    assert!((m.psnr - psnr).abs() < 1e-6, "{} vs {psnr}", m.psnr);
}

#[test]
fn permuting_the_views_gives_bit_identical_maps() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let forward = ["p0/flash0", "p1/projector", "p0/flash1", "p1/flash0"];
    let mut backward = forward;
    backward.reverse();
    let mut outputs = Vec::new();
    for (i, order) in [forward, backward].iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        let options = EstimateOptions {
            out: Some(out.clone()),
            filter: ViewFilter {
                positions: vec![],
                views: order.iter().map(|s| s.to_string()).collect(),
            },
            ..EstimateOptions::default()
        };
        let result = run(&scan, &options).unwrap();
        let expected: Vec<String> = order.iter().map(|s| s.to_string()).collect();
        assert_eq!(result.views, expected);
        outputs.push(out);
    }
    for kind in matscan_estimate::PIPELINE_ORDER {
        let file = format!("p0/{}.exr", kind.name());
        let a = std::fs::read(outputs[0].join(&file)).unwrap();
        let b = std::fs::read(outputs[1].join(&file)).unwrap();
        assert!(a == b, "{file} differs");
    }
}

#[test]
fn every_position_as_reference_writes_each_positions_maps_and_keeps_the_reference_maps() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let first_out = dir.path().join("first");
    let every_out = dir.path().join("every");
    let first = run(
        &scan,
        &EstimateOptions {
            out: Some(first_out.clone()),
            ..EstimateOptions::default()
        },
    )
    .unwrap();
    let every = run(
        &scan,
        &EstimateOptions {
            out: Some(every_out.clone()),
            references: References::Every,
            ..EstimateOptions::default()
        },
    )
    .unwrap();
    assert_eq!(first.positions, vec!["p0".to_string()]);
    assert_eq!(every.positions, vec!["p0".to_string(), "p1".to_string()]);
    assert_eq!(every.reference_position, "p0");
    assert_eq!(every.metrics, first.metrics);
    assert!(!first_out.join("p1").exists());
    let bundle = Bundle::open(&scan).unwrap();
    let mask = bundle
        .read_truth("p1", &TruthMap::Mask)
        .unwrap()
        .unwrap()
        .into_mask()
        .unwrap();
    for kind in matscan_estimate::PIPELINE_ORDER {
        let file = format!("p0/{}.exr", kind.name());
        let a = std::fs::read(first_out.join(&file)).unwrap();
        let b = std::fs::read(every_out.join(&file)).unwrap();
        assert!(a == b, "{file} differs between one and every reference");
        if kind == Param::Basecolor {
            continue;
        }
        let p1 = read_scalar_exr(&every_out.join(format!("p1/{}.exr", kind.name()))).unwrap();
        assert_eq!((p1.width, p1.height), (mask.width, mask.height));
        for (v, inside) in p1.data.iter().zip(&mask.data) {
            assert!(v.is_finite() && (0.0..=1.0).contains(v), "{kind}: {v}");
            if !inside {
                assert_eq!(*v, 0.0, "{kind} outside p1's mask");
            }
        }
    }
}

#[test]
fn positions_and_views_narrow_the_view_set() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let options = EstimateOptions {
        only: Some(vec![Param::Metallic]),
        filter: ViewFilter {
            positions: vec!["p1".to_string()],
            views: vec!["flash1".to_string()],
        },
        ..EstimateOptions::default()
    };
    let result = run(&scan, &options).unwrap();
    assert_eq!(result.reference_position, "p1");
    assert_eq!(result.views, vec!["p1/flash1".to_string()]);
    assert_eq!(ran(&result), vec!["metallic"]);
    let bad = EstimateOptions {
        filter: ViewFilter {
            positions: vec!["p9".to_string()],
            views: vec![],
        },
        ..EstimateOptions::default()
    };
    let err = run(&scan, &bad).unwrap_err();
    assert!(err.to_string().contains("no position `p9`"), "{err}");
}

#[test]
fn a_missing_or_truncated_weights_file_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let weights = dir.path().join("weights");
    copy_dir(&fixture().2, &weights);
    let metallic = weights.join(weights_file_name(Param::Metallic));
    std::fs::remove_file(&metallic).unwrap();
    let err = estimate(
        &scan,
        ModelSource::Dir(weights.clone()),
        &EstimateOptions::default(),
        &cpu_device(),
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(text.contains(&metallic.display().to_string()), "{text}");
    assert!(text.contains("does not exist"), "{text}");

    let roughness = weights.join(weights_file_name(Param::Roughness));
    let bytes = std::fs::read(&roughness).unwrap();
    std::fs::write(&roughness, &bytes[..bytes.len() / 2]).unwrap();
    let options = EstimateOptions {
        given: vec![(Param::Metallic, Given::Constant(0.0))],
        ..EstimateOptions::default()
    };
    let err = estimate(&scan, ModelSource::Dir(weights), &options, &cpu_device()).unwrap_err();
    let text = err.to_string();
    assert!(text.contains(&roughness.display().to_string()), "{text}");
    assert!(text.contains("truncated"), "{text}");
    // Nothing was written by the failed runs.
    assert!(!scan.join("estimate").exists());
}

#[test]
fn a_given_map_of_the_wrong_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let map = dir.path().join("rough.exr");
    matscan_scan::image_io::write_scalar_exr(
        &map,
        &matscan_scan::raster::ScalarRaster::filled(5, 5, 0.5),
        matscan_scan::Precision::Float,
    )
    .unwrap();
    let options = EstimateOptions {
        only: Some(vec![Param::Roughness]),
        given: vec![(Param::Roughness, Given::Map(map.clone()))],
        ..EstimateOptions::default()
    };
    let err = estimate(
        &scan,
        ModelSource::Loaded(Models::new()),
        &options,
        &cpu_device(),
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(text.contains("rough.exr") && text.contains("5x5"), "{text}");
}

/// The GPU backend runs the same networks: its maps equal the CPU's up to
/// float summation order. Runs where a Vulkan adapter exists (a GPU, or
/// Mesa's lavapipe on the CPU); says why it skipped elsewhere.
#[cfg(feature = "vulkan")]
#[test]
fn the_gpu_backend_writes_the_maps_the_cpu_writes() {
    let (device, adapter) = match matscan_estimate::gpu_device() {
        Ok(found) => found,
        Err(e) => {
            eprintln!("skipped: {e}");
            return;
        }
    };
    eprintln!("GPU adapter: {adapter}");
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let out = |name: &str| EstimateOptions {
        out: Some(dir.path().join(name)),
        ..EstimateOptions::default()
    };
    let cpu = estimate(&scan, weights(), &out("cpu"), &cpu_device()).unwrap();
    let gpu = estimate(&scan, weights(), &out("gpu"), &device).unwrap();
    assert_eq!(cpu.result.positions, gpu.result.positions);
    let position = &cpu.result.positions[0];
    let mut compared = 0;
    for kind in matscan_estimate::PIPELINE_ORDER {
        let file = format!("{position}/{}.exr", kind.name());
        let a = read_scalar_exr(&cpu.out.join(&file)).unwrap();
        let b = read_scalar_exr(&gpu.out.join(&file)).unwrap();
        assert_eq!((a.width, a.height), (b.width, b.height), "{file}");
        let worst = a
            .data
            .iter()
            .zip(&b.data)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        eprintln!("{file}: largest CPU/GPU difference {worst:.2e}");
        assert!(worst < 1e-3, "{file}: largest difference {worst}");
        compared += 1;
    }
    assert_eq!(compared, matscan_estimate::PIPELINE_ORDER.len());
}

#[test]
fn the_fit_runs_only_the_networks_it_does_not_replace() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let result = run_method(&scan, dir.path(), Method::Fit, "out");
    assert_eq!(ran(&result), vec!["subsurface", "transmission"]);
    assert_eq!(
        result.models.keys().collect::<Vec<_>>(),
        vec!["subsurface", "transmission"]
    );
    for kind in [Param::Basecolor, Param::Roughness, Param::Metallic] {
        let entry = result.param(kind).unwrap();
        assert_eq!(entry.method.as_deref(), Some("fit"), "{kind:?}");
        assert!(entry.model.is_none(), "{kind:?}");
    }
    assert_eq!(result.fit.as_ref().map(|f| f.method), Some(Method::Fit));
    // The scale the fit measured against, with the numbers themselves.
    let scale = result.fit.map(|f| f.scale).unwrap_or_default();
    let manifest = matscan_scan::Bundle::open(&scan).unwrap().manifest;
    let flash = manifest.positions[0]
        .light("flash0")
        .and_then(|l| l.intensity);
    assert!(
        scale.contains(&format!("flash0 {:.6}", flash.unwrap_or(f64::NAN))),
        "{scale}"
    );
}

#[test]
fn fit_metallic_answers_metallic_by_the_fit_and_keeps_the_networks_chain_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let result = run_method(&scan, dir.path(), Method::FitMetallic, "out");
    // The metallic network still runs: subsurface reads its answer.
    assert_eq!(
        ran(&result),
        vec![
            "basecolor",
            "metallic",
            "roughness",
            "subsurface",
            "transmission"
        ]
    );
    let metallic = result.param(Param::Metallic).unwrap();
    let share = metallic.constrained.expect("the fit says what it pinned");
    assert!((0.0..=1.0).contains(&share), "{share}");
    // Hybrid where the photos pinned some of it, the networks' otherwise.
    let answered = if share > 0.0 { "hybrid" } else { "networks" };
    assert_eq!(metallic.method.as_deref(), Some(answered));
    for kind in [Param::Basecolor, Param::Roughness] {
        let entry = result.param(kind).unwrap();
        assert_eq!(entry.method.as_deref(), Some("networks"), "{kind:?}");
        assert!(entry.model.is_some(), "{kind:?}");
    }
    assert_eq!(
        result.fit.as_ref().map(|f| f.method),
        Some(Method::FitMetallic)
    );

    // Subsurface and transmission are the networks' own chain, map for
    // map; roughness and basecolor are fed the fit's metallic.
    run_method(&scan, dir.path(), Method::Networks, "networks");
    for p in ["subsurface", "transmission"] {
        assert_eq!(
            map_in(dir.path(), "out", p),
            map_in(dir.path(), "networks", p),
            "{p}"
        );
    }
}

#[test]
fn the_falling_back_methods_without_light_intensities_keep_the_networks_answers() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    // A rig without radiometric calibration: no light intensity anywhere.
    let path = scan.join("scan.toml");
    let (mut manifest, _) = Manifest::read(&path).unwrap();
    for position in &mut manifest.positions {
        for light in &mut position.lights {
            light.intensity = None;
        }
    }
    std::fs::write(&path, manifest.to_toml()).unwrap();
    let networks = run_method(&scan, dir.path(), Method::Networks, "networks");
    for method in [
        Method::FitMetallic,
        Method::FitSpecular,
        Method::FitDielectric,
    ] {
        let chosen = run_method(&scan, dir.path(), method, method.name());
        // Nothing is pinned, so every map equals the networks' own chain.
        let metallic = chosen.param(Param::Metallic).unwrap();
        assert_eq!(metallic.constrained, Some(0.0), "{method}");
        assert_eq!(metallic.method.as_deref(), Some("networks"), "{method}");
        for p in ["metallic", "roughness", "subsurface"] {
            assert_eq!(
                map_in(dir.path(), "networks", p),
                map_in(dir.path(), method.name(), p),
                "{method}: {p}"
            );
        }
        assert!(chosen
            .fit
            .as_ref()
            .is_some_and(|f| f.scale.starts_with("none")));
    }
    assert_eq!(
        networks.param(Param::Metallic).unwrap().method.as_deref(),
        Some("networks")
    );
}

#[test]
fn the_fit_to_direct_light_separates_the_global_light_with_the_checker_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let fit_to = |light: FitLight, out: &str| {
        let options = EstimateOptions {
            method: Method::Fit,
            out: Some(dir.path().join(out)),
            fit: FitOptions {
                light,
                ..FitOptions::default()
            },
            ..EstimateOptions::default()
        };
        let result = run(&scan, &options).unwrap();
        result.fit.map(|f| f.notes).unwrap_or_default()
    };
    let separated = |notes: &[String]| notes.iter().any(|n| n.contains("global light separated"));
    let direct = fit_to(FitLight::Direct, "direct");
    assert!(separated(&direct), "{direct:?}");
    let total = fit_to(FitLight::Total, "total");
    assert!(!separated(&total), "{total:?}");

    // Without a checker the fit says it takes the photos' light as direct.
    drop_captures(&scan, |r| matches!(r, CaptureRole::Pattern { .. }));
    let without = fit_to(FitLight::Direct, "without");
    assert!(!separated(&without), "{without:?}");
    assert!(
        without
            .iter()
            .any(|n| n.contains("no checker capture") && n.contains("as direct")),
        "{without:?}"
    );
}

#[test]
fn fit_specular_is_fit_metallic_with_the_fits_roughness_where_the_photos_pin_it() {
    let dir = tempfile::tempdir().unwrap();
    let scan = scan_copy(dir.path());
    let specular = run_method(&scan, dir.path(), Method::FitSpecular, "specular");
    run_method(&scan, dir.path(), Method::FitMetallic, "fit-metallic");
    for p in ["metallic", "subsurface", "transmission"] {
        assert_eq!(
            map_in(dir.path(), "specular", p),
            map_in(dir.path(), "fit-metallic", p),
            "{p}"
        );
    }
    let basecolor = |out: &str| {
        matscan_scan::image_io::read_rgb_exr(&dir.path().join(out).join("p0").join("basecolor.exr"))
            .unwrap()
            .data
    };
    assert_eq!(basecolor("specular"), basecolor("fit-metallic"));
    let roughness = specular.param(Param::Roughness).unwrap();
    let share = roughness.constrained.expect("the fit says what it pinned");
    let answered = if share > 0.0 { "hybrid" } else { "networks" };
    assert_eq!(roughness.method.as_deref(), Some(answered));
    let (ours, theirs) = (
        map_in(dir.path(), "specular", "roughness"),
        map_in(dir.path(), "fit-metallic", "roughness"),
    );
    // Only pinned pixels may differ from the networks' roughness (this
    // small scan pins none: every pixel must be the network's).
    let changed = ours.iter().zip(&theirs).filter(|(a, b)| a != b).count();
    let pixels = ours.len() as f32;
    assert!(
        changed as f32 <= share * pixels + 0.5,
        "{changed} changed, {share} pinned"
    );
    assert_eq!(
        specular.param(Param::Basecolor).unwrap().method.as_deref(),
        Some("networks")
    );
}

#[test]
fn a_subsurface_measured_at_the_reference_serves_every_other_position() {
    // A grey sphere at sweep step 10 (subsurface 0.53): its light scatters
    // inside, so the fit measures its subsurface by rendering.
    let dir = tempfile::tempdir().unwrap();
    let scan = simulated_sphere(dir.path(), SceneKind::SweepSubsurface, 10, 64, 4);
    let out = dir.path().join("every");
    let result = run(
        &scan,
        &EstimateOptions {
            out: Some(out.clone()),
            references: References::Every,
            // The tiny random networks' transmission could call the
            // sphere clear, which the measurement leaves out.
            given: vec![(Param::Transmission, Given::Constant(0.0))],
            // Fewer samples than the product's: the test asks where the
            // value comes from, not how close it is.
            fit: FitOptions {
                scattering: Some(ScatteringOptions {
                    samples: 64,
                    ..ScatteringOptions::default()
                }),
                ..FitOptions::default()
            },
            ..EstimateOptions::default()
        },
    )
    .unwrap();
    let fit = result.fit.expect("the default method fits");
    let measured: Vec<f32> = fit
        .materials
        .iter()
        .filter_map(|m| m.subsurface.as_ref()?.value())
        .collect();
    let value = *measured
        .first()
        .unwrap_or_else(|| panic!("a scattering material measured at p0: {fit:?}"));
    assert!(measured.iter().all(|&v| v == value), "{measured:?}");
    // A second measurement at p1 would render with p1's photos and camera
    // and land elsewhere; the value itself, bit for bit, is p0's.
    let mask = Bundle::open(&scan)
        .unwrap()
        .read_truth("p1", &TruthMap::Mask)
        .unwrap()
        .unwrap()
        .into_mask()
        .unwrap();
    let p1 = read_scalar_exr(&out.join("p1/subsurface.exr")).unwrap();
    let inside = p1.data.iter().zip(&mask.data).filter(|(_, &m)| m);
    let taken = inside.clone().filter(|(&v, _)| v == value).count();
    assert!(
        taken * 2 > inside.count(),
        "p1 takes p0's subsurface {value} on most of its object ({taken} pixels)"
    );
}
