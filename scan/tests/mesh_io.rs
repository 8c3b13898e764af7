//! PLY and OBJ reading and writing: round trips, hand-written files of every
//! supported flavour, vertex splitting, and the errors for bad files.

use glam::{Vec2, Vec3};
use matscan_scan::mesh_io::{read_mesh, read_obj, read_ply, write_mesh, write_obj, write_ply};
use matscan_scan::{Mesh, ScanError};
use std::path::Path;

fn sample_mesh(normals: bool, uvs: bool) -> Mesh {
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.5, -0.25, 1e-3),
        Vec3::new(0.1, 2.0, -3.75),
        Vec3::new(-1e3, 1e-7, 0.333_333_34),
    ];
    Mesh {
        normals: normals.then(|| {
            vec![
                Vec3::Z,
                Vec3::new(0.6, 0.8, 0.0),
                Vec3::ZERO, // zero-length normals are kept
                Vec3::new(-0.1, 0.2, 0.97),
            ]
        }),
        uvs: uvs.then(|| {
            vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(0.25, 0.75),
                Vec2::new(0.123_456_7, 0.999),
            ]
        }),
        positions,
        triangles: vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]],
    }
}

fn message(err: ScanError) -> String {
    err.to_string()
}

#[test]
fn binary_ply_round_trips_exactly_with_and_without_attributes() {
    let dir = tempfile::tempdir().unwrap();
    for (normals, uvs) in [(false, false), (true, false), (false, true), (true, true)] {
        let mesh = sample_mesh(normals, uvs);
        let path = dir.path().join("geometry.ply");
        write_ply(&path, &mesh).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"ply\nformat binary_little_endian 1.0\n"));
        assert_eq!(
            String::from_utf8_lossy(&bytes).contains("property float s\nproperty float t\n"),
            uvs
        );
        assert_eq!(read_mesh(&path).unwrap(), mesh);
    }
    // Atomic write: nothing but the mesh is left in the folder.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec!["geometry.ply"]);
}

#[test]
fn obj_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for (normals, uvs) in [(false, false), (true, false), (false, true), (true, true)] {
        let mesh = sample_mesh(normals, uvs);
        let path = dir.path().join("geometry.obj");
        write_obj(&path, &mesh).unwrap();
        assert_eq!(read_mesh(&path).unwrap(), mesh);
    }
}

#[test]
fn write_mesh_picks_the_format_by_extension_case_insensitively() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = sample_mesh(true, true);
    let ply = dir.path().join("A.PLY");
    let obj = dir.path().join("b.Obj");
    write_mesh(&ply, &mesh).unwrap();
    write_mesh(&obj, &mesh).unwrap();
    assert!(std::fs::read(&ply).unwrap().starts_with(b"ply\n"));
    assert!(std::fs::read(&obj)
        .unwrap()
        .starts_with(b"# written by matscan\n"));
    assert_eq!(read_mesh(&ply).unwrap(), mesh);
    assert_eq!(read_mesh(&obj).unwrap(), mesh);
    let err = message(write_mesh(&dir.path().join("m.stl"), &mesh).unwrap_err());
    assert!(
        err.contains("m.stl") && err.contains(".ply or .obj"),
        "{err}"
    );
}

#[test]
fn writing_an_invalid_mesh_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut mesh = sample_mesh(false, false);
    mesh.triangles.push([0, 1, 9]);
    let err = message(write_ply(&dir.path().join("bad.ply"), &mesh).unwrap_err());
    assert!(err.contains("vertex 9"), "{err}");
    assert!(!dir.path().join("bad.ply").exists());
}

const ASCII_PLY: &str = "ply\r
format ascii 1.0\r
comment made by hand, with CRLF header lines\r
obj_info anything\r
element vertex 5\r
property double x\r
property double y\r
property float z\r
property uchar red\r
property list uchar float junk\r
property float u\r
property float v\r
property float nx\r
property float ny\r
property float nz\r
element material 2\r
property list int int ids\r
property float shininess\r
element face 3\r
property uchar flags\r
property list uchar int vertex_indices\r
property list uchar float texcoord\r
end_header\r
0 0 0 255 2 9.5 8.5 0 0 0 0 1
1 0 0 10 0 1 0 0 0 1
1 1 0.5 10 1 7 1 1 0 0 0
0 1 0 10 0 0 1 0.5 0.5 0.5
0.5 0.5 -1 0 3 1 2 3 0.5 0.5 1 0 0
3 1 2 3 1.5
0 2.5
7 4 0 1 2 3 0
0 3 0 1 4 6 0 0 0 0 0 0
1 3 4 2 3 0
";

#[test]
fn ascii_ply_with_extra_properties_elements_and_polygons_is_read() {
    let mesh = read_ply(ASCII_PLY.as_bytes(), Path::new("hand.ply")).unwrap();
    assert_eq!(mesh.positions.len(), 5);
    assert_eq!(mesh.positions[2], Vec3::new(1.0, 1.0, 0.5));
    assert_eq!(mesh.positions[4], Vec3::new(0.5, 0.5, -1.0));
    let uvs = mesh.uvs.as_ref().expect("u v read as texture coordinates");
    assert_eq!(uvs[0], Vec2::new(0.0, 0.0));
    assert_eq!(uvs[2], Vec2::new(1.0, 1.0));
    assert_eq!(uvs[4], Vec2::new(0.5, 0.5));
    let normals = mesh.normals.as_ref().unwrap();
    assert_eq!(normals[0], Vec3::Z);
    assert_eq!(normals[3], Vec3::splat(0.5));
    // The quad is fan-triangulated; the two triangles follow.
    assert_eq!(
        mesh.triangles,
        vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [4, 2, 3]]
    );
}

#[test]
fn ascii_ply_errors_name_the_line_and_what_was_expected() {
    let bad_number = ASCII_PLY.replace("1 1 0.5 10", "1 one 0.5 10");
    let err = message(read_ply(bad_number.as_bytes(), Path::new("hand.ply")).unwrap_err());
    assert!(err.contains("hand.ply") && err.contains("line 26"), "{err}");
    assert!(
        err.contains("element vertex 2") && err.contains("`one`"),
        "{err}"
    );

    let out_of_range = ASCII_PLY.replace("1 3 4 2 3 0", "1 3 4 2 5 0");
    let err = message(read_ply(out_of_range.as_bytes(), Path::new("hand.ply")).unwrap_err());
    assert!(
        err.contains("line 33") && err.contains("vertex index 5"),
        "{err}"
    );

    let truncated = &ASCII_PLY[..ASCII_PLY.len() - 8];
    let err = message(read_ply(truncated.as_bytes(), Path::new("hand.ply")).unwrap_err());
    assert!(err.contains("unexpected end of file"), "{err}");

    let nan_normal = ASCII_PLY.replace("0 0 1 0.5 0.5 0.5", "0 0 1 nan 0.5 0.5");
    let err = message(read_ply(nan_normal.as_bytes(), Path::new("hand.ply")).unwrap_err());
    assert!(
        err.contains("element vertex 3") && err.contains("normal"),
        "{err}"
    );
}

/// Builds a binary PLY by hand: big endian, doubles, `texture_u
/// texture_v`, short indices in a `vertex_index` list, a skipped list.
fn big_endian_ply() -> Vec<u8> {
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\n\
        property double x\nproperty double y\nproperty double z\n\
        property short tag\nproperty float texture_u\nproperty float texture_v\n\
        element face 2\nproperty list uint short vertex_index\n\
        property list uchar uint extra\nend_header\n"
        .to_vec();
    let verts = [
        ([0.0f64, 0.0, 0.0], [0.0f32, 0.0]),
        ([2.0, 0.0, 0.0], [1.0, 0.0]),
        ([2.0, 3.0, 0.0], [1.0, 1.0]),
        ([0.0, 3.0, 1e-9], [0.0, 1.0]),
    ];
    for (p, t) in verts {
        for x in p {
            b.extend_from_slice(&x.to_be_bytes());
        }
        b.extend_from_slice(&(-7i16).to_be_bytes());
        for x in t {
            b.extend_from_slice(&x.to_be_bytes());
        }
    }
    for face in [[0i16, 1, 2, 3].as_slice(), [3, 2, 1].as_slice()] {
        b.extend_from_slice(&(face.len() as u32).to_be_bytes());
        for i in face {
            b.extend_from_slice(&i.to_be_bytes());
        }
        b.push(2);
        b.extend_from_slice(&[0xff; 8]);
    }
    b
}

#[test]
fn big_endian_binary_ply_with_doubles_and_short_indices_is_read() {
    let mesh = read_ply(big_endian_ply().as_slice(), Path::new("be.ply")).unwrap();
    assert_eq!(
        mesh.positions,
        vec![
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 3.0, 0.0),
            Vec3::new(0.0, 3.0, 1e-9),
        ]
    );
    assert_eq!(mesh.uvs.unwrap()[2], Vec2::ONE);
    assert_eq!(mesh.normals, None);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
}

#[test]
fn truncated_binary_ply_reports_the_element() {
    let bytes = big_endian_ply();
    let err = message(read_ply(&bytes[..bytes.len() - 12], Path::new("be.ply")).unwrap_err());
    assert!(
        err.contains("be.ply") && err.contains("element face 1"),
        "{err}"
    );
    assert!(err.contains("unexpected end of file"), "{err}");
}

#[test]
fn ply_without_faces_or_positions_is_rejected() {
    let cloud = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nend_header\n0 0 0\n";
    let err = message(read_ply(cloud.as_bytes(), Path::new("c.ply")).unwrap_err());
    assert!(err.contains("point cloud"), "{err}");
    let no_z = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                0 0\n1 0\n0 1\n3 0 1 2\n";
    let err = message(read_ply(no_z.as_bytes(), Path::new("c.ply")).unwrap_err());
    assert!(err.contains("x, y and z"), "{err}");
    let not_ply = "solid cube\n";
    let err = message(read_ply(not_ply.as_bytes(), Path::new("c.ply")).unwrap_err());
    assert!(err.contains("not a PLY file"), "{err}");
}

const OBJ: &str = "# a unit square in two triangles plus a quad, with a uv seam
mtllib ignored.mtl
o square
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0.5 0.5 1 0.2 0.3 0.4
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5 0
vn 0 0 1
vn 0 0 2
usemtl whatever
s off
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
# the same position 3 with another uv and normal: a split vertex
f -3/-1/-1 \\
  4//1 1//1
f 5 2 3 4
l 1 2
";

#[test]
fn obj_corners_are_split_where_uv_or_normal_differ_and_deduplicated_otherwise() {
    let mesh = read_obj(OBJ.as_bytes(), Path::new("m.obj")).unwrap();
    // Positions 0..5 keep their file index for their first combination;
    // new combinations are appended: (3, uv 5, n 2), (4, -, n 1),
    // (1, -, n 1), (5,-,-), (2,-,-), (3,-,-).
    assert_eq!(mesh.triangles[0], [0, 1, 2]);
    assert_eq!(mesh.triangles[1], [0, 2, 3]);
    assert_eq!(mesh.triangles.len(), 5);
    let uvs = mesh.uvs.as_ref().unwrap();
    let normals = mesh.normals.as_ref().unwrap();
    let corner = |t: usize, k: usize| mesh.triangles[t][k] as usize;
    // Third face: position 3 (z 0) with uv (0.5, 0.5) and normal (0,0,2).
    let split = corner(2, 0);
    assert!(split >= 5, "split vertex appended, got {split}");
    assert_eq!(mesh.positions[split], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(uvs[split], Vec2::new(0.5, 0.5));
    assert_eq!(normals[split], Vec3::new(0.0, 0.0, 2.0));
    // Identical combinations share a vertex.
    assert_eq!(corner(0, 0), corner(1, 0));
    assert_eq!(corner(0, 2), corner(1, 1));
    // The quad without vt/vn is fan-triangulated over its own vertices.
    let quad: Vec<Vec3> = [3, 4]
        .iter()
        .flat_map(|&t| mesh.triangles[t].map(|i| mesh.positions[i as usize]))
        .collect();
    assert_eq!(
        quad,
        vec![
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y,
        ]
    );
    assert_eq!(uvs[corner(0, 1)], Vec2::new(1.0, 0.0));
    // Every mesh vertex is used or was in the file.
    assert!(mesh.positions.len() <= 5 + 6);
}

#[test]
fn obj_errors_name_the_line_and_what_was_expected() {
    let cases = [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "line 4",
            "vertex 4 but the file has 3",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", "line 4", "index 0"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 2 3\n",
            "line 4",
            "before the first",
        ),
        ("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n", "line 2", "finite"),
        (
            "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n",
            "line 2",
            "expected 3 numbers",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 nan 1\nf 1//1 2//1 3//1\n",
            "line 4",
            "finite",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4", "at least 3"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n", "line 4", "`x`"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
            "line 4",
            "texture coordinate 1",
        ),
        ("v 0 0 0\n", "m.obj", "no faces"),
    ];
    for (text, location, expected) in cases {
        let err = message(read_obj(text.as_bytes(), Path::new("m.obj")).unwrap_err());
        assert!(
            err.contains("m.obj") && err.contains(location) && err.contains(expected),
            "{text:?}: {err}"
        );
    }
}

#[test]
fn obj_zero_normals_are_kept_and_missing_corner_attributes_default() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvt 0.5 0.25\nf 1/1/1 2//1 3\n";
    let mesh = read_obj(text.as_bytes(), Path::new("m.obj")).unwrap();
    assert_eq!(mesh.normals.as_ref().unwrap(), &vec![Vec3::ZERO; 3]);
    assert_eq!(
        mesh.uvs.as_ref().unwrap(),
        &vec![Vec2::new(0.5, 0.25), Vec2::ZERO, Vec2::ZERO]
    );
    // The shading normal falls back to the geometric one.
    assert_eq!(mesh.surface(0, 0.3, 0.3).shading_normal, Vec3::Z);
}

#[test]
fn read_mesh_reports_missing_files_and_unknown_extensions() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.ply");
    assert!(matches!(read_mesh(&missing), Err(ScanError::Io { path, .. }) if path == missing));
    let err = message(read_mesh(&dir.path().join("mesh.gltf")).unwrap_err());
    assert!(
        err.contains("mesh.gltf") && err.contains(".ply or .obj"),
        "{err}"
    );
}

/// Binary little-endian PLY of one triangle, by hand, so that values the
/// writer refuses can be put in.
fn little_endian_triangle(positions: [[f32; 3]; 3], face: [u32; 3]) -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
        property float x\nproperty float y\nproperty float z\n\
        element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
        .to_vec();
    for x in positions.iter().flatten() {
        b.extend_from_slice(&x.to_le_bytes());
    }
    b.push(3);
    for i in face {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

#[test]
fn empty_truncated_nan_and_out_of_range_inputs_are_errors() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let good = little_endian_triangle(tri, [0, 1, 2]);
    assert_eq!(
        read_ply(good.as_slice(), Path::new("t.ply"))
            .unwrap()
            .triangles,
        vec![[0, 1, 2]]
    );

    let err = message(read_ply(&b""[..], Path::new("t.ply")).unwrap_err());
    assert!(err.contains("t.ply") && err.contains("end_header"), "{err}");
    let err = message(read_obj(&b""[..], Path::new("t.obj")).unwrap_err());
    assert!(err.contains("t.obj") && err.contains("no faces"), "{err}");

    // Cut in the face list, in the face count, in the vertices, after the
    // header, and in the header.
    for cut in [1, 4, 13, 49] {
        let err = message(read_ply(&good[..good.len() - cut], Path::new("t.ply")).unwrap_err());
        assert!(
            err.contains("t.ply") && err.contains("unexpected end of file"),
            "{cut}: {err}"
        );
    }
    let err = message(read_ply(&good[..90], Path::new("t.ply")).unwrap_err());
    assert!(err.contains("end_header"), "{err}");

    let mut nan = tri;
    nan[1][2] = f32::NAN;
    let doc = little_endian_triangle(nan, [0, 1, 2]);
    let err = message(read_ply(doc.as_slice(), Path::new("t.ply")).unwrap_err());
    assert!(
        err.contains("element vertex 1") && err.contains("finite coordinates"),
        "{err}"
    );

    let doc = little_endian_triangle(tri, [0, 3, 2]);
    let err = message(read_ply(doc.as_slice(), Path::new("t.ply")).unwrap_err());
    assert!(
        err.contains("element face 0") && err.contains("vertex index 3 out of range"),
        "{err}"
    );
}
