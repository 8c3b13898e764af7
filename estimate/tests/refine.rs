//! The per-pixel refinement on synthetic problems generated with its own
//! forward model: recovery from a poor start, a stiff near-mirror, the
//! prior where data are absent or blind, and hostile inputs.

use matscan_estimate::refine::loss::Prior;
use matscan_estimate::refine::model::{self, directions, Fixed, Observation, Params, N};
use matscan_estimate::refine::solver::{solve, Problem, Settings, StopReason};
use matscan_estimate::refine::{refine_pixels, Confidence, Hold, RefineOptions, Start};

/// (cos N·V, cos N·L, cos V·L) of a small rig: three cameras, each with
/// two lights beside it and one across, plus mirror configurations that
/// put a highlight in view.
fn rig(with_highlights: bool) -> Vec<(f32, f32, f32)> {
    let mut views = vec![
        (0.95, 0.7, 0.9),
        (0.95, 0.5, 0.2),
        (0.8, 0.9, -0.3),
        (0.7, 0.4, 0.95),
        (0.6, 0.85, 0.5),
        (0.9, 0.3, -0.6),
        (0.5, 0.6, 0.8),
    ];
    if with_highlights {
        // Mirror directions (equal polar angles, opposite azimuths) and
        // near-mirror ones.
        views.extend([(0.8, 0.8, -1.0), (0.9, 0.85, -0.98), (0.6, 0.65, -0.95)]);
    }
    views
}

fn observe(truth: &Params, fixed: &Fixed, views: &[(f32, f32, f32)]) -> Vec<Observation> {
    let bsdf = model::bsdf(&truth.to_x(), fixed);
    views
        .iter()
        .map(|&(nv, nl, vl)| {
            let (wo, wi) = directions(nv, nl, vl);
            let mut o = Observation {
                wo,
                wi,
                light: [0.5, 0.48, 0.45],
                observed: [0.0; 3],
                weight: 1.0,
            };
            let p = model::predict(&bsdf, &o);
            o.observed = p.map(|v| v as f32);
            o
        })
        .collect()
}

fn weak_prior(x0: [f64; N]) -> Prior {
    Prior {
        mean: x0,
        precision: [1e-4; N],
    }
}

fn settings(iterations: u32) -> Settings {
    Settings {
        max_iterations: iterations,
        ..Settings::default()
    }
}

fn poor_start() -> Params {
    Params {
        basecolor: [0.5, 0.5, 0.5],
        roughness: 0.8,
        metallic: 0.5,
    }
}

#[test]
fn the_fit_recovers_known_parameters_from_a_poor_start() {
    let cases = [
        Params {
            basecolor: [0.7, 0.3, 0.2],
            roughness: 0.35,
            metallic: 0.0,
        },
        Params {
            basecolor: [0.9, 0.6, 0.3],
            roughness: 0.25,
            metallic: 1.0,
        },
        Params {
            basecolor: [0.2, 0.5, 0.8],
            roughness: 0.6,
            metallic: 0.3,
        },
    ];
    let fixed = Fixed::default();
    for truth in cases {
        let obs = observe(&truth, &fixed, &rig(true));
        let x0 = poor_start().to_x();
        let fit = solve(
            &Problem {
                start: x0,
                prior: weak_prior(x0),
                fixed,
                observations: &obs,
            },
            &settings(60),
        );
        let got = Params::from_x(&fit.x);
        for c in 0..3 {
            assert!(
                (got.basecolor[c] - truth.basecolor[c]).abs() < 0.02,
                "{truth:?} -> {got:?} ({:?})",
                fit.stop
            );
        }
        assert!(
            (got.roughness - truth.roughness).abs() < 0.02,
            "{truth:?} -> {got:?}"
        );
        assert!(
            (got.metallic - truth.metallic).abs() < 0.03,
            "{truth:?} -> {got:?}"
        );
        assert!(fit.cost < 1e-3 * fit.start_cost, "{fit:?}");
    }
}

#[test]
fn a_stiff_near_mirror_converges_or_stops_with_a_reason_and_stays_finite() {
    let truth = Params {
        basecolor: [0.3, 0.3, 0.3],
        roughness: 0.03,
        metallic: 0.0,
    };
    let fixed = Fixed::default();
    let obs = observe(&truth, &fixed, &rig(true));
    // The exact-mirror view's highlight dwarfs every diffuse view.
    let peak = obs.iter().map(|o| o.observed[0]).fold(0.0f32, f32::max);
    let diffuse = obs[0].observed[0];
    assert!(peak > 100.0 * diffuse, "peak {peak} diffuse {diffuse}");
    for start_roughness in [1e-4, 1e-3, 0.05, 0.9] {
        let x0 = Params {
            roughness: start_roughness,
            ..poor_start()
        }
        .to_x();
        for iterations in [1, 5, 40] {
            let fit = solve(
                &Problem {
                    start: x0,
                    prior: weak_prior(x0),
                    fixed,
                    observations: &obs,
                },
                &settings(iterations),
            );
            assert!(fit.x.iter().all(|v| v.is_finite()), "{fit:?}");
            assert!(fit.posterior_variance.iter().all(|v| v.is_finite()));
            assert!(fit.cost <= fit.start_cost, "diverged: {fit:?}");
            assert!(fit.iterations <= iterations);
            if iterations == 40 {
                let got = Params::from_x(&fit.x);
                assert!(
                    matches!(fit.stop, StopReason::Converged | StopReason::StepTooSmall)
                        || (got.roughness - 0.03).abs() < 0.01,
                    "start {start_roughness}: {fit:?}"
                );
            }
        }
    }
}

#[test]
fn the_prior_decides_where_there_are_no_data() {
    let start = Params {
        basecolor: [0.4, 0.5, 0.6],
        roughness: 0.3,
        metallic: 0.2,
    };
    let x0 = start.to_x();
    let options = RefineOptions::default();
    let prior = options.prior(x0, &Hold::default());
    let truth = Params {
        basecolor: [0.9, 0.1, 0.1],
        roughness: 0.8,
        metallic: 0.9,
    };
    // Every view dropped (shadow, saturated, ...): weight 0.
    let mut obs = observe(&truth, &Fixed::default(), &rig(true));
    for o in &mut obs {
        o.weight = 0.0;
    }
    let fit = solve(
        &Problem {
            start: x0,
            prior,
            fixed: Fixed::default(),
            observations: &obs,
        },
        &settings(20),
    );
    assert_eq!(fit.stop, StopReason::NoData);
    assert_eq!(fit.x, x0);
    assert_eq!(
        Confidence::of(&fit.posterior_variance, &prior),
        Confidence::default()
    );
}

#[test]
fn roughness_confidence_is_low_where_no_highlight_is_ever_seen() {
    let truth = Params {
        basecolor: [0.6, 0.4, 0.3],
        roughness: 0.15,
        metallic: 0.0,
    };
    let fixed = Fixed::default();
    let options = RefineOptions::default();
    let start = Params {
        roughness: 0.1,
        metallic: 0.05,
        ..poor_start()
    };
    let x0 = start.to_x();
    let prior = options.prior(x0, &Hold::default());
    let run = |highlights: bool| {
        let obs = observe(&truth, &fixed, &rig(highlights));
        let fit = solve(
            &Problem {
                start: x0,
                prior,
                fixed,
                observations: &obs,
            },
            &settings(30),
        );
        (fit, Confidence::of(&fit.posterior_variance, &prior))
    };
    let (blind, blind_conf) = run(false);
    assert!(blind_conf.roughness < 0.3, "{blind_conf:?}");
    assert!(blind_conf.basecolor > 0.6, "{blind_conf:?}");
    let got = Params::from_x(&blind.x);
    assert!((got.basecolor[0] - 0.6).abs() < 0.05, "{got:?}");
    let (_, seen_conf) = run(true);
    assert!(seen_conf.roughness > 0.8, "{seen_conf:?}");
}

#[test]
fn hostile_pixels_give_finite_maps_and_every_pixel_a_stop_reason() {
    let n = 6;
    let mut start_base = vec![[0.5f32; 3]; n];
    start_base[1] = [f32::NAN, 2.0, -1.0];
    let roughness = vec![1e-4, f32::INFINITY, 0.5, 0.0, 1.0, 0.3];
    let metallic = vec![0.0, 0.5, f32::NAN, 1.0, 0.0, 0.2];
    let zeros = vec![0.0; n];
    let mask = vec![true, true, true, true, true, false];
    let start = Start {
        basecolor: &start_base,
        roughness: &roughness,
        metallic: &metallic,
        transmission: &zeros,
        subsurface: &zeros,
        mask: &mask,
        hold: Hold::default(),
    };
    let observe = |i: usize| -> Vec<Observation> {
        let (wo, wi) = directions(0.9, 0.8, -1.0);
        let base = Observation {
            wo,
            wi,
            light: [0.5; 3],
            observed: [0.2; 3],
            weight: 1.0,
        };
        match i {
            // Black pixel, zero light.
            0 => vec![Observation {
                observed: [0.0; 3],
                light: [0.0; 3],
                ..base
            }],
            // Non-finite photo and light.
            1 => vec![Observation {
                observed: [f32::NAN, f32::INFINITY, -1.0],
                light: [f32::INFINITY; 3],
                ..base
            }],
            // Degenerate directions (zero vectors, grazing).
            2 => {
                let (wo, wi) = directions(f32::NAN, 0.0, 2.0);
                vec![Observation {
                    wo,
                    wi: wi * 0.0,
                    ..base
                }]
            }
            // A huge (saturated-like) value.
            3 => vec![Observation {
                observed: [1e30; 3],
                ..base
            }],
            _ => vec![base],
        }
    };
    let options = RefineOptions {
        iterations: 8,
        ..RefineOptions::default()
    };
    let out = refine_pixels(&start, observe, &options);
    for i in 0..n {
        let values = [
            out.basecolor[i][0],
            out.basecolor[i][1],
            out.basecolor[i][2],
            out.roughness[i],
            out.metallic[i],
            out.confidence[i].basecolor,
            out.confidence[i].roughness,
            out.confidence[i].metallic,
        ];
        assert!(
            values
                .iter()
                .all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
            "pixel {i}: {values:?}"
        );
    }
    assert_eq!(out.roughness[5], 0.0, "unmasked pixels stay 0");
    assert_eq!(out.stops.values().sum::<u64>(), 5);
}
