//! Whole-network behaviour: sizes, multi-view fusion, roughness's per-view
//! output, and numerical safety under extreme inputs.

use burn::tensor::{Tensor, TensorData};
use matscan_estimate::NetworkSpec;
use matscan_estimate::{cpu_device, InputError, NetConfig, NetOutput, ParamNet};
use matscan_scan::Param;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn net(kind: Param, width: usize) -> ParamNet {
    let config = NetConfig::new(kind, width).expect("valid width");
    ParamNet::new(config, &cpu_device())
}

fn tensor(values: Vec<f32>, shape: [usize; 4]) -> Tensor<4> {
    Tensor::from_data(TensorData::new(values, shape), &cpu_device())
}

/// `count` views of uniform values in [-1, 1], mask channel (0) in {0, 1}.
fn random_views(kind: Param, count: usize, h: usize, w: usize, seed: u64) -> Vec<Tensor<4>> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let c = kind.inputs().len();
    (0..count)
        .map(|_| {
            let values = (0..c * h * w)
                .map(|i| {
                    if i < h * w {
                        f32::from(rng.gen_bool(0.8))
                    } else {
                        rng.gen_range(-1.0..1.0)
                    }
                })
                .collect();
            tensor(values, [1, c, h, w])
        })
        .collect()
}

fn bits(t: &Tensor<4>) -> Vec<u32> {
    t.to_data()
        .try_to_vec::<f32>()
        .expect("f32")
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

fn values(t: &Tensor<4>) -> Vec<f32> {
    t.to_data().try_to_vec::<f32>().expect("f32")
}

fn assert_finite(output: &NetOutput, what: &str) {
    for (i, map) in std::iter::once(&output.fused)
        .chain(&output.per_view)
        .enumerate()
    {
        let bad = values(map).into_iter().filter(|v| !v.is_finite()).count();
        assert_eq!(bad, 0, "{what}: map {i} has {bad} non-finite values");
    }
}

#[test]
fn outputs_have_exactly_the_input_size() {
    for (h, w) in [
        (256, 256),
        (512, 512),
        (768, 768),
        (97, 61),
        (1, 1),
        (16, 17),
    ] {
        for kind in [Param::Transmission, Param::Roughness] {
            let network = net(kind, 4);
            let views = random_views(kind, 2, h, w, 1);
            let out = network.forward(&views).expect("valid views");
            let fused = kind.fused_outputs().len();
            assert_eq!(out.fused.dims(), [1, fused, h, w], "{kind} at {h}x{w}");
            let per_view: Vec<[usize; 4]> = out.per_view.iter().map(|t| t.dims()).collect();
            let expected = if kind == Param::Roughness {
                vec![[1, 1, h, w]; 2]
            } else {
                Vec::new()
            };
            assert_eq!(per_view, expected, "{kind} at {h}x{w}");
        }
    }
}

#[test]
fn every_network_runs_one_and_nine_views() {
    for kind in matscan_estimate::PIPELINE_ORDER {
        let network = net(kind, 8);
        for count in [1, 9] {
            let views = random_views(kind, count, 24, 40, 2);
            let out = network.forward(&views).expect("valid views");
            assert_eq!(out.fused.dims()[1], kind.fused_outputs().len());
            assert_eq!(
                out.per_view.len(),
                if kind == Param::Roughness { count } else { 0 }
            );
            assert_finite(&out, &format!("{kind}, {count} views"));
        }
    }
}

#[test]
fn permuting_the_views_leaves_every_output_bit_identical() {
    let mut rng = Pcg64::seed_from_u64(3);
    for kind in [Param::Transmission, Param::Roughness] {
        let network = net(kind, 8);
        for count in 1..=5usize {
            let views = random_views(kind, count, 40, 24, 10 + count as u64);
            let reference = network.forward(&views).expect("valid views");
            let mut orders: Vec<Vec<usize>> = Vec::new();
            let mut order: Vec<usize> = (0..count).collect();
            for _ in 0..4 {
                order.shuffle(&mut rng);
                orders.push(order.clone());
            }
            orders.push((0..count).rev().collect());
            for order in orders {
                let permuted: Vec<Tensor<4>> = order.iter().map(|&v| views[v].clone()).collect();
                let out = network.forward(&permuted).expect("valid views");
                assert_eq!(
                    bits(&out.fused),
                    bits(&reference.fused),
                    "{kind}, order {order:?}"
                );
                assert_eq!(out.per_view.len(), reference.per_view.len());
                for (slot, &view) in order
                    .iter()
                    .enumerate()
                    .filter(|_| !out.per_view.is_empty())
                {
                    assert_eq!(
                        bits(&out.per_view[slot]),
                        bits(&reference.per_view[view]),
                        "{kind}: illumination of view {view} at slot {slot}"
                    );
                }
            }
        }
    }
}

#[test]
fn fusion_lets_every_view_see_the_others() {
    let kind = Param::Transmission;
    let network = net(kind, 8);
    let views = random_views(kind, 2, 32, 32, 4);
    let alone = network.forward(&views[..1]).expect("valid views");
    let together = network.forward(&views).expect("valid views");
    assert_ne!(bits(&alone.fused), bits(&together.fused));
    // Two copies of one view fuse to that view: max(a, a) = a.
    let twice = network
        .forward(&[views[0].clone(), views[0].clone()])
        .expect("valid views");
    assert_eq!(bits(&twice.fused), bits(&alone.fused));
}

#[test]
fn roughness_fuses_one_half_and_keeps_illumination_per_view() {
    let kind = Param::Roughness;
    let network = net(kind, 8);
    let views = random_views(kind, 3, 32, 20, 5);
    let out = network.forward(&views).expect("valid views");
    assert_eq!(out.fused.dims(), [1, 1, 32, 20]);
    assert_eq!(out.per_view.len(), 3);
    // Different views light the object differently: their illuminations differ.
    assert_ne!(bits(&out.per_view[0]), bits(&out.per_view[1]));
    assert_ne!(bits(&out.per_view[1]), bits(&out.per_view[2]));
    // A view's illumination depends on the other views only through the
    // fused half, so adding views changes it, but not its shape.
    let alone = network.forward(&views[..1]).expect("valid views");
    assert_eq!(alone.per_view[0].dims(), out.per_view[0].dims());
    assert_ne!(bits(&alone.per_view[0]), bits(&out.per_view[0]));
}

/// Mask value at (row, column).
type Mask<'a> = &'a dyn Fn(usize, usize) -> f32;

/// Views of one value everywhere except the mask.
fn filled(kind: Param, h: usize, w: usize, mask: Mask, value: f32) -> Tensor<4> {
    let c = kind.inputs().len();
    let mut data = vec![value; c * h * w];
    for y in 0..h {
        for x in 0..w {
            data[y * w + x] = mask(y, x);
        }
    }
    tensor(data, [1, c, h, w])
}

#[test]
fn extreme_inputs_give_finite_outputs() {
    let (h, w) = (37, 20);
    let everywhere = |_: usize, _: usize| 1.0;
    let one_pixel = |y: usize, x: usize| f32::from(y == 18 && x == 7);
    let one_column = |_: usize, x: usize| f32::from(x == 11);
    let one_row = |y: usize, _: usize| f32::from(y == 0);
    let masks: [(&str, Mask); 4] = [
        ("full mask", &everywhere),
        ("holes everywhere but one pixel", &one_pixel),
        ("one-pixel-wide column", &one_column),
        ("one-pixel-high row", &one_row),
    ];
    let fills = [
        ("black", -1.0f32),
        ("zero", 0.0),
        ("saturated", 1.0),
        ("far out of range", 1.0e30),
        ("infinite", f32::INFINITY),
        ("minus infinite", f32::NEG_INFINITY),
        ("NaN", f32::NAN),
    ];
    for kind in matscan_estimate::PIPELINE_ORDER {
        let network = net(kind, 8);
        for (mask_name, mask) in masks {
            for (fill_name, value) in fills {
                let views: Vec<Tensor<4>> =
                    (0..3).map(|_| filled(kind, h, w, mask, value)).collect();
                let out = network.forward(&views).expect("valid views");
                assert_finite(&out, &format!("{kind}, {mask_name}, {fill_name}"));
            }
        }
        // Every view different: one black, one saturated, one NaN.
        let mixed = vec![
            filled(kind, h, w, &one_pixel, -1.0),
            filled(kind, h, w, &one_column, 1.0),
            filled(kind, h, w, &everywhere, f32::NAN),
        ];
        assert_finite(
            &network.forward(&mixed).expect("valid views"),
            &format!("{kind}, mixed"),
        );
    }
}

#[test]
fn wrong_views_are_refused_with_the_reason() {
    let kind = Param::Subsurface;
    let network = net(kind, 4);
    assert_eq!(
        network.forward(&[]).unwrap_err(),
        InputError::NoViews { kind }
    );
    let wrong_channels = random_views(Param::Transmission, 1, 8, 8, 6);
    match network.forward(&wrong_channels) {
        Err(InputError::Shape {
            view: 0,
            channels: 7,
            found,
            ..
        }) => assert_eq!(found, [1, 5, 8, 8]),
        other => panic!("expected a shape error, got {other:?}"),
    }
    let mut views = random_views(kind, 2, 8, 8, 7);
    views.extend(random_views(kind, 1, 8, 9, 8));
    let err = network.forward(&views).unwrap_err();
    assert_eq!(
        err,
        InputError::SizeMismatch {
            view: 2,
            found: [8, 9],
            first: [8, 8]
        }
    );
    assert!(err.to_string().contains("view 2"), "{err}");
}
