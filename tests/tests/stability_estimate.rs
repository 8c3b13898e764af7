//! Numerical stability of the whole estimate (`estimate::estimate`) on a
//! tiny simulated scan whose photos are all black or all saturated: with
//! the bad-light check overridden it completes with the shipped networks
//! (and with the refinement on), writing finite maps in [0, 1] for every
//! position; with the default check it refuses the scan with the reason.
//! The same holds for a 1e6 exposure ratio between captures and for 1x1
//! and odd image sizes.

use crate::common;

use matscan_estimate::pipeline::output::ResultFile;
use matscan_estimate::pipeline::run::References;
use matscan_estimate::refine::RefineOptions;
use matscan_estimate::{cpu_device, estimate, EstimateOptions, ModelSource};
use matscan_scan::image_io::{read_rgb_exr, read_scalar_exr};
use matscan_scan::Manifest;
use matscan_scan::Param;
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::Path;

fn options(refine: bool) -> EstimateOptions {
    EstimateOptions {
        calib: common::no_bad_light_check(),
        references: References::Every,
        refine: RefineOptions {
            iterations: if refine { 4 } else { 0 },
            ..RefineOptions::default()
        },
        ..EstimateOptions::default()
    }
}

/// Every map of every position the result lists: finite and in [0, 1].
fn assert_maps_in_range(scan: &Path, result: &ResultFile, what: &str) {
    assert!(!result.positions.is_empty(), "{what}: no position has maps");
    for position in &result.positions {
        let dir = scan.join("estimate").join(position);
        for kind in matscan_estimate::PIPELINE_ORDER {
            let path = dir.join(format!("{}.exr", kind.name()));
            let values: Vec<f32> = if kind == Param::Basecolor {
                read_rgb_exr(&path).unwrap().data.concat()
            } else {
                read_scalar_exr(&path).unwrap().data
            };
            assert!(!values.is_empty(), "{what}: {} is empty", path.display());
            let bad = values
                .iter()
                .filter(|v| !(v.is_finite() && (0.0..=1.0).contains(*v)))
                .count();
            assert_eq!(
                bad,
                0,
                "{what}: {} has {bad} values outside [0, 1]",
                path.display()
            );
        }
    }
    for (name, m) in &result.metrics {
        assert!(
            m.mad.is_finite() && m.mse.is_finite() && m.psnr.is_finite(),
            "{what}: {name} metrics {m:?}"
        );
    }
}

fn run_constant(value: f32, refine: bool) {
    let what = format!("photos at {value}, refine {refine}");
    let dir = tempfile::tempdir().unwrap();
    let scan = common::copy(dir.path());
    common::constant_photos(&scan, value);
    let report = estimate(
        &scan,
        ModelSource::Embedded,
        &options(refine),
        &cpu_device(),
    )
    .unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_maps_in_range(&scan, &report.result, &what);
    if refine {
        let summary = report.result.refine.as_ref().expect("refinement ran");
        // Every fitted pixel stopped for a named reason.
        assert!(
            summary.stops.values().sum::<u64>() > 0,
            "{what}: {summary:?}"
        );
    }
}

#[test]
fn an_all_black_scan_gives_finite_maps_in_range() {
    run_constant(0.0, false);
}

#[test]
fn an_all_saturated_scan_gives_finite_maps_in_range() {
    // 1.0: a clipped sensor; 65504: the largest half float, what a clipped
    // HDR merge stores.
    run_constant(1.0, false);
    run_constant(65504.0, false);
}

#[test]
fn the_refinement_on_black_and_saturated_scans_gives_finite_maps_in_range() {
    run_constant(0.0, true);
    run_constant(1.0, true);
}

#[test]
fn a_1e6_exposure_ratio_between_captures_gives_finite_maps_in_range() {
    // Lit captures exposed 1e6 times shorter than ambient (and the other
    // way round): every lit photo is scaled by 1e6 (or 1e-6) on its way
    // to the ambient's units, with the refinement on.
    for factor in [1e-6, 1e6] {
        let what = format!("lit exposure x {factor}");
        let dir = tempfile::tempdir().unwrap();
        let scan = common::copy(dir.path());
        let path = scan.join("scan.toml");
        let (mut manifest, _) = Manifest::read(&path).unwrap();
        for position in &mut manifest.positions {
            for capture in &mut position.captures {
                if !capture.lights.is_empty() {
                    capture.exposure_s *= factor;
                }
            }
        }
        std::fs::write(&path, manifest.to_toml()).unwrap();
        let report = estimate(&scan, ModelSource::Embedded, &options(true), &cpu_device())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_maps_in_range(&scan, &report.result, &what);
    }
}

#[test]
fn tiny_and_odd_image_sizes_give_finite_maps_in_range() {
    // 1x1 and odd sizes: the input pyramid, warps and fusion at their
    // smallest; refinement on.
    for (w, h) in [(1u32, 1u32), (3, 5), (7, 2)] {
        let what = format!("{w}x{h}");
        let dir = tempfile::tempdir().unwrap();
        let scan = dir.path().join("scan");
        let scene = generate(&SceneOptions {
            seed: 3,
            kind: SceneKind::MultimatNoEnv,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: w,
            height: h,
            positions: 2,
            map_size: 8,
        });
        let sim = SimOptions {
            samples: 1,
            threads: Some(2),
            ..SimOptions::default()
        };
        write_scan_bundle(&scene, &sim, &scan).unwrap();
        let report = estimate(&scan, ModelSource::Embedded, &options(true), &cpu_device())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_maps_in_range(&scan, &report.result, &what);
    }
}

#[test]
fn the_default_bad_light_check_refuses_an_all_black_scan_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let scan = common::copy(dir.path());
    common::constant_photos(&scan, 0.0);
    let err = estimate(
        &scan,
        ModelSource::Embedded,
        &EstimateOptions::default(),
        &cpu_device(),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("bad light"), "{err}");
    assert!(!scan.join("estimate").exists());
}
