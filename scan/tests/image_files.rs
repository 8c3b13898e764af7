//! Image codecs of the bundle: EXR half/float and PNG linear/sRGB round
//! trips with value checks, tolerated layouts (RGBA, Y, one channel, 8-bit),
//! orientation (row 0 on top), and the refusal of non-finite pixels.

use exr::prelude::f16;
use matscan_scan::image_io::{
    linear_to_srgb, read_mask_png, read_rgb, read_rgb_exr, read_rgb_png, read_scalar_exr,
    srgb_to_linear, write_mask_png, write_preview_png, write_rgb_exr, write_rgb_png16,
    write_scalar_exr, write_scalar_preview_png, Precision,
};
use matscan_scan::manifest::Encoding;
use matscan_scan::raster::{MaskRaster, Raster, RgbRaster, ScalarRaster};
use std::path::Path;

fn gradient(w: u32, h: u32) -> RgbRaster {
    Raster::from_fn(w, h, |x, y| {
        [
            x as f32 / w as f32,
            y as f32 / h as f32,
            0.25 + 0.5 * ((x + y) % 2) as f32,
        ]
    })
}

#[test]
fn float_exr_round_trips_bit_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let mut img = gradient(5, 3);
    img.data[0] = [-0.125, 1e6, 1e-20];
    write_rgb_exr(&path, &img, Precision::Float).unwrap();
    assert_eq!(read_rgb_exr(&path).unwrap(), img);
    assert_eq!(read_rgb(&path, None).unwrap(), img);
    assert_eq!(read_rgb(&path, Some(Encoding::Linear)).unwrap(), img);
}

#[test]
fn half_exr_round_trips_within_half_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let mut img = gradient(7, 4);
    img.data[1] = [0.1, 3.3, 60000.0];
    write_rgb_exr(&path, &img, Precision::Half).unwrap();
    let back = read_rgb_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (7, 4));
    for (a, b) in img.data.iter().flatten().zip(back.data.iter().flatten()) {
        assert!((a - b).abs() <= a.abs() / 2048.0, "{a} read back as {b}");
    }
    // Values a half holds exactly come back exactly.
    assert_eq!(back.data[0], [0.0, 0.0, 0.25]);
    // And the file really is half: 0.1 is not representable.
    assert_ne!(back.data[1][0], 0.1);
    assert_eq!(back.data[1][0], f16::from_f32(0.1).to_f32());
}

#[test]
fn scalar_exr_stores_its_channel_in_r_and_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("roughness.exr");
    let img: ScalarRaster = Raster::from_fn(4, 3, |x, y| (x * 3 + y) as f32 / 11.0);
    write_scalar_exr(&path, &img, Precision::Float).unwrap();
    assert_eq!(read_scalar_exr(&path).unwrap(), img);
    let raw = exr::prelude::read_first_flat_layer_from_file(&path).unwrap();
    let names: Vec<String> = raw
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["R"]);
    // Read as a photo, one channel becomes grey.
    let rgb = read_rgb_exr(&path).unwrap();
    assert_eq!(rgb.data[5], [img.data[5]; 3]);
}

#[test]
fn exr_row_zero_is_the_top_row_as_other_readers_see_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.exr");
    let img = gradient(6, 4);
    write_rgb_exr(&path, &img, Precision::Float).unwrap();
    let other = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |res, _| vec![[0.0f32; 3]; res.width() * res.height()],
        move |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 6 + pos.x()] = [r, g, b]
        },
    )
    .unwrap();
    assert_eq!(other.layer_data.channel_data.pixels, img.data);
    assert_eq!(img.get(1, 3)[1], 0.75);
}

fn write_exr_channels(path: &Path, w: usize, h: usize, channels: Vec<(&str, Vec<f32>)>) {
    use exr::prelude::*;
    let list: Vec<AnyChannel<FlatSamples>> = channels
        .into_iter()
        .map(|(n, v)| AnyChannel::new(n, FlatSamples::F32(v)))
        .collect();
    let layer = Layer::new(
        (w, h),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(SmallVec::from_vec(list)),
    );
    Image::from_layer(layer).write().to_file(path).unwrap();
}

#[test]
fn exr_reading_accepts_rgba_and_luminance_and_rejects_other_channel_sets() {
    let dir = tempfile::tempdir().unwrap();
    let rgba = dir.path().join("rgba.exr");
    let (w, h) = (3, 2);
    let ramp = |k: f32| (0..w * h).map(|i| i as f32 * k).collect::<Vec<f32>>();
    write_exr_channels(
        &rgba,
        w,
        h,
        vec![
            ("R", ramp(1.0)),
            ("G", ramp(2.0)),
            ("B", ramp(3.0)),
            ("A", vec![0.0; 6]),
        ],
    );
    let img = read_rgb_exr(&rgba).unwrap();
    assert_eq!(img.data[4], [4.0, 8.0, 12.0]);

    let y = dir.path().join("y.exr");
    write_exr_channels(&y, w, h, vec![("Y", ramp(0.5))]);
    assert_eq!(read_rgb_exr(&y).unwrap().data[3], [1.5; 3]);
    assert_eq!(read_scalar_exr(&y).unwrap().data[3], 1.5);

    let uv = dir.path().join("uv.exr");
    write_exr_channels(&uv, w, h, vec![("U", ramp(1.0)), ("V", ramp(1.0))]);
    let msg = read_rgb_exr(&uv).unwrap_err().to_string();
    assert!(
        msg.contains("uv.exr")
            && msg.contains("expected channels R G B, Y or a single channel, found U V"),
        "{msg}"
    );
}

#[test]
fn non_finite_pixels_are_rejected_on_read_and_write() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nan.exr");
    let mut values = vec![0.5f32; 6];
    values[2] = f32::NAN;
    values[4] = f32::INFINITY;
    write_exr_channels(
        &path,
        3,
        2,
        vec![
            ("R", values.clone()),
            ("G", vec![0.0; 6]),
            ("B", vec![0.0; 6]),
        ],
    );
    let msg = read_rgb_exr(&path).unwrap_err().to_string();
    assert!(
        msg.contains("nan.exr") && msg.contains("2 pixels hold NaN or infinite values"),
        "{msg}"
    );
    assert!(read_scalar_exr(&path).is_err());

    let mut img = gradient(3, 2);
    img.data[1][2] = f32::NAN;
    let out = dir.path().join("out.exr");
    let msg = write_rgb_exr(&out, &img, Precision::Float)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("refusing to write 1 NaN or infinite values"),
        "{msg}"
    );
    assert!(!out.exists());
}

#[test]
fn half_writes_refuse_values_beyond_the_half_range() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("big.exr");
    let mut img = gradient(3, 2);
    img.data[0][0] = 70000.0;
    img.data[1][1] = -1e9;
    let msg = write_rgb_exr(&path, &img, Precision::Half)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("2 values exceed the half-float range")
            && msg.contains("write Float precision"),
        "{msg}"
    );
    assert!(!path.exists());
    write_rgb_exr(&path, &img, Precision::Float).unwrap();
    assert_eq!(read_rgb_exr(&path).unwrap().data[0][0], 70000.0);
}

#[test]
fn rasters_whose_data_does_not_match_their_size_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bad = Raster {
        width: 4,
        height: 4,
        data: vec![[0.0f32; 3]; 3],
    };
    let msg = write_rgb_exr(&dir.path().join("a.exr"), &bad, Precision::Float)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("cannot write 3 pixels as a 4x4 image"),
        "{msg}"
    );
    assert!(write_preview_png(&dir.path().join("a.png"), &bad).is_err());
    let empty: MaskRaster = Raster::filled(0, 3, false);
    assert!(write_mask_png(&dir.path().join("m.png"), &empty).is_err());
}

#[test]
fn png16_linear_round_trips_to_16_bit_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.png");
    let img = gradient(5, 4);
    write_rgb_png16(&path, &img, Encoding::Linear).unwrap();
    let back = read_rgb_png(&path, Encoding::Linear).unwrap();
    for (a, b) in img.data.iter().flatten().zip(back.data.iter().flatten()) {
        assert!((a - b).abs() <= 0.5 / 65535.0 + 1e-7, "{a} vs {b}");
    }
    // Out-of-range values clip like a camera's.
    let mut hot = img.clone();
    hot.data[0] = [2.0, -1.0, 0.5];
    write_rgb_png16(&path, &hot, Encoding::Linear).unwrap();
    let back = read_rgb_png(&path, Encoding::Linear).unwrap();
    assert_eq!(back.data[0][0], 1.0);
    assert_eq!(back.data[0][1], 0.0);
}

#[test]
fn png16_srgb_is_decoded_to_linear() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.png");
    let img = gradient(5, 4);
    write_rgb_png16(&path, &img, Encoding::Srgb).unwrap();
    let back = read_rgb_png(&path, Encoding::Srgb).unwrap();
    for (a, b) in img.data.iter().flatten().zip(back.data.iter().flatten()) {
        assert!((a - b).abs() <= 2e-5, "{a} vs {b}");
    }
    // The stored values are the sRGB-encoded ones: linear 0.25 is ~0.537.
    let raw = read_rgb_png(&path, Encoding::Linear).unwrap();
    assert!(
        (raw.data[0][2] - 0.537_098_6).abs() < 2e-5,
        "{}",
        raw.data[0][2]
    );
    // Through read_rgb's dispatch as well.
    assert_eq!(read_rgb(&path, Some(Encoding::Srgb)).unwrap(), back);
}

#[test]
fn eight_bit_and_grey_pngs_are_accepted_as_photos() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grey8.png");
    image::GrayImage::from_fn(3, 2, |x, _| image::Luma([if x == 0 { 255 } else { 128 }]))
        .save(&path)
        .unwrap();
    let linear = read_rgb_png(&path, Encoding::Linear).unwrap();
    assert_eq!(linear.data[0], [1.0; 3]);
    assert!((linear.data[1][0] - 128.0 / 255.0).abs() < 1e-6);
    let srgb = read_rgb_png(&path, Encoding::Srgb).unwrap();
    assert!((srgb.data[1][0] - srgb_to_linear(128.0 / 255.0)).abs() < 1e-6);
    assert!((srgb.data[1][0] - 0.2158605).abs() < 1e-5);
}

#[test]
fn read_rgb_requires_an_encoding_for_png_and_refuses_srgb_exr() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("a.png");
    let exr = dir.path().join("a.exr");
    let img = gradient(2, 2);
    write_rgb_png16(&png, &img, Encoding::Linear).unwrap();
    write_rgb_exr(&exr, &img, Precision::Float).unwrap();
    let msg = read_rgb(&png, None).unwrap_err().to_string();
    assert!(msg.contains("a PNG photo needs its encoding"), "{msg}");
    let msg = read_rgb(&exr, Some(Encoding::Srgb))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("EXR photos are linear"), "{msg}");
    let msg = read_rgb(&dir.path().join("a.jpg"), None)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("expected a .exr or .png image"), "{msg}");
}

#[test]
fn masks_round_trip_and_any_nonzero_colour_channel_counts() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mask.png");
    let mask: MaskRaster = Raster::from_fn(5, 3, |x, y| (x + 2 * y) % 3 == 0);
    write_mask_png(&path, &mask).unwrap();
    assert_eq!(read_mask_png(&path).unwrap(), mask);
    let raw = image::open(&path).unwrap();
    assert_eq!(raw.color(), image::ColorType::L8);

    let rgba = dir.path().join("rgba.png");
    let img = image::RgbaImage::from_fn(3, 1, |x, _| match x {
        0 => image::Rgba([0, 1, 0, 255]),
        1 => image::Rgba([0, 0, 0, 255]),
        _ => image::Rgba([0, 0, 0, 0]),
    });
    img.save(&rgba).unwrap();
    assert_eq!(read_mask_png(&rgba).unwrap().data, [true, false, false]);
}

#[test]
fn previews_are_8_bit_srgb_and_scalar_previews_are_plain_grey() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.png");
    let img = Raster::from_vec(
        4,
        1,
        vec![[0.5, 0.0, 1.0], [2.0, -1.0, f32::NAN], [0.0; 3], [1.0; 3]],
    )
    .unwrap();
    write_preview_png(&path, &img).unwrap();
    let back = image::open(&path).unwrap().into_rgb8();
    assert_eq!(back.get_pixel(0, 0).0, [188, 0, 255]);
    assert_eq!(back.get_pixel(1, 0).0, [255, 0, 0]);

    let scalar = Raster::from_vec(3, 1, vec![0.5, 1.5, f32::NAN]).unwrap();
    let spath = dir.path().join("s.png");
    write_scalar_preview_png(&spath, &scalar).unwrap();
    let back = image::open(&spath).unwrap().into_luma8();
    assert_eq!(back.as_raw().as_slice(), [128, 255, 0]);
}

#[test]
fn srgb_curves_invert_each_other() {
    for i in 0..=1000 {
        let v = i as f32 / 1000.0;
        assert!((srgb_to_linear(linear_to_srgb(v)) - v).abs() < 1e-6, "{v}");
    }
    assert!((linear_to_srgb(0.5) - 0.735_356_7).abs() < 1e-6);
}

#[test]
fn missing_and_garbage_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.exr");
    let msg = read_rgb_exr(&missing).unwrap_err().to_string();
    assert!(msg.contains("none.exr"), "{msg}");
    let garbage = dir.path().join("garbage.png");
    std::fs::write(&garbage, b"this is not a png").unwrap();
    let msg = read_mask_png(&garbage).unwrap_err().to_string();
    assert!(
        msg.contains("garbage.png: not a readable PNG image"),
        "{msg}"
    );
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"this is not an exr").unwrap();
    let msg = read_rgb_exr(&garbage).unwrap_err().to_string();
    assert!(
        msg.contains("garbage.exr: not a readable OpenEXR image"),
        "{msg}"
    );
}
