//! Baking a simulated scan's truth maps reproduces the scene's authored
//! material in UV space, marks exactly the seen texels as measured, and
//! fills everything else from measured values.

use glam::{Vec2, Vec3};
use matscan_bake::atlas::{Atlas, TexelKind};
use matscan_bake::{bake_truth, texel_uv, BakeOptions, BakedTextures};
use matscan_scan::bvh::RayCaster;
use matscan_scan::{Bundle, Param, SurfacePoint};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, Scene, SceneKind, SceneOptions};
use std::sync::OnceLock;

const TEXTURE: u32 = 96;

struct Fixture {
    _dir: tempfile::TempDir,
    scene: Scene,
    bundle: Bundle,
    baked: BakedTextures,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let scene = generate(&SceneOptions {
            seed: 7,
            kind: SceneKind::Multimat,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: 128,
            height: 128,
            positions: 3,
            map_size: 16,
        });
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("scan");
        let options = SimOptions {
            samples: 1,
            seed: 3,
            threads: Some(2),
            ..SimOptions::default()
        };
        let bundle = write_scan_bundle(&scene, &options, &out).unwrap();
        let baked = bake_truth(
            &bundle,
            &BakeOptions {
                size: TEXTURE,
                ..BakeOptions::default()
            },
        )
        .unwrap();
        Fixture {
            _dir: dir,
            scene,
            bundle,
            baked,
        }
    })
}

/// The scene's effective parameter at `uv`, as the truth maps hold it.
fn true_value(scene: &Scene, param: Param, uv: Vec2) -> f32 {
    let sp = SurfacePoint {
        position: Vec3::ZERO,
        geometric_normal: Vec3::Z,
        shading_normal: Vec3::Z,
        uv: Some(uv),
        triangle: 0,
    };
    let m = scene.material.at(&sp);
    match param {
        Param::Basecolor => m.basecolor.to_array().iter().sum::<f32>() / 3.0,
        Param::Roughness => m.roughness,
        Param::Metallic => m.metallic,
        Param::Transmission => m.effective_transmission(),
        Param::Subsurface => m.effective_subsurface(),
    }
}

fn atlas(f: &Fixture) -> (Atlas, RayCaster) {
    let mesh = f.bundle.read_mesh().unwrap();
    let uvs = mesh.uvs.clone().unwrap();
    let atlas = Atlas::rasterize(&mesh, &uvs, TEXTURE, TEXTURE, 2);
    (atlas, RayCaster::new(mesh))
}

#[test]
fn baked_truth_matches_the_authored_material_on_measured_texels() {
    let f = fixture();
    let (atlas, _) = atlas(f);
    assert_eq!(f.baked.params(), Param::ALL.to_vec());
    for param in Param::ALL {
        let (mut err, mut spread, mut n) = (0.0f64, 0.0f64, 0usize);
        let (mut flat_err, mut flat_n) = (0.0f64, 0usize);
        let mut truth = Vec::new();
        let step = 1.0 / TEXTURE as f32;
        for y in 0..TEXTURE {
            for x in 0..TEXTURE {
                if !*f.baked.coverage().get(x, y) || atlas.kind(x, y) != TexelKind::Inside {
                    continue;
                }
                let uv = texel_uv(x, y, TEXTURE, TEXTURE);
                let t = true_value(&f.scene, param, uv);
                let b = f.baked.value(param, x, y).unwrap();
                let e = f64::from((t - b).abs());
                err += e;
                truth.push(t);
                n += 1;
                // Away from material edges (truth within 0.02 over four
                // texels), where resampling through the camera cannot blur.
                let flat = (-4..=4).all(|dy: i32| {
                    (-4..=4).all(|dx: i32| {
                        let o = Vec2::new(dx as f32 * step, dy as f32 * step);
                        (true_value(&f.scene, param, uv + o) - t).abs() < 0.02
                    })
                });
                if flat {
                    flat_err += e;
                    flat_n += 1;
                }
            }
        }
        assert!(
            n > (TEXTURE * TEXTURE / 8) as usize,
            "{param}: only {n} measured texels"
        );
        let mean = truth.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
        for &t in &truth {
            spread += (f64::from(t) - mean).abs();
        }
        let (mad, baseline) = (err / n as f64, spread / n as f64);
        let flat_mad = flat_err / flat_n.max(1) as f64;
        println!(
            "{param}: MAD {mad:.4} over {n} texels (constant guess {baseline:.4}); \
             {flat_mad:.4} over {flat_n} texels away from material edges"
        );
        // Binary maps have flat regions, where the bake must be exact; the
        // smooth basecolor noise has none, and its MAD overall is small.
        if flat_n >= 50 {
            assert!(flat_mad < 0.005, "{param}: MAD {flat_mad} away from edges");
        } else {
            assert!(mad < 0.03, "{param}: MAD {mad}");
        }
        assert!(
            baseline < 1e-3 || mad < 0.4 * baseline,
            "{param}: MAD {mad} not well below the constant guess's {baseline}"
        );
    }
}

#[test]
fn coverage_marks_exactly_the_texels_some_camera_sees() {
    let f = fixture();
    let (atlas, caster) = atlas(f);
    let cameras: Vec<_> = f
        .bundle
        .manifest
        .positions
        .iter()
        .map(|p| f.bundle.camera(&p.name).unwrap())
        .collect();
    // Every surface point a camera pixel sees lands on a measured texel.
    let (mut seen, mut covered) = (0usize, 0usize);
    for camera in &cameras {
        let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
        for j in 0..h {
            for i in 0..w {
                let Some((_, sp)) = caster.closest(&camera.pixel_ray(i, j)) else {
                    continue;
                };
                let uv = sp.uv.unwrap();
                let x = ((uv.x * TEXTURE as f32) as u32).min(TEXTURE - 1);
                let y = (((1.0 - uv.y) * TEXTURE as f32) as u32).min(TEXTURE - 1);
                seen += 1;
                covered += usize::from(*f.baked.coverage().get(x, y));
            }
        }
    }
    assert!(seen > 1000);
    assert!(
        covered as f64 > 0.97 * seen as f64,
        "{covered} of {seen} seen points covered"
    );
    // Texels facing away from every camera are not.
    let mesh = &caster.mesh;
    let uvs = mesh.uvs.as_ref().unwrap();
    let mut hidden = 0;
    for y in 0..TEXTURE {
        for x in 0..TEXTURE {
            let Some(sp) = atlas.surface(mesh, uvs, x, y) else {
                continue;
            };
            let faces_away = cameras.iter().all(|c| {
                let to_cam = c.center().as_vec3() - sp.position;
                sp.geometric_normal.dot(to_cam) <= 0.0
            });
            if faces_away {
                hidden += 1;
                assert!(
                    !*f.baked.coverage().get(x, y),
                    "texel {x},{y} faces away but is covered"
                );
            }
        }
    }
    assert!(
        hidden > 50,
        "only {hidden} hidden texels: the test proves little"
    );
    // And texels outside the atlas are never measured.
    for y in 0..TEXTURE {
        for x in 0..TEXTURE {
            if atlas.kind(x, y) == TexelKind::Outside {
                assert!(!*f.baked.coverage().get(x, y));
            }
        }
    }
}

#[test]
fn hole_filling_leaves_no_hole_and_stays_in_the_measured_range() {
    let f = fixture();
    let cov = f.baked.coverage();
    let holes = cov.data.iter().filter(|&&c| !c).count();
    assert!(holes > 100, "only {holes} holes");
    for param in Param::ALL {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in 0..TEXTURE {
            for x in 0..TEXTURE {
                if *cov.get(x, y) {
                    let v = f.baked.value(param, x, y).unwrap();
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        for y in 0..TEXTURE {
            for x in 0..TEXTURE {
                let v = f.baked.value(param, x, y).unwrap();
                assert!(v.is_finite());
                assert!(
                    v >= lo - 1e-5 && v <= hi + 1e-5,
                    "{param} at {x},{y}: {v} outside measured [{lo}, {hi}]"
                );
            }
        }
    }
    // A filled basecolor hole is not black: it holds measured colour.
    let base = f.baked.basecolor().unwrap();
    let black_holes = (0..cov.data.len())
        .filter(|&i| !cov.data[i] && base.data[i].iter().all(|&c| c == 0.0))
        .count();
    assert_eq!(black_holes, 0);
}
