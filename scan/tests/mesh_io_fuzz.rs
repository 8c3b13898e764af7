//! Malformed meshes never panic: truncated, bit-flipped, spliced and
//! number-swapped PLY (ASCII, binary little and big endian) and OBJ input
//! either reads as a valid mesh or fails with an error.

use glam::{Vec2, Vec3};
use matscan_scan::mesh_io::{read_obj, read_ply, write_obj, write_ply};
use matscan_scan::Mesh;
use proptest::prelude::*;
use proptest::sample::Index;
use std::path::Path;

const ASCII_PLY: &str = "ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
property list uchar int junk
property float s
property float t
element extra 1
property list int float values
element face 2
property list uchar uint vertex_indices
end_header
0 0 0 1 5 0 0
1 0 0 0 1 0
1 1 0 2 1 2 1 1
0 1 0 0 0 1
3 0.5 1.5 2.5
4 0 1 2 3
3 3 2 0
";

const BIG_ENDIAN_HEADER: &str = "ply
format binary_big_endian 1.0
element vertex 3
property double x
property double y
property double z
element face 1
property list uchar short vertex_index
end_header
";

const OBJ: &str = "v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 1
vn 0 0 1
f 1/1/1 2/2/1 3/2/1 4/1/1
f -1//1 -2//1 -3//1
f 1 2 3
";

fn sample() -> Mesh {
    Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::Y],
        normals: Some(vec![Vec3::Z; 4]),
        uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// The documents every case starts from: (bytes, is PLY).
fn bases() -> &'static [(Vec<u8>, bool)] {
    static BASES: std::sync::OnceLock<Vec<(Vec<u8>, bool)>> = std::sync::OnceLock::new();
    BASES.get_or_init(make_bases)
}

fn make_bases() -> Vec<(Vec<u8>, bool)> {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("m.ply");
    let obj = dir.path().join("m.obj");
    write_ply(&ply, &sample()).unwrap();
    write_obj(&obj, &sample()).unwrap();
    let mut be = BIG_ENDIAN_HEADER.as_bytes().to_vec();
    for p in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in p {
            be.extend_from_slice(&x.to_be_bytes());
        }
    }
    be.push(3);
    for i in [0i16, 1, 2] {
        be.extend_from_slice(&i.to_be_bytes());
    }
    vec![
        (ASCII_PLY.as_bytes().to_vec(), true),
        (std::fs::read(&ply).unwrap(), true),
        (be, true),
        (OBJ.as_bytes().to_vec(), false),
        (std::fs::read(&obj).unwrap(), false),
    ]
}

#[derive(Debug, Clone)]
enum Mutation {
    Truncate(Index),
    SetByte(Index, u8),
    Insert(Index, Vec<u8>),
    Delete(Index, usize),
    /// Replaces the n-th run of ASCII digits (counts, indices, types'
    /// sizes in headers) with another number.
    Number(Index, String),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let number = prop_oneof![
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("4294967295".to_string()),
        Just("4294967296".to_string()),
        Just("99999999999999999999".to_string()),
        Just("1e30".to_string()),
        Just("nan".to_string()),
        (0u32..20).prop_map(|n| n.to_string()),
    ];
    let bytes = prop::collection::vec(
        prop_oneof![
            any::<u8>(),
            Just(b'\n'),
            Just(b' '),
            Just(b'/'),
            Just(b'-'),
            Just(b'\\'),
        ],
        1..12,
    );
    prop_oneof![
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Mutation::SetByte(i, b)),
        (any::<Index>(), bytes).prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<Index>(), 1usize..16).prop_map(|(i, n)| Mutation::Delete(i, n)),
        (any::<Index>(), number).prop_map(|(i, n)| Mutation::Number(i, n)),
    ]
}

fn apply(doc: &mut Vec<u8>, m: &Mutation) {
    if doc.is_empty() {
        return;
    }
    match m {
        Mutation::Truncate(i) => doc.truncate(i.index(doc.len())),
        Mutation::SetByte(i, b) => {
            let i = i.index(doc.len());
            doc[i] = *b;
        }
        Mutation::Insert(i, bytes) => {
            let i = i.index(doc.len() + 1);
            doc.splice(i..i, bytes.iter().copied());
        }
        Mutation::Delete(i, n) => {
            let i = i.index(doc.len());
            let end = (i + n).min(doc.len());
            doc.drain(i..end);
        }
        Mutation::Number(i, n) => {
            let mut runs = Vec::new();
            let mut k = 0;
            while k < doc.len() {
                if doc[k].is_ascii_digit() {
                    let start = k;
                    while k < doc.len() && doc[k].is_ascii_digit() {
                        k += 1;
                    }
                    runs.push(start..k);
                } else {
                    k += 1;
                }
            }
            if !runs.is_empty() {
                let run = runs[i.index(runs.len())].clone();
                doc.splice(run, n.bytes());
            }
        }
    }
}

fn check(doc: &[u8], is_ply: bool) {
    let read = if is_ply {
        read_ply(doc, Path::new("fuzz.ply"))
    } else {
        read_obj(doc, Path::new("fuzz.obj"))
    };
    if let Ok(mesh) = read {
        assert_eq!(mesh.validate(), Ok(()));
    }
}

#[test]
fn unmutated_bases_read() {
    for (doc, is_ply) in bases() {
        let read = if *is_ply {
            read_ply(doc.as_slice(), Path::new("base.ply"))
        } else {
            read_obj(doc.as_slice(), Path::new("base.obj"))
        };
        assert!(read.is_ok(), "{read:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, ..ProptestConfig::default() })]

    #[test]
    fn mutated_meshes_read_or_fail_without_panicking(
        base in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..5),
    ) {
        let bases = bases();
        let (mut doc, is_ply) = bases[base.index(bases.len())].clone();
        for m in &mutations {
            apply(&mut doc, m);
        }
        check(&doc, is_ply);
    }
}

#[test]
fn huge_counts_fail_fast_instead_of_allocating_or_looping() {
    for doc in [
        ASCII_PLY.replace("element vertex 4", "element vertex 4000000000"),
        ASCII_PLY.replace("element vertex 4", "element vertex 99999999999"),
        ASCII_PLY.replace("element extra 1", "element extra 18446744073709551615"),
        ASCII_PLY.replace("3 0.5 1.5 2.5", "2147483647 0.5 1.5 2.5"),
    ] {
        let read = read_ply(doc.as_bytes(), Path::new("huge.ply"));
        assert!(read.is_err(), "{read:?}");
    }
    // An element without properties holds no data, whatever its count.
    let empty = ASCII_PLY.replace(
        "element extra 1\n",
        "element empty 18446744073709551615\nelement extra 1\n",
    );
    let mesh = read_ply(empty.as_bytes(), Path::new("empty.ply")).unwrap();
    assert_eq!(mesh.triangles.len(), 3);
}
