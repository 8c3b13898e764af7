//! A simulated scan read back from disk: the bundle is valid, its photos are
//! finite, and calibration from the manifest and mesh alone reproduces the
//! renderer's object mask and passes `calib check`.

use matscan_bsdf::material::Material;
use matscan_calib::check::{check, CheckOptions};
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_scan::{Bundle, TruthImage, TruthMap};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{
    generate, GeometryKind, GeometrySource, MaterialField, SceneKind, SceneOptions,
};

fn small_scan(dir: &std::path::Path, kind: SceneKind, geometry: GeometryKind) -> Bundle {
    let scene = generate(&SceneOptions {
        seed: 7,
        kind,
        geometry: GeometrySource::Kind(geometry),
        width: 64,
        height: 64,
        positions: 3,
        map_size: 64,
    });
    let opts = SimOptions {
        samples: 2,
        seed: 7,
        ..SimOptions::default()
    };
    write_scan_bundle(&scene, &opts, &dir.join("scan")).expect("simulate")
}

#[test]
fn simulated_bundle_reads_back_with_finite_photos_of_the_camera_size() {
    let tmp = tempfile::tempdir().unwrap();
    let written = small_scan(tmp.path(), SceneKind::TwoMat, GeometryKind::Sphere);
    let bundle = Bundle::open(&written.root).expect("reopen");
    assert!(bundle.warnings.is_empty(), "{:?}", bundle.warnings);
    assert_eq!(bundle.manifest.positions.len(), 3);
    for p in &bundle.manifest.positions {
        assert_eq!(p.captures.len(), 7, "captures of {}", p.name);
        for c in &p.captures {
            let img = bundle.read_photo(&p.name, &c.name).unwrap();
            assert_eq!((img.width, img.height), (64, 64));
            assert!(img
                .data
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0));
        }
    }
}

#[test]
fn calibration_reproduces_the_renderers_object_mask() {
    let tmp = tempfile::tempdir().unwrap();
    let bundle = small_scan(tmp.path(), SceneKind::TwoMat, GeometryKind::Torus);
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default()).unwrap();
    for p in &bundle.manifest.positions {
        let truth = match bundle.read_truth(&p.name, &TruthMap::Mask).unwrap() {
            Some(TruthImage::Mask(m)) => m,
            other => panic!("no truth mask for {}: {other:?}", p.name),
        };
        let maps = &calibration.position(&p.name).unwrap().maps;
        let differing = truth
            .data
            .iter()
            .zip(&maps.geometry.mask.data)
            .filter(|(a, b)| a != b)
            .count();
        let object = truth.data.iter().filter(|&&m| m).count();
        assert!(object > 100, "{}: object too small ({object} px)", p.name);
        // Both cast one ray through each pixel centre with the manifest's
        // camera: only float ties at silhouette edges may differ.
        assert!(
            differing <= object / 200 + 2,
            "{}: {differing} of {object} mask pixels differ",
            p.name
        );
    }
}

#[test]
fn calib_check_reports_silhouette_iou_of_at_least_0_98_on_a_textured_simulated_scan() {
    let tmp = tempfile::tempdir().unwrap();
    let bundle = small_scan(tmp.path(), SceneKind::TwoMat, GeometryKind::Blob);
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default()).unwrap();
    let report = check(
        &bundle.manifest,
        &calibration,
        &bundle,
        &CheckOptions::default(),
    )
    .unwrap();
    for p in &report.positions {
        let s = p
            .silhouette
            .as_ref()
            .expect("backlit capture gives a silhouette");
        assert!(s.iou >= 0.98, "{}: IoU {}", p.position, s.iou);
        // Texture and gloss weaken the shading test, but a correctly placed
        // light still correlates positively.
        for l in &p.lights {
            assert!(l.correlation.unwrap() > 0.0, "{}: {l:?}", p.position);
        }
    }
}

#[test]
fn calib_check_passes_every_test_on_a_white_diffuse_simulated_scan() {
    let tmp = tempfile::tempdir().unwrap();
    let mut scene = generate(&SceneOptions {
        seed: 3,
        kind: SceneKind::TwoMat,
        geometry: GeometrySource::Kind(GeometryKind::Blob),
        width: 64,
        height: 64,
        positions: 2,
        map_size: 16,
    });
    scene.material = MaterialField::uniform(&Material::WHITE_DIFFUSE);
    let opts = SimOptions {
        samples: 4,
        seed: 3,
        ..SimOptions::default()
    };
    let bundle = write_scan_bundle(&scene, &opts, &tmp.path().join("white")).unwrap();
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default()).unwrap();
    let report = check(
        &bundle.manifest,
        &calibration,
        &bundle,
        &CheckOptions::default(),
    )
    .unwrap();
    assert!(report.passed(), "{:?}", report.problems);
    assert!(!report.geometry_mismatch);
    for p in &report.positions {
        assert!(p.silhouette.as_ref().unwrap().iou >= 0.98);
        for l in &p.lights {
            assert!(l.correlation.unwrap() > 0.8, "{}: {l:?}", p.position);
        }
    }
}
