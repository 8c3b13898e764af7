//! Numerical stability of the parameter networks (`estimate::ParamNet`),
//! random small ones and the shipped embedded weights: inputs at the
//! extremes of [-1, 1], constant planes, 1x1 and odd image sizes, several
//! views, give finite outputs; and a tiny change of the input gives a tiny
//! change of the output (a measured Lipschitz-style bound, stated below).

use burn::tensor::{Tensor, TensorData};
use matscan_estimate::net::models::Models;
use matscan_estimate::NetworkSpec;
use matscan_estimate::{cpu_device, NetConfig, NetOutput, ParamNet};
use matscan_scan::Param;
use proptest::prelude::*;
use std::sync::OnceLock;

/// Random-weight width of the fast tests (tracks of 2).
const WIDTH: usize = 8;

fn random_net(kind: Param, seed: u64) -> ParamNet {
    let device = cpu_device();
    device.seed(seed);
    ParamNet::new(NetConfig::new(kind, WIDTH).unwrap(), &device)
}

/// The shipped networks, loaded once per test binary.
fn embedded() -> &'static Models {
    static MODELS: OnceLock<Models> = OnceLock::new();
    MODELS.get_or_init(|| {
        Models::load_embedded(&matscan_estimate::PIPELINE_ORDER, &cpu_device()).unwrap()
    })
}

fn kind() -> impl Strategy<Value = Param> {
    prop::sample::select(matscan_estimate::PIPELINE_ORDER.to_vec())
}

/// How a plane of one channel is filled.
#[derive(Clone, Copy, Debug)]
enum Fill {
    Constant(f32),
    /// Alternating -1 / +1 (the largest local contrast).
    Checker,
    /// Pseudo-random in [-1, 1] from the seed.
    Noise(u32),
}

fn fill() -> impl Strategy<Value = Fill> {
    prop_oneof![
        Just(Fill::Constant(-1.0)),
        Just(Fill::Constant(1.0)),
        Just(Fill::Constant(0.0)),
        Just(Fill::Checker),
        (-1.0f32..=1.0).prop_map(Fill::Constant),
        any::<u32>().prop_map(Fill::Noise),
    ]
}

fn size() -> impl Strategy<Value = (usize, usize)> {
    prop_oneof![
        Just((1usize, 1usize)),
        Just((1, 7)),
        Just((5, 1)),
        Just((3, 3)),
        Just((17, 9)),
        Just((33, 31)),
        (1usize..24, 1usize..24),
    ]
}

fn plane(fill: Fill, channel: usize, h: usize, w: usize) -> impl Iterator<Item = f32> {
    (0..h * w).map(move |i| match fill {
        Fill::Constant(v) => v,
        Fill::Checker => {
            if (i % w + i / w + channel).is_multiple_of(2) {
                -1.0
            } else {
                1.0
            }
        }
        Fill::Noise(seed) => {
            let x = (i as u32)
                .wrapping_mul(2_654_435_761)
                .wrapping_add(seed ^ (channel as u32).wrapping_mul(40_503));
            let x = (x ^ (x >> 15)).wrapping_mul(2_246_822_519);
            (x >> 8) as f32 / (1u32 << 23) as f32 - 1.0
        }
    })
}

/// `views` views of `kind`'s inputs, every channel filled by `fills`
/// (cycled), the mask channel 0 kept at 1 (a whole object).
fn inputs(kind: Param, views: usize, h: usize, w: usize, fills: &[Fill]) -> Vec<Vec<f32>> {
    let c = kind.inputs().len();
    (0..views)
        .map(|v| {
            (0..c)
                .flat_map(|ch| {
                    let f = if ch == 0 {
                        Fill::Constant(1.0)
                    } else {
                        fills[(ch + v) % fills.len()]
                    };
                    plane(f, ch, h, w)
                })
                .collect()
        })
        .collect()
}

fn tensors(kind: Param, h: usize, w: usize, views: &[Vec<f32>]) -> Vec<Tensor<4>> {
    let c = kind.inputs().len();
    views
        .iter()
        .map(|v| Tensor::from_data(TensorData::new(v.clone(), [1, c, h, w]), &cpu_device()))
        .collect()
}

/// Every output value, fused first, then per view.
fn outputs(o: NetOutput) -> Vec<f32> {
    std::iter::once(o.fused)
        .chain(o.per_view)
        .flat_map(|t| t.into_data().try_to_vec::<f32>().unwrap())
        .collect()
}

fn run(net: &ParamNet, h: usize, w: usize, views: &[Vec<f32>]) -> Vec<f32> {
    outputs(
        net.forward(&tensors(net.config().kind(), h, w, views))
            .unwrap(),
    )
}

fn max_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// Input perturbation of the Lipschitz tests: every input value moves by
/// at most this (in network units, where [-1, 1] is the whole range).
const DELTA: f32 = 1e-3;

/// Largest output change per unit of input change (max norm over all
/// pixels, channels and views) allowed for a random width-8 network.
/// Measured: at most 0.16 over 200 random nets, kinds, sizes, fills and
/// perturbations (leaky ReLUs and max-fusion are 1-Lipschitz, so the gain
/// is the product of the freshly initialised convolutions' gains). The
/// bound is about 10x that: it still catches an amplifying bug such as an
/// unnormalised sum over pixels or views, which grows with the image.
const RANDOM_LIPSCHITZ: f32 = 2.0;
/// The same for the shipped weights: measured at most 3.2 over 96 cases
/// (trained nets have larger gains than fresh ones); bound about 10x.
const EMBEDDED_LIPSCHITZ: f32 = 30.0;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn random_networks_give_finite_outputs_for_extreme_inputs_and_any_size(
        kind in kind(),
        seed in any::<u64>(),
        (h, w) in size(),
        views in 1usize..4,
        fills in prop::collection::vec(fill(), 1..4),
    ) {
        let net = random_net(kind, seed);
        let out = run(&net, h, w, &inputs(kind, views, h, w, &fills));
        prop_assert!(!out.is_empty());
        let bad = out.iter().filter(|v| !v.is_finite()).count();
        prop_assert_eq!(bad, 0, "{} {}x{}: {} non-finite outputs", kind, h, w, bad);
    }

    #[test]
    fn a_tiny_input_change_gives_a_tiny_output_change_in_random_networks(
        kind in kind(),
        seed in any::<u64>(),
        (h, w) in size(),
        views in 1usize..3,
        fills in prop::collection::vec(fill(), 1..4),
        noise in any::<u32>(),
    ) {
        let net = random_net(kind, seed);
        let base = inputs(kind, views, h, w, &fills);
        let moved = perturb(&base, noise);
        let (a, b) = (run(&net, h, w, &base), run(&net, h, w, &moved));
        let ratio = max_abs_diff(&a, &b) / DELTA;
        prop_assert!(ratio <= RANDOM_LIPSCHITZ, "{kind} {h}x{w}: output moved {ratio} x the input");
    }
}

/// Every non-mask value moved by ±DELTA (sign pseudo-random), kept in
/// [-1, 1] by moving inward at the ends.
fn perturb(views: &[Vec<f32>], seed: u32) -> Vec<Vec<f32>> {
    views
        .iter()
        .map(|v| {
            v.iter()
                .enumerate()
                .map(|(i, &x)| {
                    let bit = ((i as u32).wrapping_mul(2_654_435_761) ^ seed) >> 13 & 1;
                    let d = if bit == 0 { DELTA } else { -DELTA };
                    let y = x + d;
                    if (-1.0..=1.0).contains(&y) {
                        y
                    } else {
                        x - d
                    }
                })
                .collect()
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(8))]

    #[test]
    fn shipped_networks_stay_finite_and_smooth_on_extreme_inputs(
        kind in kind(),
        (h, w) in prop_oneof![Just((1usize, 1usize)), Just((7, 5)), Just((17, 19))],
        fills in prop::collection::vec(fill(), 1..3),
        noise in any::<u32>(),
    ) {
        let net = &embedded().get(kind).unwrap().net;
        let base = inputs(kind, 2, h, w, &fills);
        let a = run(net, h, w, &base);
        prop_assert!(a.iter().all(|v| v.is_finite()), "{kind} {h}x{w}");
        let b = run(net, h, w, &perturb(&base, noise));
        let ratio = max_abs_diff(&a, &b) / DELTA;
        prop_assert!(ratio <= EMBEDDED_LIPSCHITZ, "{kind} {h}x{w}: output moved {ratio} x the input");
    }
}

#[test]
fn the_mask_channel_switching_off_everywhere_stays_finite() {
    // An all-zero mapped mask (no view sees the object) and inputs pinned
    // at +-1: fusion and pooling see nothing valid anywhere.
    for kind in matscan_estimate::PIPELINE_ORDER {
        let net = random_net(kind, 3);
        let c = kind.inputs().len();
        let (h, w) = (9, 11);
        let values: Vec<f32> = (0..c * h * w)
            .map(|i| {
                if i < h * w {
                    0.0
                } else if i % 2 == 0 {
                    1.0
                } else {
                    -1.0
                }
            })
            .collect();
        let out = run(&net, h, w, &[values.clone(), values]);
        assert!(out.iter().all(|v| v.is_finite()), "{kind}");
    }
}
