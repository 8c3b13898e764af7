//! The texture file layout: what is written reads back (to 16-bit
//! precision), basecolor goes through the sRGB curve, row 0 is v = 1.

use matscan_bake::{read_textures, texel_uv, write_textures, BakeError, BakedTextures};
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::Param;

fn sample_set(w: u32, h: u32) -> BakedTextures {
    let coverage = MaskRaster::from_fn(w, h, |x, _| x % 2 == 0);
    let mut t = BakedTextures::new(coverage);
    t.set_basecolor(RgbRaster::from_fn(w, h, |x, y| {
        [x as f32 / w as f32, y as f32 / h as f32, 0.25]
    }))
    .unwrap();
    t.set_scalar(
        Param::Roughness,
        ScalarRaster::from_fn(w, h, |x, y| (x + y) as f32 / (w + h) as f32),
    )
    .unwrap();
    t.set_scalar(Param::Metallic, ScalarRaster::filled(w, h, 2.0))
        .unwrap();
    t
}

#[test]
fn written_textures_read_back_within_16_bit_precision() {
    let dir = tempfile::tempdir().unwrap();
    let t = sample_set(8, 5);
    write_textures(dir.path(), &t).unwrap();
    let back = read_textures(dir.path()).unwrap();
    assert_eq!(
        back.params(),
        vec![Param::Basecolor, Param::Roughness, Param::Metallic]
    );
    assert_eq!(back.coverage(), t.coverage());
    let (a, b) = (t.basecolor().unwrap(), back.basecolor().unwrap());
    for (p, q) in a.data.iter().zip(&b.data) {
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() < 2e-4, "{p:?} vs {q:?}");
        }
    }
    let (a, b) = (
        t.scalar(Param::Roughness).unwrap(),
        back.scalar(Param::Roughness).unwrap(),
    );
    for (p, q) in a.data.iter().zip(&b.data) {
        assert!((p - q).abs() < 2e-5, "{p} vs {q}");
    }
    // Out-of-range values are clipped to the parameter range.
    assert!(back
        .scalar(Param::Metallic)
        .unwrap()
        .data
        .iter()
        .all(|&v| v == 1.0));
}

#[test]
fn basecolor_file_holds_srgb_encoded_values() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = BakedTextures::new(MaskRaster::filled(2, 2, true));
    t.set_basecolor(RgbRaster::filled(2, 2, [0.214_041, 0.0, 1.0]))
        .unwrap();
    write_textures(dir.path(), &t).unwrap();
    let png = image::open(dir.path().join("basecolor.png")).unwrap();
    assert_eq!(png.color(), image::ColorType::Rgb16);
    let px = png.into_rgb16().get_pixel(0, 0).0;
    // Linear 0.214 is sRGB 0.5.
    assert!((f32::from(px[0]) / 65535.0 - 0.5).abs() < 1e-3, "{px:?}");
    assert_eq!(px[1], 0);
    assert_eq!(px[2], 65535);
    let cov = image::open(dir.path().join("coverage.png")).unwrap();
    assert_eq!(cov.color(), image::ColorType::L8);
}

#[test]
fn texel_row_zero_is_the_top_of_uv_space() {
    let top = texel_uv(0, 0, 4, 4);
    assert!((top.x - 0.125).abs() < 1e-6 && (top.y - 0.875).abs() < 1e-6);
    let bottom = texel_uv(3, 3, 4, 4);
    assert!((bottom.x - 0.875).abs() < 1e-6 && (bottom.y - 0.125).abs() < 1e-6);
}

#[test]
fn textures_of_another_size_are_refused() {
    let mut t = BakedTextures::new(MaskRaster::filled(4, 4, true));
    let err = t
        .set_scalar(Param::Roughness, ScalarRaster::filled(4, 3, 0.5))
        .unwrap_err();
    assert!(
        matches!(
            err,
            BakeError::SizeMismatch {
                found_height: 3,
                ..
            }
        ),
        "{err}"
    );
    let err = t
        .set_scalar(Param::Basecolor, ScalarRaster::filled(4, 4, 0.5))
        .unwrap_err();
    assert!(matches!(err, BakeError::WrongParam { .. }), "{err}");
}

#[test]
fn reading_a_folder_without_coverage_names_the_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let err = read_textures(dir.path()).unwrap_err().to_string();
    assert!(err.contains("coverage.png"), "{err}");
}
