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

#[test]
fn a_description_names_every_capture_of_its_bundle_and_the_files_it_needs() {
    use matscan_sim::render::describe::{description_dir, write_description, DESCRIPTION_FORMAT};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scan");
    let scene = small_scene();
    let bundle = write_scan_bundle(&scene, &options(), &out).unwrap();
    let described = write_description(&scene, &options(), &bundle, &out).unwrap();
    assert_eq!(described, description_dir(&out));
    assert_eq!(described, dir.path().join("scan.scene"));
    let text = std::fs::read_to_string(described.join("scene.json")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(doc["format"], DESCRIPTION_FORMAT);
    assert_eq!(doc["bundle"], "../scan");
    assert_eq!(doc["geometry"], "sphere");
    assert_eq!(doc["kind"], "multimat");
    assert_eq!(doc["camera"]["width"], 32);
    // Every file the description names is there.
    let file = |v: &serde_json::Value| described.join(v.as_str().unwrap());
    assert!(file(&doc["mesh"]).is_file());
    assert!(file(&doc["environment"]["map"]).is_file());
    for p in [
        "basecolor",
        "roughness",
        "metallic",
        "transmission",
        "subsurface",
    ] {
        let m = &doc["material"][p];
        assert!(
            m.get("map").is_some() || m.get("value").is_some(),
            "{p}: {m}"
        );
        if let Some(map) = m.get("map") {
            assert!(file(map).is_file(), "{p}");
        }
    }
    // The captures are the bundle's, in its order, with the same lights.
    let positions = doc["positions"].as_array().unwrap();
    assert_eq!(positions.len(), bundle.manifest.positions.len());
    for (p, m) in positions.iter().zip(&bundle.manifest.positions) {
        assert_eq!(p["name"], m.name.as_str());
        let captures = p["captures"].as_array().unwrap();
        assert_eq!(captures.len(), m.captures.len());
        for (c, mc) in captures.iter().zip(&m.captures) {
            assert_eq!(c["file"], mc.file.to_string_lossy().as_ref());
            let mut lights: Vec<String> = c["flashes"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| f.as_str().unwrap().to_string())
                .collect();
            if !c["projector"].is_null() {
                lights.push(p["projector"]["name"].as_str().unwrap().to_string());
            }
            if c["backlight"] == true {
                lights.push(p["backlight"]["name"].as_str().unwrap().to_string());
            }
            let mut expected = mc.lights.clone();
            expected.sort();
            lights.sort();
            assert_eq!(lights, expected, "{}", mc.name);
        }
        // Row-major pose: the last row is (0, 0, 0, 1).
        let pose: Vec<f64> = p["camera_to_world"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(&pose[12..], &[0.0, 0.0, 0.0, 1.0]);
        assert!((pose[3] - m.camera_to_world.w_axis.x).abs() < 1e-12);
    }
    // Describing again replaces the old description.
    write_description(&scene, &options(), &bundle, &out).unwrap();
    assert!(described.join("scene.json").is_file());
}
