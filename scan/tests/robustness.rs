//! Hostile input never panics: mutated manifests and corrupted or truncated
//! EXR and PNG files give errors (or, for harmless mutations, valid data),
//! never a crash.

use crate::common;

use common::{parse, VALID};
use matscan_scan::image_io::{
    read_mask_png, read_rgb_exr, read_rgb_png, read_scalar_exr, write_mask_png, write_rgb_exr,
    write_rgb_png16, Precision,
};
use matscan_scan::manifest::Encoding;
use matscan_scan::raster::Raster;
use proptest::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

#[derive(Debug, Clone)]
enum Edit {
    DeleteLine(usize),
    DuplicateLine(usize),
    SwapLines(usize, usize),
    ReplaceByte(usize, u8),
    DeleteByte(usize),
    Truncate(usize),
    InsertToken(usize, &'static str),
}

const TOKENS: &[&str] = &[
    "[",
    "]",
    "{",
    "}",
    "=",
    "\"",
    ",",
    "\n",
    "nan",
    "-inf",
    "0",
    "-1",
    "1e400",
    "[[position]]\n",
    "[[position.capture]]\n",
    "[[position.light]]\n",
    "name = \"p0\"\n",
    "lights = []\n",
    "kind = \"projector\"\n",
    "\"\"",
    "x = 1\n",
    "..",
    "/",
    "9999999999999999999",
];

fn edit_strategy() -> impl Strategy<Value = Edit> {
    prop_oneof![
        any::<usize>().prop_map(Edit::DeleteLine),
        any::<usize>().prop_map(Edit::DuplicateLine),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Edit::SwapLines(a, b)),
        (any::<usize>(), 0x20u8..0x7f).prop_map(|(i, b)| Edit::ReplaceByte(i, b)),
        any::<usize>().prop_map(Edit::DeleteByte),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), prop::sample::select(TOKENS)).prop_map(|(i, t)| Edit::InsertToken(i, t)),
    ]
}

fn apply(text: &str, edit: &Edit) -> String {
    // An earlier edit may have emptied the text: nothing left to edit.
    if text.is_empty() {
        return String::new();
    }
    let mut lines: Vec<&str> = text.lines().collect();
    let mut bytes = text.as_bytes().to_vec();
    let n = lines.len();
    match *edit {
        Edit::DeleteLine(i) => {
            lines.remove(i % n);
        }
        Edit::DuplicateLine(i) => lines.insert(i % n, lines[i % n]),
        Edit::SwapLines(a, b) => lines.swap(a % n, b % n),
        Edit::ReplaceByte(i, b) => {
            let i = i % bytes.len();
            bytes[i] = b;
            return String::from_utf8_lossy(&bytes).into_owned();
        }
        Edit::DeleteByte(i) => {
            bytes.remove(i % bytes.len());
            return String::from_utf8_lossy(&bytes).into_owned();
        }
        Edit::Truncate(i) => {
            bytes.truncate(i % bytes.len());
            return String::from_utf8_lossy(&bytes).into_owned();
        }
        Edit::InsertToken(i, t) => {
            let mut s = text.to_string();
            let mut at = i % s.len();
            while !s.is_char_boundary(at) {
                at -= 1;
            }
            s.insert_str(at, t);
            return s;
        }
    }
    lines.join("\n")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Any edit either is rejected with an error naming scan.toml, or
    /// yields a manifest that survives its own round trip.
    #[test]
    fn mutated_manifests_never_panic_and_accepted_ones_round_trip(
        edits in prop::collection::vec(edit_strategy(), 1..4)
    ) {
        let text = edits.iter().fold(VALID.to_string(), |t, e| apply(&t, e));
        match parse(&text) {
            Ok((m, _)) => {
                let (back, warnings) = parse(&m.to_toml()).unwrap();
                prop_assert!(warnings.is_empty());
                prop_assert_eq!(back, m);
            }
            Err(e) => prop_assert!(e.to_string().starts_with("scan.toml: "), "{}", e),
        }
    }
}

/// The bytes of a valid half EXR, float EXR, 16-bit PNG and 8-bit mask,
/// encoded once (writes are fsynced, which is slow to repeat).
fn valid_files() -> &'static [(String, Vec<u8>)] {
    static FILES: OnceLock<Vec<(String, Vec<u8>)>> = OnceLock::new();
    FILES.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        encode_valid_files(dir.path())
    })
}

fn encode_valid_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let img = Raster::from_fn(9, 5, |x, y| [x as f32 * 0.1, y as f32 * 0.2, 0.3]);
    let mask = Raster::from_fn(9, 5, |x, y| (x + y) % 2 == 0);
    let half = dir.join("half.exr");
    let float = dir.join("float.exr");
    let png16 = dir.join("photo.png");
    let png8 = dir.join("mask.png");
    write_rgb_exr(&half, &img, Precision::Half).unwrap();
    write_rgb_exr(&float, &img, Precision::Float).unwrap();
    write_rgb_png16(&png16, &img, Encoding::Srgb).unwrap();
    write_mask_png(&png8, &mask).unwrap();
    [half, float, png16, png8]
        .iter()
        .map(|p| {
            (
                p.extension().unwrap().to_string_lossy().into_owned(),
                std::fs::read(p).unwrap(),
            )
        })
        .collect()
}

/// Decodes `bytes` with every reader that applies to its kind; errors are
/// fine (and must name the file), and a successful read must have sane
/// dimensions. Returns whether the photo reader accepted the bytes.
fn decode_all(dir: &Path, ext: &str, bytes: &[u8]) -> bool {
    // A fresh name per probe: overwriting a file forces a disk flush on
    // common Linux file systems, which made this test I/O-bound.
    static PROBE: AtomicUsize = AtomicUsize::new(0);
    let name = format!("probe{}.{ext}", PROBE.fetch_add(1, Ordering::Relaxed));
    let path = dir.join(&name);
    std::fs::write(&path, bytes).unwrap();
    let (photo, other) = if ext == "exr" {
        let photo = read_rgb_exr(&path).map(|img| {
            assert_eq!(img.data.len(), (img.width * img.height) as usize);
            assert!(img.data.iter().flatten().all(|v| v.is_finite()));
        });
        (photo, read_scalar_exr(&path).map(|_| ()))
    } else {
        let photo = read_rgb_png(&path, Encoding::Srgb).map(|img| {
            assert_eq!(img.data.len(), (img.width * img.height) as usize);
        });
        (photo, read_mask_png(&path).map(|_| ()))
    };
    for e in [&photo, &other]
        .into_iter()
        .filter_map(|r| r.as_ref().err())
    {
        assert!(e.to_string().contains(&name), "{e}");
    }
    std::fs::remove_file(&path).unwrap();
    photo.is_ok()
}

#[test]
fn truncated_images_are_errors_at_every_length() {
    let dir = tempfile::tempdir().unwrap();
    for (ext, bytes) in valid_files() {
        for len in 0..bytes.len() {
            let accepted = decode_all(dir.path(), ext, &bytes[..len]);
            // A PNG cut inside its final 12-byte IEND chunk still holds
            // every pixel; anything shorter must fail.
            let complete = ext == "png" && len >= bytes.len() - 12;
            assert!(
                !accepted || complete,
                "{ext} truncated to {len} of {} bytes was accepted",
                bytes.len()
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn corrupted_image_bytes_never_panic(
        which in 0usize..4,
        flips in prop::collection::vec((any::<usize>(), any::<u8>()), 1..6),
        header_only in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let (ext, mut bytes) = valid_files()[which].clone();
        // Half the cases aim at the header, where sizes and offsets live.
        let span = if header_only { bytes.len().min(400) } else { bytes.len() };
        for (i, b) in flips {
            bytes[i % span] = b;
        }
        decode_all(dir.path(), &ext, &bytes);
    }
}
