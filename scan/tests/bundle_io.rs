//! Bundles on disk: the writer publishes atomically and only valid bundles,
//! opening checks every referenced file, reads check sizes, and atomic
//! writes leave nothing behind on failure.

use crate::common;

use common::{parse, VALID};
use glam::Vec3;
use matscan_scan::atomic::{write_atomic, write_atomic_with, PendingDir};
use matscan_scan::bundle::{BundleWriter, TruthImage, TruthMap};
use matscan_scan::image_io::{write_rgb_exr, write_rgb_png16, Precision};
use matscan_scan::manifest::Encoding;
use matscan_scan::raster::{MaskRaster, Raster, RgbRaster, ScalarRaster};
use matscan_scan::{Bundle, Manifest, Mesh, Param, ScanError};
use std::fs;
use std::path::{Path, PathBuf};

fn photo(seed: u32) -> RgbRaster {
    Raster::from_fn(8, 6, |x, y| {
        [(x + seed) as f32 * 0.1, y as f32 * 0.05, 0.01 * seed as f32]
    })
}

fn triangle() -> Mesh {
    Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2]],
    }
}

fn manifest() -> Manifest {
    parse(VALID).unwrap().0
}

/// Writes every file `VALID` names, plus a mask and truth maps for p0.
fn fill(w: &BundleWriter, m: &Manifest) {
    w.write_mesh(&triangle()).unwrap();
    for (i, p) in m.positions.iter().enumerate() {
        for (j, c) in p.captures.iter().enumerate() {
            let img = photo((i * 10 + j) as u32);
            if c.file.extension().unwrap() == "png" {
                write_rgb_png16(&w.path_for(&c.file).unwrap(), &img, Encoding::Srgb).unwrap();
            } else {
                assert_eq!(
                    w.write_photo(&p.name, &c.name, &img, Precision::Float)
                        .unwrap(),
                    c.file
                );
            }
        }
    }
    let mask: MaskRaster = Raster::from_fn(8, 6, |x, _| x > 2);
    w.write_mask("p0", &mask).unwrap();
    let white = w
        .write_mask_at("views/p0/white.png", &Raster::filled(8, 6, true))
        .unwrap();
    assert_eq!(Some(white), m.positions[0].white_reference_mask);
    let rough: ScalarRaster = Raster::from_fn(8, 6, |x, y| (x * y) as f32 / 35.0);
    w.write_truth_scalar("p0", &TruthMap::Param(Param::Roughness), &rough)
        .unwrap();
    w.write_truth_rgb("p0", &TruthMap::Param(Param::Basecolor), &photo(7))
        .unwrap();
    w.write_truth_rgb("p0", &TruthMap::Illum("flash0".into()), &photo(9))
        .unwrap();
    w.write_truth_mask("p0", &mask).unwrap();
}

/// A published bundle at `<tmp>/scan`.
fn published() -> (tempfile::TempDir, Bundle) {
    let tmp = tempfile::tempdir().unwrap();
    let m = manifest();
    let w = BundleWriter::create(tmp.path().join("scan")).unwrap();
    fill(&w, &m);
    let b = w.finish(&m).unwrap();
    (tmp, b)
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn writer_publishes_a_bundle_that_opens_and_reads_back() {
    let (tmp, b) = published();
    assert_eq!(b.root, tmp.path().join("scan"));
    assert_eq!(
        entries(tmp.path()),
        ["scan"],
        "temporary folders left behind"
    );
    assert_eq!(
        entries(&b.root),
        ["geometry.ply", "scan.toml", "truth", "views"]
    );
    assert!(b.warnings.is_empty(), "{:?}", b.warnings);

    let opened = Bundle::open(&b.root).unwrap();
    assert_eq!(opened.manifest, manifest());
    assert_eq!(opened.read_photo("p0", "flash0").unwrap(), photo(1));
    assert_eq!(opened.read_photo("p1", "flash0").unwrap(), photo(11));
    let phone = opened.read_photo("p0", "phone").unwrap();
    for (a, b) in photo(2)
        .data
        .iter()
        .flatten()
        .zip(phone.data.iter().flatten())
    {
        // Clipped to [0, 1] by the PNG, then sRGB round trip.
        assert!((a.min(1.0) - b).abs() < 2e-5, "{a} vs {b}");
    }
    let mask = opened.read_mask("p0").unwrap().unwrap();
    assert!(!mask.get(2, 0) && *mask.get(3, 5));
    assert_eq!(opened.read_mask("p1").unwrap(), None);
    assert!(opened
        .read_white_reference_mask("p0")
        .unwrap()
        .unwrap()
        .data
        .iter()
        .all(|&m| m));
    assert_eq!(opened.read_white_reference_mask("p1").unwrap(), None);

    let rough = opened
        .read_truth("p0", &TruthMap::Param(Param::Roughness))
        .unwrap()
        .unwrap();
    assert_eq!(rough.into_scalar().unwrap().data[8 * 5 + 7], 1.0);
    let base = opened
        .read_truth("p0", &TruthMap::Param(Param::Basecolor))
        .unwrap()
        .unwrap();
    assert_eq!(base, TruthImage::Rgb(photo(7)));
    let illum = opened
        .read_truth("p0", &TruthMap::Illum("flash0".into()))
        .unwrap()
        .unwrap();
    assert_eq!(illum.into_rgb().unwrap(), photo(9));
    let valid = opened.read_truth("p0", &TruthMap::Mask).unwrap().unwrap();
    assert_eq!(valid.into_mask().unwrap(), mask);
    assert_eq!(
        opened
            .read_truth("p0", &TruthMap::Param(Param::Metallic))
            .unwrap(),
        None
    );
    assert_eq!(opened.read_truth("p1", &TruthMap::Mask).unwrap(), None);
    assert!(fs::metadata(b.root.join("truth/p0/illum_flash0.exr")).is_ok());

    assert_eq!(opened.mesh_path(), b.root.join("geometry.ply"));
    assert_eq!(opened.read_mesh().unwrap().triangle_count(), 1);
    let cam = opened.camera("p0").unwrap();
    assert_eq!(cam.center(), glam::DVec3::new(0.0, 0.0, -1.5));
    opened.verify_images().unwrap();
}

#[test]
fn finish_refuses_a_bundle_with_missing_files_and_publishes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let target = tmp.path().join("scan");
    let w = BundleWriter::create(&target).unwrap();
    w.write_mesh(&triangle()).unwrap();
    w.write_photo("p0", "ambient", &photo(0), Precision::Half)
        .unwrap();
    let err = w.finish(&manifest()).unwrap_err();
    assert!(matches!(err, ScanError::Missing { .. }), "{err}");
    assert!(
        err.to_string()
            .contains("position \"p0\" capture \"flash0\""),
        "{err}"
    );
    assert!(
        entries(tmp.path()).is_empty(),
        "left behind: {:?}",
        entries(tmp.path())
    );
}

#[test]
fn dropping_an_unfinished_writer_removes_its_temporary_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let w = BundleWriter::create(tmp.path().join("scan")).unwrap();
    w.write_photo("p0", "ambient", &photo(0), Precision::Half)
        .unwrap();
    let temp = w.dir().to_path_buf();
    let name = temp.file_name().unwrap().to_string_lossy().into_owned();
    assert!(
        name.starts_with(".scan") && name.contains(".tmp-"),
        "{name}"
    );
    assert_eq!(temp.parent(), Some(tmp.path()));
    drop(w);
    assert!(entries(tmp.path()).is_empty());
}

#[test]
fn writer_refuses_an_existing_target_at_create_and_at_publish() {
    let tmp = tempfile::tempdir().unwrap();
    let target = tmp.path().join("scan");
    fs::create_dir(&target).unwrap();
    let err = BundleWriter::create(&target).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!(
            "{} already exists; refusing to replace it",
            target.display()
        )
    );

    let other = tmp.path().join("scan2");
    let m = manifest();
    let w = BundleWriter::create(&other).unwrap();
    fill(&w, &m);
    fs::create_dir(&other).unwrap();
    fs::write(other.join("keep.txt"), b"mine").unwrap();
    let err = w.finish(&m).unwrap_err();
    assert!(matches!(err, ScanError::AlreadyExists { .. }), "{err}");
    assert_eq!(entries(&other), ["keep.txt"]);
    assert_eq!(entries(tmp.path()), ["scan", "scan2"]);
}

#[test]
fn writer_paths_must_stay_inside_the_bundle() {
    let tmp = tempfile::tempdir().unwrap();
    let w = BundleWriter::create(tmp.path().join("scan")).unwrap();
    for bad in ["../escape.txt", "/etc/passwd", "", "views/../../x"] {
        assert!(w.path_for(bad).is_err(), "{bad} accepted");
        assert!(w.write_file(bad, b"x").is_err());
    }
    w.write_file("notes/readme.txt", b"hello").unwrap();
    assert_eq!(
        fs::read(w.dir().join("notes/readme.txt")).unwrap(),
        b"hello"
    );
}

#[test]
fn truth_maps_must_be_written_with_their_own_kind() {
    let tmp = tempfile::tempdir().unwrap();
    let w = BundleWriter::create(tmp.path().join("scan")).unwrap();
    let scalar: ScalarRaster = Raster::filled(8, 6, 0.5);
    let err = w
        .write_truth_scalar("p0", &TruthMap::Param(Param::Basecolor), &scalar)
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("truth map basecolor is stored as Rgb, not Scalar"),
        "{err}"
    );
    assert!(w
        .write_truth_rgb("p0", &TruthMap::Param(Param::Metallic), &photo(0))
        .is_err());
}

fn remove(root: &Path, rel: &str) -> PathBuf {
    let p = root.join(rel);
    fs::remove_file(&p).unwrap();
    p
}

#[test]
fn open_names_each_missing_file_and_what_needs_it() {
    let (_tmp, b) = published();
    let root = &b.root;
    let photo_path = remove(root, "views/p1/flash0.exr");
    let err = Bundle::open(root).unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "{}: missing (the photo of position \"p1\" capture \"flash0\" in scan.toml)",
            photo_path.display()
        )
    );
    write_rgb_exr(&photo_path, &photo(11), Precision::Half).unwrap();

    let white = remove(root, "views/p0/white.png");
    let err = Bundle::open(root).unwrap_err().to_string();
    assert!(err.starts_with(&white.display().to_string()), "{err}");
    assert!(
        err.contains("the white reference mask of position \"p0\""),
        "{err}"
    );
    fs::write(&white, b"").unwrap();

    remove(root, "geometry.ply");
    let err = Bundle::open(root).unwrap_err().to_string();
    assert!(
        err.contains("geometry.ply: missing (the object mesh: geometry.ply or geometry.obj)"),
        "{err}"
    );

    remove(root, "scan.toml");
    let err = Bundle::open(root).unwrap_err().to_string();
    assert!(err.contains("scan.toml: missing"), "{err}");
}

#[test]
fn an_obj_mesh_is_used_when_there_is_no_ply_and_both_warn() {
    let (_tmp, b) = published();
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    fs::write(b.root.join("geometry.obj"), obj).unwrap();
    let both = Bundle::open(&b.root).unwrap();
    assert_eq!(both.warnings.len(), 1);
    assert!(
        both.warnings[0].contains("both geometry.ply and geometry.obj exist; using geometry.ply")
    );
    assert_eq!(both.read_mesh().unwrap().triangle_count(), 1);
    fs::remove_file(b.root.join("geometry.ply")).unwrap();
    let obj_only = Bundle::open(&b.root).unwrap();
    assert!(obj_only.warnings.is_empty());
    assert_eq!(obj_only.mesh_path(), b.root.join("geometry.obj"));
    assert_eq!(obj_only.read_mesh().unwrap().triangle_count(), 2);
}

#[test]
fn photos_of_the_wrong_size_are_rejected_naming_both_sizes() {
    let (_tmp, b) = published();
    let path = b.root.join("views/p0/flash0.exr");
    fs::remove_file(&path).unwrap();
    write_rgb_exr(&path, &Raster::filled(4, 4, [0.5; 3]), Precision::Half).unwrap();
    let err = b.read_photo("p0", "flash0").unwrap_err().to_string();
    assert_eq!(
        err,
        format!(
            "{}: image is 4x4 pixels, expected 8x6 (the camera's width x height in scan.toml)",
            path.display()
        )
    );
    assert!(b.verify_images().is_err());
}

#[test]
fn unknown_positions_and_captures_are_errors_listing_what_exists() {
    let (_tmp, b) = published();
    let err = b.read_photo("p9", "ambient").unwrap_err().to_string();
    assert!(err.ends_with("no position `p9` (it has p0, p1)"), "{err}");
    let err = b.read_photo("p1", "flash1").unwrap_err().to_string();
    assert!(
        err.ends_with("position `p1` has no capture `flash1` (it has ambient, flash0)"),
        "{err}"
    );
    assert!(b.read_truth("p0", &TruthMap::Illum("nope".into())).is_err());
    assert!(b.read_mask("p7").is_err());
}

#[test]
fn unknown_manifest_keys_reach_the_bundle_warnings() {
    let (_tmp, b) = published();
    let text = fs::read_to_string(b.manifest_path()).unwrap();
    fs::write(
        b.manifest_path(),
        text.replacen("units = \"m\"", "units = \"m\"\nrig = 2", 1),
    )
    .unwrap();
    let opened = Bundle::open(&b.root).unwrap();
    assert_eq!(opened.warnings.len(), 1);
    assert!(opened.warnings[0].contains("key `rig` is not part of matscan-scan/1; ignored"));
}

#[test]
fn write_atomic_replaces_whole_files_and_leaves_no_temporaries() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("a.txt");
    write_atomic(&path, b"first").unwrap();
    write_atomic(&path, b"second").unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"second");
    let err = write_atomic_with(&path, |w| {
        use std::io::Write;
        w.write_all(b"half of a thi").unwrap();
        Err::<(), _>(ScanError::Format {
            path: path.clone(),
            message: "encoder gave up".into(),
        })
    })
    .unwrap_err();
    assert!(err.to_string().contains("encoder gave up"));
    assert_eq!(fs::read(&path).unwrap(), b"second");
    assert_eq!(entries(tmp.path()), ["a.txt"]);
    assert!(write_atomic(&tmp.path().join("no/such/dir/a.txt"), b"x").is_err());
}

#[test]
fn pending_dir_publishes_in_one_rename_and_cleans_up_otherwise() {
    let tmp = tempfile::tempdir().unwrap();
    let target = tmp.path().join("nested/out");
    let pending = PendingDir::create(&target).unwrap();
    assert!(!target.exists());
    fs::write(pending.path().join("f"), b"x").unwrap();
    assert_eq!(pending.publish().unwrap(), target);
    assert_eq!(fs::read(target.join("f")).unwrap(), b"x");
    assert_eq!(entries(&tmp.path().join("nested")), ["out"]);

    let err = PendingDir::create(&target).unwrap_err();
    assert!(matches!(err, ScanError::AlreadyExists { .. }));

    let second = tmp.path().join("nested/second");
    let pending = PendingDir::create(&second).unwrap();
    fs::create_dir(&second).unwrap();
    assert!(pending.publish().is_err());
    assert_eq!(entries(&tmp.path().join("nested")), ["out", "second"]);
}
