//! What the material does to the captures: subsurface scattering blurs the
//! projected checkerboard, the backlight shines through transmissive parts,
//! and no material or scene scale makes a NaN or an infinity.

use crate::common;

use common::*;
use glam::{DVec3, Vec3};
use matscan_bsdf::material::Material;
use matscan_scan::PinholeCamera;
use matscan_sim::render::{CaptureSpec, RenderOptions, Renderer};
use matscan_sim::scene::{EnvSource, Scene};

/// A thick slab whose front face is the plane z = 0, under a checkerboard.
fn checker_slab(material: &Material) -> Scene {
    scene(
        cuboid(Vec3::new(0.0, 0.0, 0.25), Vec3::new(2.0, 2.0, 0.25)),
        material,
        no_env(),
        intrinsics(48, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![],
            projector(DVec3::new(0.2, 0.1, -2.0), 64, 64.0, 4.0),
            no_panel(),
        )],
    )
}

/// Mean of the dark squares over the mean of the bright ones, from pixels
/// whose centre lies in a square (classified by the contract's formula).
fn dark_to_bright(material: &Material) -> f32 {
    let s = checker_slab(material);
    let renderer = Renderer::new(&s).unwrap();
    let camera = renderer.camera(0).unwrap();
    let proj = &s.rig.positions[0].projector;
    let projector = PinholeCamera::new(proj.intrinsics, proj.projector_to_world);
    let pattern = checker(16.0);
    let opts = RenderOptions {
        samples: 16,
        seed: 4,
        max_depth: 6,
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
    let square_at = |px: glam::DVec2| -> Option<bool> {
        let ray = camera.ray(px);
        let p = ray.at(-ray.origin.z / ray.dir.z);
        let q = projector.project(p.as_dvec3())?;
        if q.x < 0.0 || q.y < 0.0 || q.x >= 64.0 || q.y >= 64.0 {
            return None;
        }
        Some(pattern.value_at(q.x.floor() as i64, q.y.floor() as i64) > 0.5)
    };
    let (mut bright, mut nb, mut dark, mut nd) = (0.0, 0, 0.0, 0);
    for y in 0..48 {
        for x in 0..48 {
            // Only pixels wholly inside one square (corners and centre agree).
            let probes: Vec<Option<bool>> = [
                (0.01, 0.01),
                (0.99, 0.01),
                (0.01, 0.99),
                (0.99, 0.99),
                (0.5, 0.5),
            ]
            .iter()
            .map(|&(dx, dy)| square_at(glam::DVec2::new(x as f64 + dx, y as f64 + dy)))
            .collect();
            if probes.iter().any(|p| *p != probes[0]) {
                continue;
            }
            let v = photo.get(x, y)[1];
            match probes[0] {
                Some(true) => {
                    bright += v;
                    nb += 1;
                }
                Some(false) => {
                    dark += v;
                    nd += 1;
                }
                None => {}
            }
        }
    }
    assert!(nb > 100 && nd > 100, "{nb} bright, {nd} dark pixels");
    (dark / nd as f32) / (bright / nb as f32)
}

#[test]
fn subsurface_scattering_blurs_the_projected_checkerboard() {
    let opaque = diffuse(0.8);
    let translucent = Material {
        subsurface: 1.0,
        subsurface_radius: Vec3::splat(0.08),
        ..opaque
    };
    let sharp = dark_to_bright(&opaque);
    let blurred = dark_to_bright(&translucent);
    assert!(sharp < 0.01, "opaque: dark squares at {sharp} of bright");
    assert!(
        blurred > 0.1,
        "subsurface: dark squares at {blurred} of bright"
    );
}

/// A slab between the camera and the switched-on panel.
fn slab_before_panel(material: &Material) -> Scene {
    scene(
        cuboid(Vec3::ZERO, Vec3::new(0.5, 0.5, 0.05)),
        material,
        no_env(),
        intrinsics(24, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0),
            vec![flash("flash0", Vec3::new(0.0, 0.0, -2.0), 4.0)],
            projector(DVec3::new(0.3, 0.0, -2.0), 64, 64.0, 1.0),
            panel_at(Vec3::new(0.0, 0.0, 1.0), 1.5, 2.0),
        )],
    )
}

fn backlit_centre(material: &Material) -> f32 {
    let s = slab_before_panel(material);
    let renderer = Renderer::new(&s).unwrap();
    let opts = RenderOptions {
        samples: 32,
        seed: 6,
        max_depth: 8,
        ..RenderOptions::default()
    };
    let images = renderer
        .render_position(
            0,
            &[CaptureSpec::new("backlight", &["backlight"], None)],
            &opts,
        )
        .unwrap();
    let mut sum = 0.0;
    for y in 10..14 {
        for x in 10..14 {
            sum += images.light_only[0].get(x, y)[1];
        }
    }
    sum / 16.0
}

#[test]
fn the_backlight_shines_through_a_transmissive_slab() {
    let opaque = diffuse(0.8);
    let clear = Material {
        transmission: 1.0,
        roughness: 0.0,
        basecolor: Vec3::ONE,
        ..opaque
    };
    let frosted = Material {
        roughness: 0.3,
        ..clear
    };
    let radiance = 2.0;
    let blocked = backlit_centre(&opaque);
    let through_clear = backlit_centre(&clear);
    let through_frosted = backlit_centre(&frosted);
    assert!(blocked < 0.02 * radiance, "opaque: {blocked}");
    // Two dielectric interfaces lose about 7 % to reflection.
    assert!(through_clear > 0.8 * radiance, "clear: {through_clear}");
    assert!(
        through_frosted > 0.5 * radiance,
        "frosted: {through_frosted}"
    );
}

fn all_captures() -> Vec<CaptureSpec> {
    vec![
        CaptureSpec::new("ambient", &[], None),
        CaptureSpec::new("flash0", &["flash0"], None),
        CaptureSpec::new("projector", &["projector"], None),
        CaptureSpec::new("checker", &["projector"], Some(checker(8.0))),
        CaptureSpec::new("backlight", &["backlight"], None),
    ]
}

fn assert_finite_renders(s: &Scene, what: &str) {
    let renderer = Renderer::new(s).unwrap();
    let opts = RenderOptions {
        samples: 4,
        seed: 8,
        max_depth: 8,
        ..RenderOptions::default()
    };
    let images = renderer.render_position(0, &all_captures(), &opts).unwrap();
    assert_eq!(images.dropped_samples, 0, "{what}: samples dropped");
    for img in images.photos.iter().chain(&images.light_only) {
        assert!(
            img.data
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0),
            "{what}"
        );
    }
    let illum = renderer
        .render_illum(0, &all_captures()[1..3], &opts)
        .unwrap();
    assert!(illum
        .iter()
        .all(|i| i.data.iter().flatten().all(|v| v.is_finite())));
    let truth = renderer.render_truth(0).unwrap();
    assert!(truth.basecolor.data.iter().flatten().all(|v| v.is_finite()));
}

#[test]
fn extreme_materials_render_without_nan_or_infinity() {
    let base = diffuse(0.5);
    let materials = [
        Material {
            roughness: 0.0,
            metallic: 1.0,
            basecolor: Vec3::ONE,
            ..base
        },
        Material {
            roughness: 0.0,
            transmission: 1.0,
            basecolor: Vec3::ONE,
            ..base
        },
        Material {
            roughness: 1.0,
            transmission: 1.0,
            basecolor: Vec3::ZERO,
            ..base
        },
        Material {
            subsurface: 1.0,
            subsurface_radius: Vec3::splat(1e-7),
            ..base
        },
        Material {
            subsurface: 1.0,
            subsurface_radius: Vec3::new(1e3, 1e-3, 1.0),
            basecolor: Vec3::ONE,
            ..base
        },
        Material {
            subsurface: 1e-4,
            roughness: 1e-4,
            basecolor: Vec3::new(1.0, 0.0, 1.0),
            ..base
        },
        Material {
            basecolor: Vec3::new(f32::NAN, f32::INFINITY, -1.0),
            roughness: f32::NAN,
            metallic: 2.0,
            transmission: -1.0,
            subsurface: f32::INFINITY,
            subsurface_radius: Vec3::splat(f32::NAN),
        },
    ];
    for (i, m) in materials.iter().enumerate() {
        let mut s = slab_before_panel(m);
        s.mesh = sphere(Vec3::ZERO, 0.4, 12, 24);
        s.environment.source = EnvSource::Procedural { seed: i as u64 };
        assert_finite_renders(&s, &format!("material {i}"));
    }
}

/// The closed-form plane scene scaled by `k` (lights scaled by k^2 so the
/// radiance stays the same).
fn plane_at_scale(k: f32) -> Scene {
    let kd = k as f64;
    let mut s = scene(
        merge(&[
            quad(Vec3::ZERO, Vec3::X * 3.0 * k, Vec3::Y * 3.0 * k, -Vec3::Z),
            sphere(Vec3::new(0.0, 0.0, -0.5) * k, 0.15 * k, 12, 24),
        ]),
        &Material {
            subsurface: 1.0,
            subsurface_radius: Vec3::splat(0.05 * k),
            ..diffuse(0.8)
        },
        no_env(),
        intrinsics(24, 1.0, [0.0; 5]),
        vec![position(
            DVec3::new(0.0, 0.0, -2.0) * kd,
            vec![flash("flash0", Vec3::new(0.8, 0.0, -1.2) * k, 5.0 * k * k)],
            projector(DVec3::new(0.5, 0.0, -2.0) * kd, 64, 64.0, 1.0),
            panel_at(Vec3::new(0.0, 0.0, 0.5) * k, 1.0 * k, 1.0),
        )],
    );
    s.environment.source = EnvSource::None;
    s
}

#[test]
fn scene_scale_from_a_millimetre_to_a_kilometre_renders_the_same() {
    let opts = RenderOptions {
        samples: 8,
        seed: 2,
        max_depth: 6,
        ..RenderOptions::default()
    };
    let mean = |k: f32| {
        let s = plane_at_scale(k);
        let renderer = Renderer::new(&s).unwrap();
        let images = renderer
            .render_position(0, &[CaptureSpec::new("flash0", &["flash0"], None)], &opts)
            .unwrap();
        assert_eq!(images.dropped_samples, 0);
        let data = &images.photos[0].data;
        data.iter().map(|p| p[1]).sum::<f32>() / data.len() as f32
    };
    let unit = mean(1.0);
    for k in [1e-3, 1e3] {
        let m = mean(k);
        assert!((m - unit).abs() < 0.03 * unit, "scale {k}: {m} vs {unit}");
    }
}
