//! A simulated scan is a complete, valid `matscan-scan/1` bundle, and a
//! failed simulation leaves nothing behind.

use matscan_scan::{Bundle, CaptureRole, Param, TruthMap};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::geometry::GeometryKind;
use matscan_sim::scene::kinds::SceneKind;
use matscan_sim::scene::{generate, GeometrySource, SceneOptions};

fn small_scene() -> matscan_sim::scene::Scene {
    generate(&SceneOptions {
        seed: 21,
        kind: SceneKind::Multimat,
        geometry: GeometrySource::Kind(GeometryKind::Sphere),
        width: 32,
        height: 32,
        positions: 2,
        map_size: 32,
    })
}

fn options() -> SimOptions {
    SimOptions {
        samples: 2,
        seed: 5,
        threads: Some(2),
        ..SimOptions::default()
    }
}

#[test]
fn a_simulated_scan_has_every_capture_and_truth_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan");
    let scene = small_scene();
    let written = write_scan_bundle(&scene, &options(), &out).unwrap();
    let bundle = Bundle::open(&out).unwrap();
    assert_eq!(bundle.manifest, written.manifest);
    assert_eq!(bundle.manifest.positions.len(), 2);
    for position in &bundle.manifest.positions {
        let roles: Vec<CaptureRole> = position
            .captures
            .iter()
            .map(|c| c.role(&position.lights))
            .collect();
        let count = |f: &dyn Fn(&CaptureRole) -> bool| roles.iter().filter(|r| f(r)).count();
        assert_eq!(count(&|r| *r == CaptureRole::Ambient), 1);
        assert_eq!(count(&|r| matches!(r, CaptureRole::Lit { .. })), 3);
        assert_eq!(count(&|r| *r == CaptureRole::Backlit), 1);
        assert_eq!(count(&|r| matches!(r, CaptureRole::Pattern { .. })), 2);
        for capture in &position.captures {
            let photo = bundle.read_photo(&position.name, &capture.name).unwrap();
            assert_eq!((photo.width, photo.height), (32, 32));
            assert!(photo
                .data
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0));
        }
        let mask = bundle.read_mask(&position.name).unwrap().unwrap();
        assert!(mask.data.iter().any(|&m| m), "the object is in view");
        for param in Param::ALL {
            bundle
                .read_truth(&position.name, &TruthMap::Param(param))
                .unwrap();
        }
        for light in ["flash0", "flash1", "projector"] {
            bundle
                .read_truth(&position.name, &TruthMap::Illum(light.to_string()))
                .unwrap();
        }
    }
    let meta = std::fs::read_to_string(out.join("truth").join("scene.toml")).unwrap();
    assert!(meta.contains("kind = \"multimat\""), "{meta}");
    assert_eq!(meta.matches("[[position]]").count(), 2);
    assert!(meta.contains("drowned = "));
}

#[test]
fn each_lit_photo_is_the_ambient_photo_plus_light() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan");
    write_scan_bundle(&small_scene(), &options(), &out).unwrap();
    let bundle = Bundle::open(&out).unwrap();
    let p0 = &bundle.manifest.positions[0];
    let ambient = bundle.read_photo("p0", "ambient").unwrap();
    for capture in p0.captures.iter().filter(|c| !c.lights.is_empty()) {
        let lit = bundle.read_photo("p0", &capture.name).unwrap();
        // Half precision rounds each photo separately.
        let below = lit
            .data
            .iter()
            .zip(&ambient.data)
            .flat_map(|(l, a)| (0..3).map(move |c| l[c] - a[c]))
            .filter(|d| *d < -2e-3)
            .count();
        assert_eq!(below, 0, "{}: darker than ambient somewhere", capture.name);
    }
}

#[test]
fn a_failed_simulation_leaves_no_bundle() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan");
    let bad = SimOptions {
        samples: 0,
        ..options()
    };
    assert!(write_scan_bundle(&small_scene(), &bad, &out).is_err());
    assert!(!out.exists());
    let mut scene = small_scene();
    scene.rig.positions[1].flashes[0].name = "flash0".into();
    scene.rig.positions[1].projector.name = "flash0".into();
    // Duplicate light names make an invalid manifest: caught at finish.
    assert!(write_scan_bundle(&scene, &options(), &out).is_err());
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no temporary left"
    );
}
