//! `matscan export`'s library half: a simulated scan whose "estimate" is
//! its truth maps is baked and exported; the glTF parses back with the
//! expected textures and extensions, v is flipped, the GLB is
//! self-contained, and the Khronos validator finds no error (when node and
//! npm can install it; otherwise the test says it skipped).

use crate::support;

use matscan_bake::gltf_export::{DIFFUSE_TRANSMISSION_EXT, TRANSMISSION_EXT};
use matscan_bake::{bake_scan, export_gltf, BakeError, BakeOptions, GltfFormat};
use matscan_scan::Bundle;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use support::{bake_small_scan, copy_truth_as_estimate, node_modules};

struct Fixture {
    _dir: tempfile::TempDir,
    scan: PathBuf,
    gltf: PathBuf,
    glb: PathBuf,
}

/// A 32x32 two-position scan, its truth copied as the estimate of every
/// position, baked at 64x64 and exported both ways.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let scan = dir.path().join("scan");
        let (bundle, textures) = bake_small_scan(&scan);
        let estimate = scan.join("estimate");
        let mesh = bundle.read_mesh().unwrap();
        let gltf = export_gltf(&mesh, &textures, &estimate, GltfFormat::Separate, 1.0).unwrap();
        let glb = export_gltf(&mesh, &textures, &estimate, GltfFormat::Binary, 1.0).unwrap();
        Fixture {
            _dir: dir,
            scan,
            gltf,
            glb,
        }
    })
}

#[test]
fn exported_gltf_parses_back_with_every_texture_and_extension() {
    let f = fixture();
    let doc = gltf::Gltf::open(&f.gltf).unwrap();
    let used: Vec<&str> = doc.extensions_used().collect();
    assert!(used.contains(&TRANSMISSION_EXT), "{used:?}");
    assert!(used.contains(&DIFFUSE_TRANSMISSION_EXT), "{used:?}");
    let material = doc.materials().next().unwrap();
    let pbr = material.pbr_metallic_roughness();
    let uri = |t: gltf::texture::Texture| match t.source().source() {
        gltf::image::Source::Uri { uri, .. } => uri.to_string(),
        other => panic!("expected a file, got {other:?}"),
    };
    assert_eq!(
        uri(pbr.base_color_texture().unwrap().texture()),
        "texture/basecolor.png"
    );
    assert_eq!(
        uri(pbr.metallic_roughness_texture().unwrap().texture()),
        "texture/metallic_roughness.png"
    );
    let transmission = material.transmission().unwrap();
    assert_eq!(transmission.transmission_factor(), 1.0);
    assert_eq!(
        uri(transmission.transmission_texture().unwrap().texture()),
        "texture/transmission.png"
    );
    let dt = material.extension_value(DIFFUSE_TRANSMISSION_EXT).unwrap();
    assert_eq!(dt["diffuseTransmissionFactor"], 1.0);
    for image in doc.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source() {
            assert!(
                f.gltf.parent().unwrap().join(uri).is_file(),
                "{uri} missing"
            );
        }
    }
    // Roughness in G and metallic in B of the packed texture, as baked.
    let estimate = f.gltf.parent().unwrap();
    let mr = image::open(estimate.join("texture/metallic_roughness.png"))
        .unwrap()
        .into_rgb16();
    let rough = image::open(estimate.join("texture/roughness.png"))
        .unwrap()
        .into_luma16();
    let metal = image::open(estimate.join("texture/metallic.png"))
        .unwrap()
        .into_luma16();
    for (x, y) in [(0, 0), (17, 40), (63, 63)] {
        let p = mr.get_pixel(x, y).0;
        assert_eq!(p[1], rough.get_pixel(x, y).0[0]);
        assert_eq!(p[2], metal.get_pixel(x, y).0[0]);
    }
}

#[test]
fn exported_uvs_have_v_flipped_to_the_top_left_origin() {
    let f = fixture();
    let mesh = Bundle::open(&f.scan).unwrap().read_mesh().unwrap();
    let (doc, buffers, _) = gltf::import(&f.gltf).unwrap();
    let primitive = doc.meshes().next().unwrap().primitives().next().unwrap();
    let reader = primitive.reader(|b| Some(&buffers[b.index()]));
    let uvs: Vec<[f32; 2]> = reader.read_tex_coords(0).unwrap().into_f32().collect();
    let mesh_uvs = mesh.uvs.unwrap();
    assert_eq!(uvs.len(), mesh_uvs.len());
    let mut asymmetric = 0;
    for (g, m) in uvs.iter().zip(&mesh_uvs) {
        assert_eq!(g[0], m.x);
        assert!((g[1] - (1.0 - m.y)).abs() < 1e-6, "{g:?} vs {m:?}");
        asymmetric += usize::from((m.y - 0.5).abs() > 0.1);
    }
    assert!(asymmetric > 10, "the mesh's v values cannot show a flip");
    let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
    assert_eq!(indices.len(), mesh.triangles.len() * 3);
    let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
    assert!(normals
        .iter()
        .all(|n| ((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-4));
}

#[test]
fn glb_is_self_contained() {
    let f = fixture();
    let bytes = std::fs::read(&f.glb).unwrap();
    let (doc, buffers, images) = gltf::import_slice(&bytes).unwrap();
    assert_eq!(buffers.len(), 1);
    assert_eq!(images.len(), doc.images().count());
    assert!(doc
        .images()
        .all(|i| matches!(i.source(), gltf::image::Source::View { .. })));
    assert_eq!(images[0].width, 64);
}

#[test]
fn baking_without_an_estimate_tells_to_run_matscan_estimate() {
    let f = fixture();
    let err = bake_scan(
        &f.scan,
        &f.scan.join("no-such-estimate"),
        &BakeOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(err, BakeError::NothingToBake { .. }));
    assert!(err.to_string().contains("matscan estimate"), "{err}");
}

#[test]
fn khronos_validator_finds_no_errors_in_either_format() {
    let f = fixture();
    let modules = match node_modules("gltf-validator", &["gltf-validator"]) {
        Ok(m) => m,
        Err(why) => {
            println!("skipped: Khronos glTF validator not available: {why}");
            return;
        }
    };
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/support/validate.js");
    for file in [&f.gltf, &f.glb] {
        let out = Command::new("node")
            .arg(&script)
            .arg(&modules)
            .arg(file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let issues: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        println!("{}: {issues}", file.display());
        assert_eq!(issues["numErrors"], 0, "{}: {issues:#}", file.display());
    }
}

#[test]
fn a_mesh_without_uvs_is_refused_naming_the_file_and_the_fix() {
    let f = fixture();
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("scan");
    std::fs::create_dir_all(&scan).unwrap();
    std::fs::copy(f.scan.join("scan.toml"), scan.join("scan.toml")).unwrap();
    let bundle = Bundle::open(&f.scan).unwrap();
    let mut mesh = bundle.read_mesh().unwrap();
    mesh.uvs = None;
    matscan_scan::mesh_io::write_mesh(&scan.join("geometry.ply"), &mesh).unwrap();
    let views = f.scan.join("views");
    for p in std::fs::read_dir(&views).unwrap() {
        let p = p.unwrap().path();
        let to = scan.join("views").join(p.file_name().unwrap());
        std::fs::create_dir_all(&to).unwrap();
        for file in std::fs::read_dir(&p).unwrap() {
            let file = file.unwrap().path();
            std::fs::copy(&file, to.join(file.file_name().unwrap())).unwrap();
        }
    }
    copy_truth_as_estimate(&bundle, &scan.join("estimate"));
    let err = bake_scan(
        &scan,
        &scan.join("estimate"),
        &BakeOptions {
            size: 16,
            ..BakeOptions::default()
        },
    )
    .unwrap_err();
    assert!(matches!(err, BakeError::NoUvs { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("geometry.ply"), "{text}");
    assert!(text.contains("Smart UV Project"), "{text}");
}
