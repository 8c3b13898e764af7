//! The fit on synthetic pixels: a dome of normals seen by one camera under
//! five point lights, photos predicted by the model itself.

use super::linear::Sample;
use super::*;
use crate::refine::model::{bsdf, Observation, Params};
use glam::Vec3;

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

#[test]
fn a_material_seen_from_one_angle_only_leaves_roughness_to_the_fallback() {
    // Every pixel sees the same single view away from the highlight: any
    // roughness explains it with its own basecolor, so the cost over
    // roughness is flat.
    let n = 64;
    let mask = vec![true; n];
    let truth = Params {
        basecolor: [0.5, 0.5, 0.5],
        roughness: 0.1,
        metallic: 0.0,
    };
    let b = bsdf(&truth.to_x(), &Fixed::default());
    let observe = |_: usize| -> Vec<Sample> {
        let wo = Vec3::new(0.3f32.sin(), 0.0, 0.3f32.cos());
        let wi = Vec3::new(-(1.2f32).sin(), 0.0, 1.2f32.cos());
        vec![Sample::exact(Observation::rendered(&b, wo, wi, [1.0; 3]))]
    };
    let fallback_r = vec![0.33; n];
    let fitted = fit_pixels(
        &mask,
        8,
        observe,
        &vec![0.0; n],
        Known::default(),
        Some(Fallback {
            basecolor: &vec![[0.0; 3]; n],
            roughness: &fallback_r,
            metallic: &vec![0.0; n],
        }),
        &FitOptions::default(),
    );
    assert_eq!(fitted.materials.len(), 1, "{:?}", fitted.materials);
    assert!(
        !fitted.materials[0].roughness_pinned,
        "{:?}",
        fitted.materials
    );
    assert!(fitted.roughness.iter().all(|&r| r == 0.33));
    assert_eq!(fitted.constrained.roughness, 0.0);
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
        Some(Fallback {
            metallic: &network_dielectric,
            ..fallback
        }),
        &options,
    );
    assert_eq!(metal_against_a_dielectric_network.metallic, 0.0);
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
        Some("unknown fit light \"global\": expected total or direct")
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
        },
        notes: Vec::new(),
        seconds: 0.0,
    };
    let mut roughness = vec![0.6f32; 4];
    fitted.pinned_roughness_into(&mut roughness);
    // Pinned; unpinned material; outside every material; pinned but NaN.
    assert_eq!(roughness, vec![0.2, 0.6, 0.6, 0.6]);
}
