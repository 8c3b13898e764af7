//! The renderer draws where the contract's camera model projects, and its
//! images are a deterministic function of the seed.

use crate::common;

use common::*;
use glam::{DVec2, DVec3, Vec3};
use matscan_scan::PinholeCamera;
use matscan_sim::render::{CaptureSpec, RenderOptions, Renderer};
use matscan_sim::scene::EnvSource;

/// Tiny camera-facing squares centred on points that project to the given
/// pixels' centres; returns the scene and the camera.
fn tiny_targets(
    distortion: [f64; 5],
    pixels: &[(u32, u32)],
) -> (matscan_sim::scene::Scene, PinholeCamera) {
    let mut k = intrinsics(48, 1.05, distortion);
    k.height = 40;
    k.fy = 52.0;
    k.cx = 23.3;
    k.cy = 18.7;
    let eye = DVec3::new(0.2, 0.1, -2.0);
    let pos = position(
        eye,
        vec![flash("flash0", Vec3::new(0.2, 0.1, -2.0), 4.0)],
        projector(DVec3::new(0.5, 0.0, -2.0), 64, 64.0, 1.0),
        no_panel(),
    );
    let camera = PinholeCamera::new(k, pos.camera_to_world);
    let quads: Vec<_> = pixels
        .iter()
        .map(|&(i, j)| {
            let ray = camera.ray(DVec2::new(i as f64 + 0.5, j as f64 + 0.5));
            let p = ray.at(2.0);
            let toward = -ray.dir;
            let u = toward.cross(Vec3::Y).normalize() * 0.008;
            let v = toward.cross(u).normalize() * 0.008;
            quad(p, u, v, toward)
        })
        .collect();
    let scene = scene(merge(&quads), &diffuse(0.8), no_env(), k, vec![pos]);
    (scene, camera)
}

fn assert_drawn_exactly_at(distortion: [f64; 5]) {
    let pixels = [(0, 0), (47, 39), (5, 33), (24, 19), (40, 3)];
    let (scene, camera) = tiny_targets(distortion, &pixels);
    // The manifest's projection of each target lands in its pixel.
    for &(i, j) in &pixels {
        let ray = camera.ray(DVec2::new(i as f64 + 0.5, j as f64 + 0.5));
        let px = camera.project(ray.at(2.0).as_dvec3()).unwrap();
        assert_eq!((px.x.floor() as u32, px.y.floor() as u32), (i, j));
    }
    let renderer = Renderer::new(&scene).unwrap();
    let truth = renderer.render_truth(0).unwrap();
    let opts = RenderOptions {
        samples: 16,
        seed: 1,
        max_depth: 2,
        ..RenderOptions::default()
    };
    let photo = &renderer
        .render_position(0, &[CaptureSpec::new("flash0", &["flash0"], None)], &opts)
        .unwrap()
        .photos[0];
    for y in 0..40 {
        for x in 0..48 {
            let target = pixels.contains(&(x, y));
            assert_eq!(*truth.mask.get(x, y), target, "mask at ({x}, {y})");
            let lit = photo.get(x, y).iter().any(|&v| v > 0.0);
            if !target {
                assert!(!lit, "photo lit off target at ({x}, {y})");
            }
        }
    }
    // A target smaller than its pixel is hit by some jittered samples.
    assert!(pixels
        .iter()
        .any(|&(x, y)| photo.get(x, y).iter().any(|&v| v > 0.0)));
}

#[test]
fn targets_appear_exactly_at_their_projected_pixels() {
    assert_drawn_exactly_at([0.0; 5]);
}

#[test]
fn targets_appear_exactly_at_their_projected_pixels_with_distortion() {
    assert_drawn_exactly_at([-0.25, 0.08, 0.002, -0.003, 0.01]);
}

fn sphere_scene(env_seed: u64) -> matscan_sim::scene::Scene {
    let mut s = scene(
        sphere(Vec3::ZERO, 0.5, 16, 32),
        &diffuse(0.7),
        no_env(),
        intrinsics(24, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.5),
            vec![flash("flash0", Vec3::new(0.4, 0.3, -2.0), 3.0)],
            projector(DVec3::new(-0.4, 0.0, -2.0), 64, 64.0, 2.0),
            panel_at(Vec3::new(0.0, 0.0, 1.0), 1.2, 1.5),
        )],
    );
    s.environment.source = EnvSource::Procedural { seed: env_seed };
    s
}

fn render(scene: &matscan_sim::scene::Scene, seed: u64, threads: usize) -> Vec<[f32; 3]> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let captures = [
        CaptureSpec::new("ambient", &[], None),
        CaptureSpec::new("flash0", &["flash0"], None),
        CaptureSpec::new("checker", &["projector"], Some(checker(8.0))),
        CaptureSpec::new("backlight", &["backlight"], None),
    ];
    let opts = RenderOptions {
        samples: 3,
        seed,
        max_depth: 5,
        ..RenderOptions::default()
    };
    let renderer = Renderer::new(scene).unwrap();
    let images = pool
        .install(|| renderer.render_position(0, &captures, &opts))
        .unwrap();
    images.photos.iter().flat_map(|p| p.data.clone()).collect()
}

#[test]
fn same_seed_gives_bit_identical_images_on_any_thread_count() {
    let scene = sphere_scene(4);
    let a = render(&scene, 9, 1);
    let b = render(&scene, 9, 2);
    let c = render(&scene, 9, 3);
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert!(a.iter().flatten().any(|&v| v > 0.0));
}

#[test]
fn another_seed_gives_another_noise() {
    let scene = sphere_scene(4);
    assert_ne!(render(&scene, 9, 2), render(&scene, 10, 2));
}
