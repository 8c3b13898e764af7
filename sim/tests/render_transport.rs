//! Light transport against closed forms: direct light of a point flash,
//! the white furnace, shadows, and the projector's pattern where the
//! contract says it lands.

use crate::common;

use common::*;
use glam::{DVec2, DVec3, Vec3};
use matscan_scan::PinholeCamera;
use matscan_sim::render::{CaptureSpec, Environment, ObjectMaterial, RenderOptions, Renderer};
use std::f32::consts::PI;

/// World point where the ray through pixel coordinates `px` meets z = 0.
fn on_plane_z0(camera: &PinholeCamera, px: DVec2) -> Vec3 {
    let ray = camera.ray(px);
    ray.at(-ray.origin.z / ray.dir.z)
}

#[test]
fn white_plane_under_a_flash_has_the_closed_form_radiance() {
    let light = Vec3::new(0.3, 0.2, -1.5);
    let intensity = 5.0;
    let s = scene(
        quad(Vec3::ZERO, Vec3::X * 3.0, Vec3::Y * 3.0, -Vec3::Z),
        &diffuse(1.0),
        no_env(),
        intrinsics(32, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![flash("flash0", light, intensity)],
            projector(DVec3::new(0.5, 0.0, -2.0), 64, 64.0, 1.0),
            no_panel(),
        )],
    );
    let renderer = Renderer::new(&s).unwrap();
    let camera = renderer.camera(0).unwrap();
    let opts = RenderOptions {
        samples: 32,
        seed: 3,
        max_depth: 4,
        ..RenderOptions::default()
    };
    let illum = renderer
        .render_illum(0, &[CaptureSpec::new("flash0", &["flash0"], None)], &opts)
        .unwrap()
        .remove(0);
    // Radiance of a white Lambertian: I cos / (pi d^2), averaged over the
    // pixel (the renderer's box filter).
    let closed_form = |p: Vec3| {
        let d = light - p;
        intensity * (d.normalize().dot(-Vec3::Z)) / (PI * d.length_squared())
    };
    let mut bias = 0.0f64;
    for y in 0..32 {
        for x in 0..32 {
            let n = 8;
            let mut expected = 0.0;
            for k in 0..n * n {
                let px = DVec2::new(
                    x as f64 + ((k % n) as f64 + 0.5) / n as f64,
                    y as f64 + ((k / n) as f64 + 0.5) / n as f64,
                );
                expected += closed_form(on_plane_z0(&camera, px)) / (n * n) as f32;
            }
            let got = illum.get(x, y);
            bias += (got[0] / expected - 1.0) as f64;
            for c in got {
                // Jitter noise of 32 samples across a pixel's gradient.
                assert!(
                    (c - expected).abs() < 0.025 * expected,
                    "({x}, {y}): {c} vs {expected}"
                );
            }
        }
    }
    let bias = bias / 1024.0;
    assert!(bias.abs() < 1e-3, "mean relative error {bias}");
}

#[test]
fn white_sphere_in_a_uniform_environment_renders_its_radiance() {
    let s = scene(
        sphere(Vec3::ZERO, 0.5, 48, 96),
        &diffuse(1.0),
        no_env(),
        intrinsics(32, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![],
            projector(DVec3::new(0.5, 0.0, -2.0), 64, 64.0, 1.0),
            no_panel(),
        )],
    );
    let renderer = Renderer::with_environment(&s, Environment::uniform(Vec3::ONE));
    let truth = renderer.render_truth(0).unwrap();
    let opts = RenderOptions {
        samples: 64,
        seed: 5,
        max_depth: 8,
        ..RenderOptions::default()
    };
    let img = renderer
        .render_position_with(
            0,
            &[CaptureSpec::new("ambient", &[], None)],
            &opts,
            ObjectMaterial::WhiteDiffuse,
        )
        .unwrap()
        .ambient;
    let mut sum = 0.0;
    let mut count = 0;
    let near_object = |x: u32, y: u32| {
        (x.saturating_sub(1)..=(x + 1).min(31))
            .any(|i| (y.saturating_sub(1)..=(y + 1).min(31)).any(|j| *truth.mask.get(i, j)))
    };
    for y in 0..32 {
        for x in 0..32 {
            let v = img.get(x, y);
            assert!((v[0] - 1.0).abs() < 0.25, "({x}, {y}): {v:?}");
            if *truth.mask.get(x, y) {
                sum += v[0];
                count += 1;
            } else if !near_object(x, y) {
                // The background is the environment itself.
                assert!((v[0] - 1.0).abs() < 1e-6);
            }
        }
    }
    assert!(count > 100);
    let mean = sum / count as f32;
    assert!((mean - 1.0).abs() < 0.02, "mean radiance {mean}");
}

#[test]
fn an_occluder_casts_a_shadow_where_it_blocks_the_flash() {
    let light = Vec3::new(0.8, 0.0, -1.2);
    let blocker = Vec3::new(0.0, 0.0, -0.5);
    let s = scene(
        merge(&[
            quad(Vec3::ZERO, Vec3::X * 3.0, Vec3::Y * 3.0, -Vec3::Z),
            sphere(blocker, 0.15, 12, 24),
        ]),
        &diffuse(0.8),
        no_env(),
        intrinsics(32, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![flash("flash0", light, 5.0)],
            projector(DVec3::new(0.5, 0.0, -2.0), 64, 64.0, 1.0),
            no_panel(),
        )],
    );
    let renderer = Renderer::new(&s).unwrap();
    let camera = renderer.camera(0).unwrap();
    let opts = RenderOptions {
        samples: 16,
        seed: 1,
        max_depth: 4,
        ..RenderOptions::default()
    };
    let photo = renderer
        .render_position(0, &[CaptureSpec::new("flash0", &["flash0"], None)], &opts)
        .unwrap()
        .photos
        .remove(0);
    // The shadow's centre: the line from the light through the blocker's
    // centre meets the plane there.
    let t = -light.z / (blocker.z - light.z);
    let shadow = light + (blocker - light) * t;
    let lit = Vec3::new(shadow.x, 0.55, 0.0);
    let pixel = |p: Vec3| {
        let px = camera.project(p.as_dvec3()).unwrap();
        (px.x.floor() as u32, px.y.floor() as u32)
    };
    let (sx, sy) = pixel(shadow);
    let (lx, ly) = pixel(lit);
    let dark = photo.get(sx, sy)[1];
    let bright = photo.get(lx, ly)[1];
    assert!(bright > 0.05, "lit pixel {bright}");
    assert!(dark < 0.05 * bright, "shadow {dark} vs lit {bright}");
}

#[test]
fn the_checkerboard_lands_where_the_contract_projects_it() {
    let size = 64;
    let proj = projector(DVec3::new(0.3, 0.1, -2.0), 64, 64.0, 4.0);
    let pattern = checker(16.0);
    let s = scene(
        quad(Vec3::ZERO, Vec3::X * 3.0, Vec3::Y * 3.0, -Vec3::Z),
        &diffuse(0.8),
        no_env(),
        intrinsics(size, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![],
            proj.clone(),
            no_panel(),
        )],
    );
    let renderer = Renderer::new(&s).unwrap();
    let camera = renderer.camera(0).unwrap();
    let projector_camera = PinholeCamera::new(proj.intrinsics, proj.projector_to_world);
    let opts = RenderOptions {
        samples: 4,
        seed: 2,
        max_depth: 3,
        ..RenderOptions::default()
    };
    let photo = renderer
        .render_position(
            0,
            &[CaptureSpec::new("checker", &["projector"], Some(pattern))],
            &opts,
        )
        .unwrap()
        .photos
        .remove(0);
    let value_at = |px: DVec2| -> Option<f64> {
        let p = projector_camera.project(on_plane_z0(&camera, px).as_dvec3())?;
        let (u, v) = (p.x.floor(), p.y.floor());
        if u < 0.0 || v < 0.0 || u >= 64.0 || v >= 64.0 {
            return Some(0.0);
        }
        Some(pattern.value_at(u as i64, v as i64))
    };
    let max = photo.data.iter().map(|p| p[1]).fold(0.0f32, f32::max);
    let (mut bright, mut dark) = (0, 0);
    for y in 0..size {
        for x in 0..size {
            // Only pixels wholly inside one square (corners and centre agree).
            let probes: Vec<Option<f64>> = [
                (0.01, 0.01),
                (0.99, 0.01),
                (0.01, 0.99),
                (0.99, 0.99),
                (0.5, 0.5),
            ]
            .iter()
            .map(|&(dx, dy)| value_at(DVec2::new(x as f64 + dx, y as f64 + dy)))
            .collect();
            if probes.iter().any(|p| *p != probes[0]) {
                continue;
            }
            let got = photo.get(x, y)[1];
            if probes[0] == Some(1.0) {
                // Bright squares fall off as cos / d^2 across the plane.
                assert!(got > 0.25 * max, "({x}, {y}) should be bright: {got}");
                bright += 1;
            } else {
                assert!(got == 0.0, "({x}, {y}) should be dark: {got}");
                dark += 1;
            }
        }
    }
    assert!(bright > 200 && dark > 200, "{bright} bright, {dark} dark");
}
