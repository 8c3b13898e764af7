//! End-to-end tests: a synthetic three-position scan rendered in code
//! (diffuse object, backlight panel behind it), calibrated, checked and
//! written to disk.

use crate::calibrate::{calibrate, CalibOptions};
use crate::check::{check, CheckOptions, SilhouetteSource};
use crate::maps::position_maps;
use crate::photos::MemoryScan;
use crate::synthetic::{icosphere, intrinsics, manifest, thesis_rig};
use crate::write::write_maps;
use glam::{DVec3, Vec3};
use matscan_scan::bvh::RayCaster;
use matscan_scan::camera::look_at;
use matscan_scan::{CaptureRole, LightKind, Manifest, Raster};

const N: u32 = 48;
const AMBIENT: f32 = 0.05;
const PANEL_LIT: f32 = 0.4;

fn scan_manifest() -> Manifest {
    let up = DVec3::new(0.0, -1.0, 0.0);
    let eyes = [
        DVec3::new(0.0, 0.0, -1.5),
        DVec3::new(0.5, 0.2, -1.4),
        DVec3::new(-0.4, -0.3, -1.4),
    ];
    let positions = eyes
        .iter()
        .enumerate()
        .map(|(i, &eye)| thesis_rig(&format!("p{i}"), look_at(eye, DVec3::ZERO, up)))
        .collect();
    manifest(intrinsics(N, 45.0), positions)
}

/// Photos of a diffuse grey sphere (albedo 0.7) before a backlight panel
/// that fills the background.
fn render(manifest: &Manifest, caster: &RayCaster) -> MemoryScan {
    let mut scan = MemoryScan::default();
    for pos in &manifest.positions {
        let maps = position_maps(caster, &manifest.camera, pos);
        let mask = &maps.geometry.mask;
        for c in &pos.captures {
            let photo = Raster::from_fn(N, N, |x, y| {
                let i = mask.index(x, y);
                let object = mask.data[i];
                let v = match c.role(&pos.lights) {
                    CaptureRole::Ambient => AMBIENT,
                    CaptureRole::Backlit => AMBIENT + if object { 0.0 } else { 0.8 },
                    CaptureRole::Lit { light } | CaptureRole::Pattern { light } => {
                        let lm = maps.light(&light).unwrap();
                        let shading = if lm.lit.data[i] {
                            let d = lm.distance.data[i];
                            0.7 * 0.5 * lm.cos_nl.data[i].max(0.0) / (d * d)
                        } else {
                            0.0
                        };
                        AMBIENT + if object { shading } else { PANEL_LIT }
                    }
                    CaptureRole::Other => AMBIENT,
                };
                [v; 3]
            });
            scan.insert_photo(&pos.name, &c.name, photo);
        }
    }
    scan
}

fn sphere() -> RayCaster {
    RayCaster::new(icosphere(Vec3::ZERO, 0.4, 3))
}

#[test]
fn calibrates_a_three_position_scan() {
    let manifest = scan_manifest();
    let caster = sphere();
    let scan = render(&manifest, &caster);
    let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    assert_eq!(cal.positions.len(), 3);
    assert_eq!(cal.correspondences.len(), 6);
    for p in &cal.positions {
        assert!(!p.bad_light.is_bad(), "{:?}", p.bad_light);
        let wr = p.light_response.as_ref().unwrap();
        assert_eq!(wr.responses.len(), 3);
        for r in &wr.responses {
            assert!((r.rgb[0] - (AMBIENT + PANEL_LIT)).abs() < 1e-5, "{r:?}");
            assert!((r.rgb_minus_ambient[1] - PANEL_LIT).abs() < 1e-5, "{r:?}");
        }
        assert_eq!(p.maps.lights.len(), 3, "flash0, flash1, projector");
        assert_eq!(p.maps.projectors[0].patterns.len(), 2);
    }
    let summary = cal.summary();
    for c in &summary.correspondences {
        assert!(c.valid_fraction > 0.3, "{c:?}");
    }
    assert_eq!(cal.usable_positions().count(), 3);
}

#[test]
fn a_drowned_position_is_left_out_with_a_reason() {
    let manifest = scan_manifest();
    let caster = sphere();
    let mut scan = render(&manifest, &caster);
    let ambient = scan.photos[&("p1".to_string(), "ambient".to_string())].clone();
    scan.insert_photo("p1", "flash0", ambient);
    let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    let names: Vec<_> = cal
        .usable_positions()
        .map(|p| p.maps.position.as_str())
        .collect();
    assert_eq!(names, ["p0", "p2"]);
    let reason = cal.summary().positions[1].left_out.clone().unwrap();
    assert!(
        reason.contains("p1") && reason.contains("flash0"),
        "{reason}"
    );
}

#[test]
fn check_passes_a_true_calibration_and_catches_a_misplaced_light() {
    let manifest = scan_manifest();
    let caster = sphere();
    let scan = render(&manifest, &caster);
    let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    let report = check(&manifest, &cal, &scan, &CheckOptions::default()).unwrap();
    assert!(report.passed(), "{:?}", report.problems);
    for p in &report.positions {
        let s = p.silhouette.as_ref().unwrap();
        assert_eq!(s.source, SilhouetteSource::BacklightPanel);
        assert!(s.iou > 0.999, "{s:?}");
        for l in &p.lights {
            assert!(l.correlation.unwrap() > 0.999, "{l:?}");
        }
    }
    let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
    assert_eq!(
        json["positions"][0]["silhouette"]["source"],
        "backlight_panel"
    );

    // The same photos, with flash1 claimed to be far to the side.
    let mut wrong = manifest.clone();
    for p in &mut wrong.positions {
        let eye = p.camera_to_world.transform_point3(DVec3::ZERO);
        let l = p.lights.iter_mut().find(|l| l.name == "flash1").unwrap();
        l.kind = LightKind::Point {
            position: eye + DVec3::new(-1.5, 1.2, 0.8),
        };
    }
    let cal = calibrate(&wrong, &caster, &scan, &CalibOptions::default()).unwrap();
    let report = check(&wrong, &cal, &scan, &CheckOptions::default()).unwrap();
    let flash1: Vec<f64> = report
        .positions
        .iter()
        .flat_map(|p| &p.lights)
        .filter(|l| l.light == "flash1")
        .filter_map(|l| l.correlation)
        .collect();
    assert!(flash1.iter().all(|c| *c < -0.15), "{flash1:?}");
    assert!(!report.passed());
    assert!(
        report.problems.iter().all(|p| p.contains("flash1")),
        "{:?}",
        report.problems
    );
}

#[test]
fn check_uses_the_bundle_mask_when_there_is_one() {
    let manifest = scan_manifest();
    let caster = sphere();
    let mut scan = render(&manifest, &caster);
    let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    // A mask shifted by 4 pixels: the IoU drops and is reported.
    let m0 = &cal.positions[0].maps.geometry.mask;
    let shifted = Raster::from_fn(N, N, |x, y| x >= 4 && *m0.get(x - 4, y));
    scan.object_masks.insert("p0".into(), shifted);
    let report = check(&manifest, &cal, &scan, &CheckOptions::default()).unwrap();
    let s = report.positions[0].silhouette.as_ref().unwrap();
    assert_eq!(s.source, SilhouetteSource::Mask);
    assert!(s.iou < 0.9 && s.iou > 0.3, "{s:?}");
    assert_eq!(report.problems.len(), 1);
    assert!(report.problems[0].contains("`p0`"));
}

#[test]
fn writes_every_map_as_exr_and_a_summary() {
    let manifest = scan_manifest();
    let caster = sphere();
    let scan = render(&manifest, &caster);
    let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let dirs = write_maps(&cal, dir.path()).unwrap();
    assert_eq!(dirs.len(), 3);
    for name in [
        "mask.exr",
        "position.exr",
        "normal.exr",
        "depth.exr",
        "view.exr",
        "cos_nv.exr",
        "uv.exr",
        "light_flash0.exr",
        "distance_flash1.exr",
        "cos_nl_projector.exr",
        "cos_vl_flash0.exr",
        "shadow_flash1.exr",
        "projector_pixel_projector.exr",
        "pattern_checker_8.exr",
        "match_p1.exr",
    ] {
        assert!(dirs[0].join(name).is_file(), "missing {name}");
    }
    let back = matscan_scan::image_io::read_scalar_exr(&dirs[0].join("cos_nl_flash0.exr")).unwrap();
    assert_eq!(back, cal.positions[0].maps.lights[0].cos_nl);
    let normal = matscan_scan::image_io::read_rgb_exr(&dirs[2].join("normal.exr")).unwrap();
    assert_eq!(normal, cal.positions[2].maps.geometry.normal);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("calib.json")).unwrap()).unwrap();
    assert_eq!(json["positions"].as_array().unwrap().len(), 3);
    assert_eq!(json["correspondences"].as_array().unwrap().len(), 6);
}

#[test]
fn calibrates_a_bundle_on_disk_like_the_same_scan_in_memory() {
    use matscan_scan::bundle::BundleWriter;
    use matscan_scan::image_io::Precision;
    let manifest = scan_manifest();
    let caster = sphere();
    let scan = render(&manifest, &caster);
    let dir = tempfile::tempdir().unwrap();
    let writer = BundleWriter::create(dir.path().join("scan")).unwrap();
    writer.write_mesh(&caster.mesh).unwrap();
    for ((position, capture), photo) in &scan.photos {
        writer
            .write_photo(position, capture, photo, Precision::Float)
            .unwrap();
    }
    let bundle = writer.finish(&manifest).unwrap();
    let from_disk = crate::calibrate::calibrate_bundle(&bundle, &CalibOptions::default()).unwrap();
    let in_memory = calibrate(&manifest, &caster, &scan, &CalibOptions::default()).unwrap();
    for (a, b) in from_disk.positions.iter().zip(&in_memory.positions) {
        assert_eq!(a.maps, b.maps);
        assert_eq!(
            a.light_response.as_ref().unwrap(),
            b.light_response.as_ref().unwrap()
        );
        assert_eq!(a.bad_light, b.bad_light);
    }
    let report = check(
        &bundle.manifest,
        &from_disk,
        &bundle,
        &CheckOptions::default(),
    )
    .unwrap();
    assert!(report.passed(), "{:?}", report.problems);
}
