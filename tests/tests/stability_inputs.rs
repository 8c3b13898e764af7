//! Numerical stability of input preprocessing (`estimate::inputs`): a scan
//! whose photos are all black, saturated, spread over a 1e6 dynamic range
//! or show a black white reference still yields network inputs that are
//! finite and in [-1, 1] for every network; photo files holding NaN or
//! infinity are refused with an error naming the file, so no NaN reaches a
//! network.

use crate::common;

use burn::tensor::{Device, Tensor};
use matscan_calib::calibrate_bundle;
use matscan_estimate::pipeline::inputs::{Dependencies, SceneInputs};
use matscan_estimate::pipeline::views::select_views;
use matscan_estimate::{cpu_device, EstimateOptions, ModelSource, ViewFilter};
use matscan_scan::raster::RgbRaster;
use matscan_scan::Bundle;
use matscan_scan::Param;
use proptest::prelude::*;
use std::path::Path;

/// Assembles every network's inputs for the scan at `scan` with
/// dependencies all equal to `dep` and illumination `illum`, and returns the
/// values of every tensor.
fn all_inputs(scan: &Path, dep: f32, illum: f32, device: &Device) -> Vec<(Param, Vec<f32>)> {
    let bundle = Bundle::open(scan).unwrap();
    let calibration = calibrate_bundle(&bundle, &common::no_bad_light_check()).unwrap();
    let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default()).unwrap();
    let inputs = SceneInputs::assemble(&bundle, &calibration, &set).unwrap();
    let n = inputs.pixels();
    let plane = vec![dep; n];
    let illumination = vec![vec![illum; n]; inputs.views.len()];
    let deps = Dependencies {
        metallic: Some(&plane),
        transmission_final: Some(&plane),
        subsurface_final: Some(&plane),
        roughness: Some(&plane),
        illumination: Some(&illumination),
    };
    let which: Vec<usize> = (0..inputs.views.len()).collect();
    matscan_estimate::PIPELINE_ORDER
        .iter()
        .map(|&kind| {
            let tensors = inputs.tensors(kind, &which, &deps, device).unwrap();
            let values = tensors
                .into_iter()
                .flat_map(|t: Tensor<4>| t.into_data().try_to_vec::<f32>().unwrap())
                .collect();
            (kind, values)
        })
        .collect()
}

fn assert_in_range(scan: &Path, dep: f32, illum: f32) -> Result<(), TestCaseError> {
    let device = cpu_device();
    for (kind, values) in all_inputs(scan, dep, illum, &device) {
        prop_assert!(!values.is_empty());
        let bad = values
            .iter()
            .filter(|v| !(v.is_finite() && (-1.0..=1.0).contains(*v)))
            .count();
        prop_assert_eq!(bad, 0, "{} inputs: {} values outside [-1, 1]", kind, bad);
    }
    Ok(())
}

/// Dependency and illumination values, including non-finite ones (they
/// come from other networks and must be clamped, not trusted).
fn dependency_value() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(1.0f32),
        Just(-5.0f32),
        Just(f32::NAN),
        Just(f32::INFINITY),
        -2.0f32..2.0,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    #[test]
    fn constant_photos_from_black_to_far_beyond_saturation_give_inputs_in_range(
        value in prop_oneof![Just(0.0f32), Just(1.0f32), Just(65504.0f32), Just(1e30f32), 0f32..2.0],
        dep in dependency_value(),
        illum in dependency_value(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let scan = common::copy(dir.path());
        common::constant_photos(&scan, value);
        assert_in_range(&scan, dep, illum)?;
    }

    /// Every pixel scaled by its own factor 10^k, k uniform in [-6, 0]: a
    /// 1e6 dynamic range inside one photo and between photos.
    #[test]
    fn photos_spanning_a_1e6_dynamic_range_give_inputs_in_range(
        seed in any::<u64>(),
        dep in dependency_value(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let scan = common::copy(dir.path());
        let mut state = seed | 1;
        let mut next = move || {
            // xorshift64*: a tiny generator so the factors follow the seed.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
        };
        common::rewrite_photos(&scan, |_, _, p| {
            let mut out = p.clone();
            for px in &mut out.data {
                let k = 10f32.powf(-6.0 * next());
                *px = px.map(|v| v * k);
            }
            out
        });
        assert_in_range(&scan, dep, 0.5)?;
    }
}

#[test]
fn a_black_white_reference_gives_inputs_in_range() {
    let dir = tempfile::tempdir().unwrap();
    let scan = common::copy(dir.path());
    let bundle = Bundle::open(&scan).unwrap();
    let masks: Vec<_> = bundle
        .manifest
        .positions
        .iter()
        .map(|p| bundle.read_white_reference_mask(&p.name).unwrap())
        .collect();
    assert!(
        masks
            .iter()
            .all(|m| m.as_ref().is_some_and(|m| m.data.iter().any(|&w| w))),
        "the fixture must show its white reference"
    );
    common::rewrite_photos(&scan, |pi, _, p| {
        let mask = masks[pi].as_ref().unwrap();
        let mut out = p.clone();
        for (px, &white) in out.data.iter_mut().zip(&mask.data) {
            if white {
                *px = [0.0; 3];
            }
        }
        out
    });
    assert_in_range(&scan, 0.5, 0.5).unwrap();
}

/// Writes an EXR holding `bad` at one pixel, bypassing the scan writer
/// (which refuses non-finite values).
fn write_raw_exr(path: &Path, photo: &RgbRaster, bad: f32) {
    use exr::prelude::*;
    let (w, h) = (photo.width as usize, photo.height as usize);
    let mut data = photo.data.clone();
    data[w * h / 2] = [bad, 0.5, bad];
    write_rgb_file(path, w, h, |x, y| {
        let p = data[y * w + x];
        (p[0], p[1], p[2])
    })
    .unwrap();
}

#[test]
fn nan_or_infinite_photo_pixels_are_refused_naming_the_file() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let dir = tempfile::tempdir().unwrap();
        let scan = common::copy(dir.path());
        let bundle = Bundle::open(&scan).unwrap();
        let position = &bundle.manifest.positions[0];
        let capture = position
            .captures
            .iter()
            .find(|c| !c.lights.is_empty())
            .unwrap();
        let photo = bundle.read_photo(&position.name, &capture.name).unwrap();
        write_raw_exr(&scan.join(&capture.file), &photo, bad);
        // The whole estimate stops before any network sees the value.
        let err = matscan_estimate::estimate(
            &scan,
            ModelSource::Embedded,
            &EstimateOptions::default(),
            &cpu_device(),
        )
        .unwrap_err()
        .to_string();
        let file = capture.file.display().to_string();
        assert!(
            err.contains(&file) && err.contains("NaN or infinite"),
            "{bad}: {err}"
        );
        assert!(
            !scan.join("estimate").exists(),
            "{bad}: an estimate was written"
        );
    }
}
