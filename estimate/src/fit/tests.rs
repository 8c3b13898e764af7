//! The fit on synthetic pixels: a dome of normals seen by one camera under
//! five point lights, photos predicted by the model itself.

use super::linear::Sample;
use super::*;
use crate::refine::model::{bsdf, Observation, Params};
use glam::Vec3;
use highlight::HighlightColour;

/// A local frame with `n` as +Z.
fn local(n: Vec3, v: Vec3) -> Vec3 {
    let t = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let t = (t - n * n.dot(t)).normalize();
    let b = n.cross(t);
    Vec3::new(v.dot(t), v.dot(b), v.dot(n))
}

/// Pixel `i` of a `side` x `side` dome: its normal.
fn normal(i: usize, side: usize) -> Option<Vec3> {
    let (x, y) = ((i % side) as f32, (i / side) as f32);
    let u = 2.0 * (x + 0.5) / side as f32 - 1.0;
    let v = 2.0 * (y + 0.5) / side as f32 - 1.0;
    let z2 = 1.0 - u * u - v * v;
    (z2 > 0.05).then(|| Vec3::new(u, v, z2.sqrt()))
}

/// Two flashes and the projector beside the camera, and the same from two
/// more positions of the head (seen from the reference camera, their
/// lights come from the side).
fn lights() -> [Vec3; 5] {
    [
        Vec3::new(0.25, 0.0, 1.0).normalize(),
        Vec3::new(-0.25, 0.05, 1.0).normalize(),
        Vec3::new(0.0, 0.3, 1.0).normalize(),
        Vec3::new(0.8, 0.0, 0.6).normalize(),
        Vec3::new(-0.7, 0.3, 0.6).normalize(),
    ]
}

/// Observations of pixel `i` whose truth is `truth(i)`.
fn observe(i: usize, side: usize, truth: &dyn Fn(usize) -> Params) -> Vec<Sample> {
    let Some(n) = normal(i, side) else {
        return Vec::new();
    };
    let p = truth(i);
    let b = bsdf(&p.to_x(), &Fixed::default());
    let view = Vec3::Z;
    lights()
        .iter()
        .filter_map(|&l| {
            let (wo, wi) = (local(n, view), local(n, l));
            if wo.z <= 0.05 || wi.z <= 0.05 {
                return None;
            }
            Some(Sample::exact(Observation::rendered(&b, wo, wi, [1.5; 3])))
        })
        .collect()
}

const RED_PLASTIC: Params = Params {
    basecolor: [0.7, 0.12, 0.08],
    roughness: 0.15,
    metallic: 0.0,
};
const GOLD: Params = Params {
    basecolor: [0.9, 0.65, 0.25],
    roughness: 0.4,
    metallic: 1.0,
};

#[test]
fn two_materials_get_their_roughness_metallic_and_basecolor_back() {
    let side = 48;
    let truth = |i: usize| {
        if (i % side) < side / 2 {
            RED_PLASTIC
        } else {
            GOLD
        }
    };
    let mask: Vec<bool> = (0..side * side)
        .map(|i| normal(i, side).is_some())
        .collect();
    let fitted = fit_pixels(
        &mask,
        side,
        |i| observe(i, side, &truth),
        &vec![0.0; side * side],
        Known::default(),
        None,
        &FitOptions::default(),
    );
    // The metal's apparent albedo changes toward its rim: it may split.
    assert!(
        (2..=4).contains(&fitted.materials.len()),
        "{:?}",
        fitted.materials
    );
    let object: Vec<usize> = (0..side * side).filter(|&i| mask[i]).collect();
    // The dielectric comes back to within 10% roughness and 0.03
    // basecolor; the rough metal's roughness within 25%, its metallic
    // on all but the grazing rim. Its basecolor trades against roughness (a lobe 20% broader
    // with a basecolor a third darker explains each pixel's five views as
    // well), which a per-pixel basecolor cannot break: that shortfall is
    // the next step of the fit (a basecolor shared within a material).
    let (mut plastic, mut plastic_good, mut gold, mut gold_good) = (0, 0, 0, 0);
    let metal_right = object
        .iter()
        .filter(|&&i| fitted.metallic[i] == truth(i).metallic)
        .count();
    assert!(
        metal_right as f64 > 0.97 * object.len() as f64,
        "{metal_right}"
    );
    for &i in &object {
        let t = truth(i);
        let rel = (fitted.roughness[i] - t.roughness).abs() / t.roughness;
        if t.metallic == 0.0 {
            plastic += 1;
            let bc = (0..3).all(|c| (fitted.basecolor[i][c] - t.basecolor[c]).abs() < 0.03);
            plastic_good += usize::from(rel < 0.1 && bc);
        } else {
            gold += 1;
            gold_good += usize::from(rel < 0.25);
        }
    }
    assert!(
        plastic_good as f64 > 0.95 * plastic as f64,
        "{plastic_good} of {plastic}"
    );
    assert!(
        gold_good as f64 > 0.95 * gold as f64,
        "{gold_good} of {gold}"
    );
    assert!(fitted
        .materials
        .iter()
        .all(|m| m.roughness_pinned && m.metallic_pinned));
    assert!(fitted.constrained.roughness > 0.99 && fitted.constrained.basecolor > 0.99);
}

#[test]
fn pixels_without_observations_take_the_fallback_and_are_not_counted_as_pinned() {
    let side = 16;
    let mask = vec![true; side * side];
    let n = side * side;
    let fallback_bc = vec![[0.3, 0.2, 0.1]; n];
    let (fallback_r, fallback_m) = (vec![0.6; n], vec![1.0; n]);
    let fitted = fit_pixels(
        &mask,
        side,
        |_| Vec::new(),
        &vec![0.0; n],
        Known::default(),
        Some(Fallback {
            basecolor: &fallback_bc,
            roughness: &fallback_r,
            metallic: &fallback_m,
        }),
        &FitOptions::default(),
    );
    assert!(fitted.basecolor.iter().all(|b| *b == [0.3, 0.2, 0.1]));
    assert!(fitted.roughness.iter().all(|&r| r == 0.6));
    assert_eq!(fitted.constrained, Constrained::default());
    assert!(fitted.materials.is_empty());
    assert_eq!(fitted.notes.len(), 1, "{:?}", fitted.notes);
}

/// The fit of the pixels of a glossy dielectric of `basecolor`, each seen
/// in one view far from its highlight, with the networks' roughness and
/// metallic as the fallback (basecolor black).
fn fit_one_view_away(basecolor: [f32; 3], roughness: &[f32], metallic: &[f32]) -> Fitted {
    let n = roughness.len();
    let truth = Params {
        basecolor,
        roughness: 0.1,
        metallic: 0.0,
    };
    let b = bsdf(&truth.to_x(), &Fixed::default());
    let observe = |_: usize| {
        let wo = Vec3::new(0.3f32.sin(), 0.0, 0.3f32.cos());
        let wi = Vec3::new(-(1.2f32).sin(), 0.0, 1.2f32.cos());
        vec![Sample::exact(Observation::rendered(&b, wo, wi, [1.0; 3]))]
    };
    fit_pixels(
        &vec![true; n],
        8,
        observe,
        &vec![0.0; n],
        Known::default(),
        Some(Fallback {
            basecolor: &vec![[0.0; 3]; n],
            roughness,
            metallic,
        }),
        &FitOptions::default(),
    )
}

#[test]
fn a_material_seen_from_one_angle_only_leaves_roughness_to_the_fallback() {
    // Every pixel sees the same single view away from the highlight: any
    // roughness explains it with its own basecolor, so the cost over
    // roughness is flat.
    let n = 64;
    let fallback_r = vec![0.33; n];
    let fitted = fit_one_view_away([0.5; 3], &fallback_r, &vec![0.0; n]);
    assert_eq!(fitted.materials.len(), 1, "{:?}", fitted.materials);
    assert!(
        !fitted.materials[0].roughness_pinned,
        "{:?}",
        fitted.materials
    );
    assert!(fitted.roughness.iter().all(|&r| r == 0.33));
    assert_eq!(fitted.constrained.roughness, 0.0);
}

/// [`fit_one_view_away`] of 64 pixels under the networks' roughness 0.5
/// and a metallic map alternating 0.9 and 0.1 (returned beside the fit).
fn fit_open_under_networks_map(basecolor: [f32; 3]) -> (Fitted, Vec<f32>) {
    let n = 64;
    let network_metallic: Vec<f32> = (0..n).map(|i| if i % 3 == 0 { 0.9 } else { 0.1 }).collect();
    let fitted = fit_one_view_away(basecolor, &vec![0.5; n], &network_metallic);
    (fitted, network_metallic)
}

#[test]
fn a_material_whose_metallic_the_photos_leave_open_keeps_the_networks_per_pixel_map() {
    // A black surface seen away from its highlight: metal and dielectric
    // both explain it with basecolor 0, so metallic is not pinned, and the
    // networks' answer stays pixel by pixel (metal and dielectric may
    // alternate within one colour), not one call from its median.
    let (fitted, network_metallic) = fit_open_under_networks_map([0.0; 3]);
    assert_eq!(fitted.materials.len(), 1, "{:?}", fitted.materials);
    assert!(
        !fitted.materials[0].metallic_pinned,
        "{:?}",
        fitted.materials
    );
    assert_eq!(fitted.metallic, network_metallic);
    assert_eq!(fitted.constrained.metallic, 0.0);
}

/// Gold, metal left of column `boundary` and dielectric right of it: a
/// metallic map of its own under one colour.
fn gold_metal_left_of(i: usize, side: usize, boundary: usize) -> Params {
    Params {
        metallic: if i % side < boundary { 1.0 } else { 0.0 },
        ..GOLD
    }
}

/// The dome's pixels of a `side`-wide image, and their count with the
/// background.
fn dome_mask(side: usize) -> (Vec<bool>, usize) {
    let n = side * side;
    ((0..n).map(|i| normal(i, side).is_some()).collect(), n)
}

/// The dome photographed under `truth`, fitted as one given material with
/// networks that answer 0.5 everywhere.
fn fit_one_material(
    side: usize,
    truth: &(dyn Fn(usize) -> Params + Sync),
    options: &FitOptions,
) -> Fitted {
    let (mask, n) = dome_mask(side);
    let labels: Vec<Option<usize>> = mask.iter().map(|&m| m.then_some(0)).collect();
    fit_pixels(
        &mask,
        side,
        |i| observe(i, side, truth),
        &vec![0.0; n],
        Known {
            labels: Some(&labels),
            ..Known::default()
        },
        Some(Fallback {
            basecolor: &vec![[0.5; 3]; n],
            roughness: &vec![0.5; n],
            metallic: &vec![0.5; n],
        }),
        options,
    )
}

#[test]
fn where_a_material_leaves_metallic_open_each_neighbourhood_calls_its_own() {
    // One material (given) of gold's colour, metal on the left half of
    // the dome and dielectric on the right: metallic as a map of its own,
    // not the colour's. A material contrast no sum can meet leaves its
    // call open, and the networks say 0.5 everywhere.
    let side = 48;
    let truth = |i: usize| gold_metal_left_of(i, side, side / 2);
    let (mask, n) = dome_mask(side);
    let fit = |neighbourhood: Option<NeighbourhoodOptions>| {
        fit_one_material(
            side,
            &truth,
            &FitOptions {
                metallic_contrast: 1e6,
                neighbourhood,
                ..FitOptions::default()
            },
        )
    };
    let fitted = fit(Some(NeighbourhoodOptions::default()));
    assert!(!fitted.materials[0].metallic_pinned);
    // Pixels whose 5 x 5 window lies inside one half.
    let interior: Vec<usize> = (0..n)
        .filter(|&i| mask[i] && (i % side + 2 < side / 2 || i % side >= side / 2 + 2))
        .collect();
    let called: Vec<usize> = interior
        .iter()
        .copied()
        .filter(|&i| fitted.metallic[i] != 0.5)
        .collect();
    let right = called
        .iter()
        .filter(|&&i| fitted.metallic[i] == truth(i).metallic)
        .count();
    assert!(
        called.len() as f64 > 0.9 * interior.len() as f64,
        "{} of {} interior pixels called",
        called.len(),
        interior.len()
    );
    assert_eq!(
        right,
        called.len(),
        "{right} of {} calls right",
        called.len()
    );
    let counted = fitted.materials[0].neighbourhood_pixels.unwrap_or(0);
    assert!(counted >= called.len(), "{counted}");
    let object = mask.iter().filter(|&&m| m).count() as f32;
    assert!((fitted.constrained.metallic - counted as f32 / object).abs() < 1e-6);

    // Without the neighbourhood every pixel keeps the networks' 0.5.
    let open = fit(None);
    assert!((0..n).filter(|&i| mask[i]).all(|i| open.metallic[i] == 0.5));
    assert_eq!(open.materials[0].neighbourhood_pixels, None);
}

#[test]
fn a_pinned_material_whose_neighbourhoods_contradict_it_keeps_metallic_per_pixel() {
    // One material (given) of gold's colour, metal on the left two thirds
    // of the dome and dielectric on the right third: its whole sum pins
    // one call, which is wrong on a third of it. A uniform gold metal
    // beside it stays one call.
    let side = 48;
    let (mask, n) = dome_mask(side);
    let options = FitOptions {
        metallic_contrast: 0.01,
        neighbourhood: Some(NeighbourhoodOptions::default()),
        ..FitOptions::default()
    };
    let fit = |truth: &(dyn Fn(usize) -> Params + Sync)| fit_one_material(side, truth, &options);
    let mixed = fit(&|i| gold_metal_left_of(i, side, 2 * side / 3));
    let m = &mixed.materials[0];
    assert!(m.metallic_pinned, "{m:?}");
    assert!(m.metallic_mixed, "{m:?}");
    let share = m
        .contrary_calls
        .expect("a pinned material's calls are read");
    assert!((0.25..=1.0).contains(&share), "{share}");
    // Interior pixels (whose 5 x 5 window lies on one side) that were
    // called are called right, and most of each side is called.
    let boundary = 2 * side / 3;
    let interior = |i: usize| mask[i] && (i % side + 2 < boundary || i % side >= boundary + 2);
    for (side_of, want) in [(true, 1.0f32), (false, 0.0)] {
        let pixels: Vec<usize> = (0..n)
            .filter(|&i| interior(i) && ((i % side) < boundary) == side_of)
            .collect();
        let right = pixels
            .iter()
            .filter(|&&i| mixed.metallic[i] == want)
            .count();
        let wrong = pixels
            .iter()
            .filter(|&&i| mixed.metallic[i] == 1.0 - want)
            .count();
        assert_eq!(wrong, 0, "{wrong} interior pixels called {}", 1.0 - want);
        assert!(
            right as f64 > 0.8 * pixels.len() as f64,
            "{right} of {} called {want}",
            pixels.len()
        );
    }
    // Uncalled pixels of a mixed material keep the networks' 0.5, and
    // only the called ones count as constrained.
    let called = mixed
        .metallic
        .iter()
        .zip(&mask)
        .filter(|(&v, &k)| k && v != 0.5)
        .count();
    assert_eq!(m.neighbourhood_pixels, Some(called));
    let object = mask.iter().filter(|&&k| k).count() as f32;
    assert!((mixed.constrained.metallic - called as f32 / object).abs() < 1e-6);

    let uniform = fit(&|_| GOLD);
    let m = &uniform.materials[0];
    assert!(m.metallic_pinned && !m.metallic_mixed, "{m:?}");
    assert!(m.contrary_calls.is_some_and(|s| s < 0.05), "{m:?}");
    assert!((0..n)
        .filter(|&i| mask[i])
        .all(|i| uniform.metallic[i] == 1.0));
    assert_eq!(uniform.constrained.metallic, 1.0);
}

#[test]
fn the_parabola_finds_a_minimum_between_grid_points() {
    let grid = roughness_grid();
    let target = 0.3f64.ln();
    let row: Vec<f64> = grid
        .iter()
        .map(|&r| (f64::from(r).ln() - target).powi(2))
        .collect();
    let k = argmin(&row).unwrap();
    let r = parabola_minimum(&row, &grid, k);
    assert!((r - 0.3).abs() < 1e-3, "{r}");
    assert_eq!(grid.first().copied(), Some(0.02));
    assert!((grid.last().copied().unwrap_or(0.0) - 1.0).abs() < 1e-6);
}

/// A summed cost volume (dielectric row, then metal row) whose rows fall
/// toward the grid's roughest lobe, the winning row by `margin`.
fn falling_rows(metal_wins: bool, margin: f64) -> Vec<f64> {
    let grid = roughness_grid();
    let row = |offset: f64| -> Vec<f64> {
        (0..grid.len())
            .map(|k| offset + 10.0 * (grid.len() - k) as f64)
            .collect()
    };
    let (dielectric, metal) = if metal_wins {
        (row(100.0 * margin), row(0.0))
    } else {
        (row(0.0), row(100.0 * margin))
    };
    [dielectric, metal].concat()
}

#[test]
fn at_the_roughest_lobe_a_dielectric_call_is_kept_and_a_metal_call_is_left_to_the_fallback() {
    let grid = roughness_grid();
    let members: Vec<usize> = (0..4).collect();
    let network_metal = [1.0f32; 4];
    let network_rough = [0.4f32; 4];
    let network_colour = [[0.5f32; 3]; 4];
    let fallback = Fallback {
        basecolor: &network_colour,
        roughness: &network_rough,
        metallic: &network_metal,
    };
    let options = FitOptions::default();
    let dielectric = choose(
        &falling_rows(false, 1.0),
        &grid,
        &members,
        Known::default(),
        Evidence::default(),
        Some(fallback),
        &options,
    );
    assert!(dielectric.metallic_pinned);
    assert_eq!(dielectric.metallic, 0.0);
    assert!(!dielectric.roughness_pinned);
    assert_eq!(dielectric.roughness, 0.4);
    let metal = choose(
        &falling_rows(true, 1.0),
        &grid,
        &members,
        Known::default(),
        Evidence::default(),
        Some(fallback),
        &options,
    );
    assert!(!metal.metallic_pinned);
    assert!(!metal.roughness_pinned);
    assert_eq!(metal.metallic, 1.0);
    let network_dielectric = [0.0f32; 4];
    let metal_against_a_dielectric_network = choose(
        &falling_rows(true, 1.0),
        &grid,
        &members,
        Known::default(),
        Evidence::default(),
        Some(Fallback {
            metallic: &network_dielectric,
            ..fallback
        }),
        &options,
    );
    assert_eq!(metal_against_a_dielectric_network.metallic, 0.0);
}

#[test]
fn a_surface_only_dielectric_at_the_roughest_lobe_pins_its_roughness_there() {
    let grid = roughness_grid();
    let members: Vec<usize> = (0..4).collect();
    let network_rough = [0.4f32; 4];
    let fallback = Fallback {
        basecolor: &[[0.5f32; 3]; 4],
        roughness: &network_rough,
        metallic: &[0.0f32; 4],
    };
    let surface = Evidence {
        dielectric: false,
        surface_only: true,
    };
    let options = FitOptions::default();
    // Costs still falling at the end: the roughest lobe itself.
    let rough = choose(
        &falling_rows(false, 1.0),
        &grid,
        &members,
        Known::default(),
        surface,
        Some(fallback),
        &options,
    );
    assert!(rough.roughness_pinned);
    assert_eq!(rough.roughness, 1.0);
    // Costs levelling off toward the end (least at roughness 0.905, past
    // the grid's last but one point): the parabola's minimum.
    let r = grid.len();
    let levelling: Vec<f64> = (0..r)
        .map(|k| 100.0 + 50.0 * (f64::from(grid[k]).ln() + 0.1).powi(2))
        .chain(std::iter::repeat_n(1e4, r))
        .collect();
    let levelled = choose(
        &levelling,
        &grid,
        &members,
        Known::default(),
        surface,
        Some(fallback),
        &options,
    );
    assert!(levelled.roughness_pinned);
    assert!(
        (levelled.roughness - 0.905).abs() < 0.002,
        "{}",
        levelled.roughness
    );
    // A flat row pins nothing, even for a surface.
    let flat = choose(
        &[vec![100.0; r], vec![200.0; r]].concat(),
        &grid,
        &members,
        Known::default(),
        surface,
        Some(fallback),
        &options,
    );
    assert!(!flat.roughness_pinned);
    assert_eq!(flat.roughness, 0.4);
}

#[test]
fn fit_light_names_round_trip_and_a_wrong_one_says_what_was_expected() {
    for light in FitLight::ALL {
        assert_eq!(light.name().parse::<FitLight>().ok(), Some(light));
    }
    assert_eq!(FitLight::default(), FitOptions::default().light);
    let e = "global".parse::<FitLight>().err().map(|e| e.to_string());
    assert_eq!(
        e.as_deref(),
        Some("unknown fit light \"global\": expected total, direct or material")
    );
}

#[test]
fn pinned_roughness_replaces_only_the_pixels_of_materials_that_pinned_it() {
    let material = |roughness: f32, pinned: bool| MaterialFit {
        pixels: 1,
        basecolor: [0.5; 3],
        roughness,
        metallic: 0.0,
        roughness_pinned: pinned,
        metallic_pinned: true,
        scattering: false,
        backlight: None,
        global_share: None,
        transmission: None,
        highlight: None,
        texture_kept: None,
        lobe_pixels: None,
        neighbourhood_pixels: None,
        contrary_calls: None,
        metallic_mixed: false,
        subsurface: None,
    };
    let fitted = Fitted {
        basecolor: vec![[0.5; 3]; 4],
        roughness: vec![0.2, 0.9, 0.2, f32::NAN],
        metallic: vec![0.0; 4],
        labels: vec![Some(0), Some(1), None, Some(0)],
        materials: vec![material(0.2, true), material(0.9, false)],
        constrained: Constrained {
            basecolor: 0.5,
            roughness: 0.5,
            metallic: 0.5,
            ..Constrained::default()
        },
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let mut roughness = vec![0.6f32; 4];
    fitted.pinned_roughness_into(&mut roughness);
    // Pinned; unpinned material; outside every material; pinned but NaN.
    assert_eq!(roughness, vec![0.2, 0.6, 0.6, 0.6]);
}

#[test]
fn given_materials_replace_the_split_and_keep_each_its_own_roughness() {
    // Two dielectrics of one colour differ only in their lobe: the split,
    // which reads colour, cannot tell them apart; given labels can.
    let side = 48;
    let glossy = Params {
        roughness: 0.1,
        ..RED_PLASTIC
    };
    let rough = Params {
        roughness: 0.6,
        ..RED_PLASTIC
    };
    let left = |i: usize| (i % side) < side / 2;
    let truth = |i: usize| if left(i) { glossy } else { rough };
    let mask: Vec<bool> = (0..side * side)
        .map(|i| normal(i, side).is_some())
        .collect();
    let labels: Vec<Option<usize>> = (0..side * side)
        .map(|i| mask[i].then_some(usize::from(!left(i))))
        .collect();
    let fitted = fit_pixels(
        &mask,
        side,
        |i| observe(i, side, &truth),
        &vec![0.0; side * side],
        Known {
            labels: Some(&labels),
            ..Known::default()
        },
        None,
        &FitOptions::default(),
    );
    assert_eq!(fitted.materials.len(), 2, "{:?}", fitted.materials);
    for (material, want) in fitted.materials.iter().zip([glossy, rough]) {
        let rel = (material.roughness - want.roughness).abs() / want.roughness;
        assert!(rel < 0.1, "{material:?} against {}", want.roughness);
        assert_eq!(material.metallic, 0.0);
    }
    assert!(fitted
        .labels
        .iter()
        .zip(&labels)
        .all(|(got, given)| got == given || got.is_none()));
}

#[test]
fn dielectric_basecolor_replaces_only_the_pixels_of_opaque_dielectric_materials() {
    let material = |metallic: f32, scattering: bool| MaterialFit {
        pixels: 1,
        basecolor: [0.5; 3],
        roughness: 0.3,
        metallic,
        roughness_pinned: true,
        metallic_pinned: true,
        scattering,
        backlight: None,
        global_share: None,
        transmission: None,
        highlight: None,
        texture_kept: None,
        lobe_pixels: None,
        neighbourhood_pixels: None,
        contrary_calls: None,
        metallic_mixed: false,
        subsurface: None,
    };
    let fitted = Fitted {
        basecolor: vec![
            [0.8, 0.2, 0.1],
            [0.3; 3],
            [0.9; 3],
            [f32::NAN; 3],
            [1.4, 0.2, 0.2],
            [0.6; 3],
        ],
        roughness: vec![0.3; 6],
        metallic: vec![0.0; 6],
        labels: vec![Some(0), Some(1), None, Some(0), Some(0), Some(2)],
        materials: vec![
            material(0.0, false),
            material(1.0, false),
            material(0.0, true),
        ],
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let mut basecolor = vec![[0.5f32; 3]; 6];
    let share = fitted.dielectric_basecolor_into(&mut basecolor);
    // Opaque dielectric; metal; outside every material; NaN; clamped;
    // scattering.
    assert_eq!(
        basecolor,
        vec![
            [0.8, 0.2, 0.1],
            [0.5; 3],
            [0.5; 3],
            [0.5; 3],
            [1.0, 0.2, 0.2],
            [0.5; 3]
        ]
    );
    assert_eq!(share, 0.4);
}

/// `observe`'s views of pixel `i` with `share` of each view's light global
/// (scattered inside): the total light is what the truth renders.
fn observe_scattering(
    i: usize,
    side: usize,
    truth: &dyn Fn(usize) -> Params,
    share: f32,
) -> Vec<Sample> {
    observe(i, side, truth)
        .into_iter()
        .map(|mut s| {
            s.global = s.observation.observed.map(|o| share * o);
            s
        })
        .collect()
}

#[test]
fn a_material_whose_light_is_largely_global_is_fitted_to_its_total_light() {
    let side = 40;
    let truth = |_: usize| Params {
        basecolor: [0.6, 0.45, 0.3],
        roughness: 0.5,
        metallic: 0.0,
    };
    let mask: Vec<bool> = (0..side * side)
        .map(|i| normal(i, side).is_some())
        .collect();
    let fit = |light: FitLight| {
        fit_pixels(
            &mask,
            side,
            |i| observe_scattering(i, side, &truth, 0.4),
            &vec![0.0; side * side],
            Known::default(),
            None,
            &FitOptions {
                light,
                ..FitOptions::default()
            },
        )
    };
    let mean_red = |f: &Fitted| {
        let object: Vec<usize> = (0..side * side).filter(|&i| mask[i]).collect();
        object.iter().map(|&i| f.basecolor[i][0]).sum::<f32>() / object.len() as f32
    };
    let direct = fit(FitLight::Direct);
    let material = fit(FitLight::Material);
    // The direct light alone reads the material 40 % darker; the material
    // rule measures its global share and fits the total light.
    assert!(mean_red(&direct) < 0.45, "{}", mean_red(&direct));
    assert!(
        (mean_red(&material) - 0.6).abs() < 0.05,
        "{}",
        mean_red(&material)
    );
    assert!(material
        .materials
        .iter()
        .all(|m| m.scattering && m.metallic == 0.0));
    assert!(direct.materials.iter().all(|m| !m.scattering));
}

#[test]
fn a_material_with_little_global_light_keeps_its_direct_light_under_the_material_rule() {
    let side = 40;
    let mask: Vec<bool> = (0..side * side)
        .map(|i| normal(i, side).is_some())
        .collect();
    let fitted = fit_pixels(
        &mask,
        side,
        |i| observe_scattering(i, side, &|_| RED_PLASTIC, 0.1),
        &vec![0.0; side * side],
        Known::default(),
        None,
        &FitOptions {
            light: FitLight::Material,
            ..FitOptions::default()
        },
    );
    assert!(fitted.materials.iter().all(|m| !m.scattering));
}

#[test]
fn degenerate_materials_and_views_give_finite_values_under_every_light_rule() {
    let side = 24;
    let n = side * side;
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let black_metal = |_: usize| Params {
        basecolor: [0.0; 3],
        roughness: 0.3,
        metallic: 1.0,
    };
    let mirror_metal = |_: usize| Params {
        basecolor: [0.9, 0.6, 0.3],
        roughness: 0.02,
        metallic: 1.0,
    };
    type Observe<'a> = Box<dyn Fn(usize) -> Vec<Sample> + Sync + 'a>;
    let cases: Vec<(&str, Observe)> = vec![
        ("black metal", Box::new(|i| observe(i, side, &black_metal))),
        (
            "a mirror metal whose highlights no view sees",
            Box::new(|i| {
                // Only the side lights, whose mirror directions miss the
                // camera on a dome seen from above.
                observe(i, side, &mirror_metal)
                    .into_iter()
                    .filter(|s| s.observation.wi.z < 0.95)
                    .map(|mut s| {
                        s.observation.observed = [0.0; 3];
                        s
                    })
                    .collect()
            }),
        ),
        (
            "saturated highlights",
            Box::new(|i| {
                observe(i, side, &|_| GOLD)
                    .into_iter()
                    .map(|mut s| {
                        s.clipped = [true; 3];
                        s.observation.observed = [0.05; 3];
                        s
                    })
                    .collect()
            }),
        ),
        (
            "one view",
            Box::new(|i| {
                observe(i, side, &|_| RED_PLASTIC)
                    .into_iter()
                    .take(1)
                    .collect()
            }),
        ),
        (
            "global light above the photo",
            Box::new(|i| observe_scattering(i, side, &|_| RED_PLASTIC, 3.0)),
        ),
        (
            "no light",
            Box::new(|i| {
                observe(i, side, &|_| RED_PLASTIC)
                    .into_iter()
                    .map(|mut s| {
                        s.observation.light = [0.0; 3];
                        s
                    })
                    .collect()
            }),
        ),
    ];
    // A one-pixel material among the given ones.
    let first = mask.iter().position(|&m| m).unwrap();
    let labels: Vec<Option<usize>> = (0..n)
        .map(|i| mask[i].then_some(usize::from(i == first)))
        .collect();
    for (what, observe_case) in &cases {
        for light in FitLight::ALL {
            for given in [None, Some(labels.as_slice())] {
                let fitted = fit_pixels(
                    &mask,
                    side,
                    observe_case,
                    &vec![0.0; n],
                    Known {
                        labels: given,
                        ..Known::default()
                    },
                    None,
                    &FitOptions {
                        light,
                        ..FitOptions::default()
                    },
                );
                let label = format!("{what}, {light} light, given labels {}", given.is_some());
                for i in (0..n).filter(|&i| mask[i]) {
                    assert!(
                        fitted.basecolor[i].iter().all(|v| v.is_finite()),
                        "{label}: basecolor {:?}",
                        fitted.basecolor[i]
                    );
                    assert!(
                        (0.02..=1.0).contains(&fitted.roughness[i]),
                        "{label}: roughness {}",
                        fitted.roughness[i]
                    );
                    assert!(
                        fitted.metallic[i] == 0.0 || fitted.metallic[i] == 1.0,
                        "{label}: metallic {}",
                        fitted.metallic[i]
                    );
                }
                let mut basecolor = vec![[0.5f32; 3]; n];
                let share = fitted.dielectric_basecolor_into(&mut basecolor);
                assert!((0.0..=1.0).contains(&share), "{label}: {share}");
                assert!(
                    basecolor.iter().flatten().all(|v| (0.0..=1.0).contains(v)),
                    "{label}"
                );
                let c = fitted.constrained;
                assert!(
                    [c.basecolor, c.roughness, c.metallic]
                        .iter()
                        .all(|s| (0.0..=1.0).contains(s)),
                    "{label}: {c:?}"
                );
            }
        }
    }
}

/// The backlight's reading: `share` of the panel's light seen through
/// every pixel.
fn through(n: usize, share: f32) -> backlight::Backlight {
    backlight::Backlight {
        share: vec![share; n],
        panel: [1.5; 3],
    }
}

/// Fits a `side` x `side` dome of `truth` under the caller's transmission
/// map `transmission`, the backlight showing `share` of the panel's light
/// through every pixel (unread when `None`).
fn fit_dome_through(side: usize, truth: Params, transmission: f32, share: Option<f32>) -> Fitted {
    let n = side * side;
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let b = share.map(|s| through(n, s));
    fit_pixels(
        &mask,
        side,
        |i| observe(i, side, &|_| truth),
        &vec![transmission; n],
        Known {
            backlight: b.as_ref(),
            ..Known::default()
        },
        None,
        &FitOptions::default(),
    )
}

#[test]
fn a_material_that_passes_backlight_is_fitted_as_a_dielectric() {
    // Gold's photos pin it as metal; light seen through it rules a metal
    // out, whatever its lobe looks like.
    let side = 32;
    let n = side * side;
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let fit = |share: Option<f32>| fit_dome_through(side, GOLD, 0.0, share);
    let unread = fit(None);
    assert!(unread
        .materials
        .iter()
        .all(|m| m.metallic == 1.0 && m.backlight.is_none()));
    let passing = fit(Some(0.1));
    assert!(!passing.materials.is_empty());
    for m in &passing.materials {
        assert_eq!(m.metallic, 0.0, "{m:?}");
        assert!(
            m.metallic_pinned && m.passes_light() && !m.blocks_light(),
            "{m:?}"
        );
        let reading = m.backlight.expect("read");
        assert!((reading.share - 0.1).abs() < 1e-6 && reading.pixels == m.pixels);
    }
    assert!(passing
        .metallic
        .iter()
        .zip(&mask)
        .all(|(&v, &m)| !m || v == 0.0));
    // A passing material's basecolor is left to the networks.
    let mut basecolor = vec![[0.25f32; 3]; n];
    assert_eq!(passing.dielectric_basecolor_into(&mut basecolor), 0.0);
    assert!(basecolor.iter().all(|b| *b == [0.25; 3]));
}

#[test]
fn a_dielectric_that_passes_no_backlight_is_fitted_without_transmission() {
    // The caller's map says half the light passes through; the backlight
    // shows none does. Fitted under the map the basecolor reads twice as
    // bright; under the backlight it comes back, and the blocked material's
    // transmission and subsurface are written 0.
    let side = 32;
    let n = side * side;
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let fit = |share: Option<f32>| fit_dome_through(side, RED_PLASTIC, 0.5, share);
    let object: Vec<usize> = (0..n).filter(|&i| mask[i]).collect();
    let close = |f: &Fitted| {
        object
            .iter()
            .filter(|&&i| {
                (0..3).all(|c| (f.basecolor[i][c] - RED_PLASTIC.basecolor[c]).abs() < 0.03)
            })
            .count()
    };
    let unread = fit(None);
    assert!(close(&unread) < object.len() / 10, "{}", close(&unread));
    let blocked = fit(Some(0.0));
    // Materials too small to be read (a few pixels at the rim) keep the
    // caller's transmission; the rest are blocked dielectrics.
    let read: Vec<&MaterialFit> = blocked
        .materials
        .iter()
        .filter(|m| m.backlight.is_some())
        .collect();
    assert!(read.iter().map(|m| m.pixels).sum::<usize>() > object.len() * 9 / 10);
    assert!(
        read.iter().all(|m| m.blocks_light() && m.metallic == 0.0),
        "{:?}",
        blocked.materials
    );
    assert!(
        close(&blocked) > object.len() * 95 / 100,
        "{} of {}",
        close(&blocked),
        object.len()
    );
    let mut transmission = vec![0.7f32; n];
    let share = blocked.measured_into(Param::Transmission, &mut transmission);
    assert!(share > 0.9, "{share}");
    let zeroed = object.iter().filter(|&&i| transmission[i] == 0.0).count();
    assert_eq!(zeroed as f32, (share * object.len() as f32).round());
    assert!((0..n).filter(|&i| !mask[i]).all(|i| transmission[i] == 0.7));
    // Unread, nothing is written.
    let mut untouched = vec![0.7f32; n];
    assert_eq!(
        unread.measured_into(Param::Transmission, &mut untouched),
        0.0
    );
    assert!(untouched.iter().all(|&v| v == 0.7));
}

#[test]
fn transmission_and_subsurface_are_absent_only_where_the_photos_show_it() {
    let material =
        |metallic: f32, passage: Option<backlight::Passage>, global: Option<f32>| MaterialFit {
            pixels: 2,
            basecolor: [0.5; 3],
            roughness: 0.3,
            metallic,
            roughness_pinned: true,
            metallic_pinned: true,
            scattering: global.is_some_and(|g| f64::from(g) >= SCATTERING_SHARE),
            backlight: passage.map(|passage| backlight::MaterialBacklight {
                share: 0.0,
                high: 0.0,
                pixels: 2,
                passage,
            }),
            global_share: global,
            transmission: None,
            highlight: None,
            texture_kept: None,
            lobe_pixels: None,
            neighbourhood_pixels: None,
            contrary_calls: None,
            metallic_mixed: false,
            subsurface: None,
        };
    use backlight::Passage::{Blocked, Partly, Passes};
    // A blocked metal (both hidden in it); a blocked dielectric (neither);
    // a dielectric passing light with little global light (its measured
    // transmission, no subsurface); one passing light that scatters it inside
    // (both unknown); one partly passing, unseparated (both unknown).
    let mut materials = vec![
        material(1.0, Some(Blocked), Some(0.0)),
        material(0.0, Some(Blocked), Some(0.5)),
        material(0.0, Some(Passes), Some(0.05)),
        material(0.0, Some(Passes), Some(0.8)),
        material(0.0, Some(Partly), None),
    ];
    // The clear material's transmission, measured through it.
    materials[2].transmission = Some(0.3);
    let labels: Vec<Option<usize>> = (0..10).map(|i| Some(i / 2)).collect();
    let fitted = Fitted {
        basecolor: vec![[0.5; 3]; 10],
        roughness: vec![0.3; 10],
        metallic: vec![0.0; 10],
        labels,
        materials,
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let mut transmission = vec![0.4f32; 10];
    assert_eq!(
        fitted.measured_into(Param::Transmission, &mut transmission),
        0.4
    );
    assert_eq!(
        transmission,
        vec![0.4, 0.4, 0.0, 0.0, 0.3, 0.3, 0.4, 0.4, 0.4, 0.4]
    );
    let mut subsurface = vec![0.4f32; 10];
    assert_eq!(
        fitted.measured_into(Param::Subsurface, &mut subsurface),
        0.4
    );
    assert_eq!(
        subsurface,
        vec![0.4, 0.4, 0.0, 0.0, 0.0, 0.0, 0.4, 0.4, 0.4, 0.4]
    );
    let mut roughness = vec![0.4f32; 10];
    assert_eq!(fitted.measured_into(Param::Roughness, &mut roughness), 0.0);
}

#[test]
fn a_clear_material_that_passes_backlight_gets_its_transmission_and_basecolor_measured() {
    // A dielectric with transmission 0.6: the flashes see (1 - t) of its
    // basecolor, the backlight (1 - F0)^2 (t b)^2 of the panel. The
    // networks' map says 0; its light is 5 % global (no scattering inside).
    let side = 32;
    let n = side * side;
    let (t, basecolor) = (0.6f32, [0.7f32, 0.5, 0.3]);
    let truth = Params {
        basecolor,
        roughness: 0.3,
        metallic: 0.0,
    };
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let b = bsdf(&truth.to_x(), &Fixed { transmission: t });
    let observe = |i: usize| -> Vec<Sample> {
        let Some(nrm) = normal(i, side) else {
            return Vec::new();
        };
        lights()
            .iter()
            .filter_map(|&l| {
                let (wo, wi) = (local(nrm, Vec3::Z), local(nrm, l));
                if wo.z <= 0.05 || wi.z <= 0.05 {
                    return None;
                }
                let mut s = Sample::exact(Observation::rendered(&b, wo, wi, [1.5; 3]));
                s.global = s.observation.observed.map(|o| 0.05 * o);
                Some(s)
            })
            .collect()
    };
    let passed = 1.0 - matscan_bsdf::fresnel_dielectric_cos(1.0, matscan_bsdf::material::IOR);
    let luma = matscan_calib::photos::luma(basecolor);
    let through = through(n, (passed * t * luma).powi(2));
    let fitted = fit_pixels(
        &mask,
        side,
        observe,
        &vec![0.0; n],
        Known {
            backlight: Some(&through),
            ..Known::default()
        },
        None,
        &FitOptions::default(),
    );
    let object: Vec<usize> = (0..n).filter(|&i| mask[i]).collect();
    let measured: usize = fitted
        .materials
        .iter()
        .filter(|m| m.transmission.is_some_and(|v| (v - t).abs() < 0.05))
        .map(|m| m.pixels)
        .sum();
    assert!(measured > object.len() * 9 / 10, "{:?}", fitted.materials);
    assert!(fitted
        .materials
        .iter()
        .all(|m| m.metallic == 0.0 && !m.scattering));
    let mut map = vec![0.0f32; n];
    let share = fitted.measured_into(Param::Transmission, &mut map);
    assert!(share > 0.9, "{share}");
    assert!(
        object
            .iter()
            .filter(|&&i| (map[i] - t).abs() < 0.05)
            .count()
            > object.len() * 9 / 10
    );
    // Its basecolor is the albedo over (1 - t), and fit-dielectric takes it.
    let close = object
        .iter()
        .filter(|&&i| (0..3).all(|c| (fitted.basecolor[i][c] - basecolor[c]).abs() < 0.06))
        .count();
    assert!(close > object.len() * 9 / 10, "{close} of {}", object.len());
    let mut written = vec![[0.0f32; 3]; n];
    assert!(fitted.dielectric_basecolor_into(&mut written) > 0.9);
}

/// A pinned metal of a few pixels whose highlights said `highlight`.
fn pinned_metal(highlight: Option<HighlightColour>) -> MaterialFit {
    MaterialFit {
        pixels: 2,
        basecolor: [0.3; 3],
        roughness: 0.3,
        metallic: 1.0,
        roughness_pinned: true,
        metallic_pinned: true,
        scattering: false,
        backlight: None,
        global_share: Some(0.0),
        transmission: None,
        highlight,
        texture_kept: None,
        lobe_pixels: None,
        neighbourhood_pixels: None,
        contrary_calls: None,
        metallic_mixed: false,
        subsurface: None,
    }
}

#[test]
fn a_metals_measured_highlight_colour_becomes_its_mean_with_the_texture_both_readings_show() {
    let materials = vec![
        pinned_metal(Some(HighlightColour::Measured {
            colour: [0.8, 0.4, 0.0],
            observations: 40,
            clipped: 0.0,
        })),
        pinned_metal(Some(HighlightColour::Blind {
            reason: "no highlight".into(),
        })),
        pinned_metal(None),
    ];
    // Material 0's pixels: the fit's own answers and the networks' agree
    // that pixel 1 is twice as bright as pixel 0 in red and green; in
    // blue the networks read black, which holds no texture.
    let mut fitted = Fitted {
        basecolor: vec![
            [0.1, 0.1, 0.2],
            [0.2, 0.2, 0.2],
            [0.3; 3],
            [0.3; 3],
            [0.3; 3],
            [0.3; 3],
        ],
        roughness: vec![0.3; 6],
        metallic: vec![1.0; 6],
        labels: vec![Some(0), Some(0), Some(1), Some(1), Some(2), None],
        materials,
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let mut basecolor = vec![
        [0.2, 0.2, 0.0],
        [0.4, 0.4, 0.0],
        [0.4; 3],
        [0.6; 3],
        [0.5; 3],
        [0.5; 3],
    ];
    assert_eq!(fitted.basecolor_texture_into(&mut basecolor), 1.0);
    let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(
        close(basecolor[0], [0.8 * 2.0 / 3.0, 0.4 * 2.0 / 3.0, 0.0]),
        "{:?}",
        basecolor[0]
    );
    // Scaled past 1 it is clamped.
    assert!(
        close(basecolor[1], [1.0, 0.4 * 4.0 / 3.0, 0.0]),
        "{:?}",
        basecolor[1]
    );
    // The pinned metals whose highlights gave no colour keep the networks'
    // mean; the texture only the networks read is left out.
    assert!(
        basecolor[2..4]
            .iter()
            .all(|b| b.iter().all(|v| (v - 0.5).abs() < 1e-6)),
        "{basecolor:?}"
    );
    assert_eq!(basecolor[4..], [[0.5; 3]; 2]);
    assert_eq!(fitted.materials[0].texture_kept, Some([1.0, 1.0, 0.0]));
    assert_eq!(fitted.materials[1].texture_kept, Some([0.0; 3]));
    assert_eq!(fitted.materials[2].texture_kept, Some([0.0; 3]));
}

#[test]
fn a_material_the_networks_answer_keeps_their_mean_with_the_agreed_texture_and_an_open_one_is_untouched(
) {
    // Material 0: a scattering dielectric whose metallic the photos
    // pinned; its two readings disagree on the texture. Material 1: the
    // same with its metallic open (a per-pixel map). Material 2: an
    // opaque dielectric, whose basecolor is the fit's own.
    let dielectric = |pinned: bool, scattering: bool| MaterialFit {
        metallic: 0.0,
        metallic_pinned: pinned,
        scattering,
        highlight: None,
        ..pinned_metal(None)
    };
    let mut fitted = Fitted {
        basecolor: vec![[0.2; 3], [0.4; 3], [0.2; 3], [0.4; 3], [0.3; 3], [0.35; 3]],
        roughness: vec![0.3; 6],
        metallic: vec![0.0; 6],
        labels: vec![Some(0), Some(0), Some(1), Some(1), Some(2), Some(2)],
        materials: vec![
            dielectric(true, true),
            dielectric(false, true),
            dielectric(true, false),
        ],
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let networks = vec![[0.6; 3], [0.4; 3], [0.6; 3], [0.4; 3], [0.7; 3], [0.5; 3]];
    let mut basecolor = networks.clone();
    // Only material 0's pixels are written.
    assert_eq!(fitted.basecolor_texture_into(&mut basecolor), 2.0 / 6.0);
    for b in &basecolor[..2] {
        assert!(b.iter().all(|v| (v - 0.5).abs() < 1e-6), "{b:?}");
    }
    assert_eq!(basecolor[2..], networks[2..]);
    assert_eq!(fitted.materials[0].texture_kept, Some([0.0; 3]));
    assert_eq!(fitted.materials[1].texture_kept, None);
    assert_eq!(fitted.materials[2].texture_kept, None);
}

#[test]
fn a_metals_texture_the_readings_partly_agree_on_is_kept_by_their_agreement() {
    let mut fitted = Fitted {
        // The fit's own reading: -1/3 and +1/3 about its mean; a third
        // pixel at the mean whose networks' value is not finite.
        basecolor: vec![[0.1; 3], [0.2; 3], [0.15; 3]],
        roughness: vec![0.3; 3],
        metallic: vec![1.0; 3],
        labels: vec![Some(0); 3],
        materials: vec![pinned_metal(Some(HighlightColour::Measured {
            colour: [0.6; 3],
            observations: 40,
            clipped: 0.0,
        }))],
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    // The networks': -1/6 and +1/6. The deviations' summed products, 1/9,
    // over the mean deviation's summed squares, 1/8: 8/9 of the mean
    // deviation (-1/4, +1/4) kept.
    let mut basecolor = vec![[0.25; 3], [0.35; 3], [f32::NAN; 3]];
    assert_eq!(fitted.basecolor_texture_into(&mut basecolor), 1.0);
    let expected = [0.6 * 7.0 / 9.0, 0.6 * 11.0 / 9.0, 0.6];
    for (b, e) in basecolor.iter().zip(expected) {
        assert!(b.iter().all(|v| (v - e).abs() < 1e-5), "{b:?} against {e}");
    }
    let kept = fitted.materials[0].texture_kept.expect("a measured metal");
    assert!(
        kept.iter().all(|k| (k - 8.0 / 9.0).abs() < 1e-5),
        "{kept:?}"
    );
}

#[test]
fn a_metals_texture_the_two_readings_disagree_on_is_left_out() {
    let material = pinned_metal(Some(HighlightColour::Measured {
        colour: [0.6, 0.5, 0.4],
        observations: 40,
        clipped: 0.0,
    }));
    // The fit's own answers darken the pixels its lobe's tail covers (0
    // and 1); the networks' vary the other way: neither is the metal's.
    let mut fitted = Fitted {
        basecolor: vec![[0.2; 3], [0.3; 3], [0.6; 3], [0.7; 3]],
        roughness: vec![0.3; 4],
        metallic: vec![1.0; 4],
        labels: vec![Some(0); 4],
        materials: vec![material],
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let mut basecolor = vec![[0.7; 3], [0.6; 3], [0.3; 3], [0.2; 3]];
    assert_eq!(fitted.basecolor_texture_into(&mut basecolor), 1.0);
    for b in &basecolor {
        assert!(
            b.iter()
                .zip([0.6, 0.5, 0.4])
                .all(|(x, y)| (x - y).abs() < 1e-6),
            "{b:?}"
        );
    }
    assert_eq!(fitted.materials[0].texture_kept, Some([0.0; 3]));
}

#[test]
fn an_uncalled_pixels_basecolor_is_read_at_its_materials_metallic_not_the_networks() {
    // A grey surface seen from one angle away from its highlight leaves
    // metallic open, and no window calls it: the networks' fractional
    // metallic stays each pixel's answer, but its basecolor is read at
    // the material's metallic (the networks' majority, rounded: a
    // dielectric), so it does not follow that guess and stays near the
    // truth (read at the networks' roughness 0.5, not the truth's 0.1).
    let (fitted, network_metallic) = fit_open_under_networks_map([0.5; 3]);
    assert_eq!(fitted.materials.len(), 1, "{:?}", fitted.materials);
    let material = &fitted.materials[0];
    assert!(!material.metallic_pinned, "{material:?}");
    assert_eq!(fitted.metallic, network_metallic);
    let first = fitted.basecolor[0];
    assert!(first.iter().all(|c| (c - 0.5).abs() < 0.1), "{first:?}");
    assert!(
        fitted.basecolor.iter().all(|b| *b == first),
        "{:?}",
        &fitted.basecolor[..4]
    );
}

#[test]
fn a_material_that_passes_light_reads_its_roughness_from_its_highlights() {
    // A clear glossy dielectric: the backlight shows light through it,
    // and its direct light also holds light refracted through the object
    // (a checker seen through clear material keeps its sharp edges),
    // which no surface model renders: here a broad glow over every view.
    // Summed over every view that glow widens the lobe (there it pins
    // roughness 0.86); the views near the mirror direction still show the
    // surface's own.
    let side = 48;
    let n = side * side;
    let mask: Vec<bool> = (0..n).map(|i| normal(i, side).is_some()).collect();
    let truth = Params {
        basecolor: [0.3, 0.5, 0.6],
        roughness: 0.2,
        metallic: 0.0,
    };
    let transmission = 0.85;
    let surface = bsdf(&truth.to_x(), &Fixed { transmission });
    let glow = Params {
        basecolor: [0.0; 3],
        roughness: 1.0,
        metallic: 0.0,
    };
    let glow = bsdf(&glow.to_x(), &Fixed::default());
    let observe_clear = |i: usize| -> Vec<Sample> {
        let Some(nrm) = normal(i, side) else {
            return Vec::new();
        };
        lights()
            .iter()
            .filter_map(|&l| {
                let (wo, wi) = (local(nrm, Vec3::Z), local(nrm, l));
                if wo.z <= 0.05 || wi.z <= 0.05 {
                    return None;
                }
                let mut o = Observation::rendered(&surface, wo, wi, [1.5; 3]);
                let extra = Observation::rendered(&glow, wo, wi, [1.5; 3]);
                for (v, e) in o.observed.iter_mut().zip(extra.observed) {
                    *v += 6.0 * e;
                }
                // The checkers separated a little global light: the
                // glow itself kept its edges and counts as direct.
                let mut sample = Sample::exact(o);
                sample.global = o.observed.map(|v| 0.02 * v);
                Some(sample)
            })
            .collect()
    };
    let labels: Vec<Option<usize>> = mask.iter().map(|&m| m.then_some(0)).collect();
    let backlight = through(n, 0.3);
    let fitted = fit_pixels(
        &mask,
        side,
        observe_clear,
        &vec![transmission; n],
        Known {
            backlight: Some(&backlight),
            labels: Some(&labels),
            ..Known::default()
        },
        None,
        &FitOptions::default(),
    );
    assert_eq!(fitted.materials.len(), 1, "{:?}", fitted.materials);
    let m = &fitted.materials[0];
    assert!(m.passes_light() && m.metallic == 0.0, "{m:?}");
    assert!(m.roughness_pinned && m.lobe_pixels.is_some(), "{m:?}");
    assert!((m.roughness - truth.roughness).abs() < 0.05, "{m:?}");
}
