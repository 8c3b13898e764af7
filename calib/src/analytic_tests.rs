//! Tests on analytic scenes (a sphere and planes under known lights) where
//! every map has a closed form.
//!
//! Honest tolerances: a plane made of two triangles is exact, so its maps
//! are compared with the closed form of the ray-plane intersection at every
//! pixel. A tessellated sphere is not a sphere: its hit points are compared
//! with the analytic ray-sphere intersection to within the tessellation's
//! sagitta (< 1e-4 at the pixels compared), and every derived map (normal,
//! view, light, cosines, distance) with the sphere's closed form evaluated
//! at the hit point, which is exact up to f32 rounding.

use crate::angles;
use crate::geometry::position_geometry;
use crate::lights::{light_maps, LightSource};
use crate::maps::position_maps;
use crate::synthetic::{icosphere, intrinsics, merge, point_light, projector, quad};
use crate::warp::{correspondence, WarpOptions};
use glam::{DMat4, DVec2, DVec3, Vec3};
use matscan_scan::bvh::RayCaster;
use matscan_scan::camera::look_at;
use matscan_scan::{Intrinsics, Mesh, Pattern, PinholeCamera, Position, Raster};
use std::sync::OnceLock;

const TOL: f64 = 1e-4;

fn v3(p: &[f32; 3]) -> DVec3 {
    DVec3::new(p[0].into(), p[1].into(), p[2].into())
}

fn position(name: &str, camera_to_world: DMat4, lights: Vec<matscan_scan::Light>) -> Position {
    Position {
        name: name.into(),
        camera_to_world,
        lights,
        captures: vec![],
        white_reference_mask: None,
    }
}

/// A level-6 icosphere (81920 triangles) of radius 0.5 at the origin:
/// sagitta ~2.5e-5, built once for all tests.
fn fine_sphere() -> &'static RayCaster {
    static SCENE: OnceLock<RayCaster> = OnceLock::new();
    SCENE.get_or_init(|| RayCaster::new(icosphere(Vec3::ZERO, 0.5, 6)))
}

/// Distance along a ray to the analytic sphere, if hit.
fn ray_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let oc = o - c;
    let b = d.dot(oc);
    let disc = b * b - (oc.length_squared() - r * r);
    (disc >= 0.0).then(|| -b - disc.sqrt())
}

fn assert_close(what: &str, x: u32, y: u32, got: f64, want: f64, tol: f64) {
    assert!(
        (got - want).abs() <= tol,
        "{what} at ({x},{y}): got {got}, want {want}"
    );
}

fn assert_vec(what: &str, x: u32, y: u32, got: DVec3, want: DVec3, tol: f64) {
    assert!(
        (got - want).abs().max_element() <= tol,
        "{what} at ({x},{y}): got {got}, want {want}"
    );
}

#[test]
fn sphere_maps_match_closed_forms() {
    let scene = fine_sphere();
    let eye = DVec3::new(0.0, 0.0, -1.5);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let light = DVec3::new(0.4, -0.3, -1.2);
    let cam = PinholeCamera::new(intrinsics(40, 45.0), c2w);
    let pos = position("p0", c2w, vec![point_light("flash", light)]);
    let maps = position_maps(scene, &cam.intrinsics, &pos);
    let g = &maps.geometry;
    let lm = &maps.lights[0];
    let w2c = cam.world_to_camera();
    let mut compared = 0;
    for y in 0..40 {
        for x in 0..40 {
            let ray = cam.pixel_ray(x, y);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let analytic = ray_sphere(o, d, DVec3::ZERO, 0.5);
            let hit = *g.mask.get(x, y);
            let Some(t) = analytic else {
                assert!(!hit, "background pixel ({x},{y}) marked object");
                continue;
            };
            let p_true = o + d * t;
            let n_true = p_true.normalize();
            // Away from the silhouette, where the tessellation error along
            // the ray (sagitta / cos) stays below 1e-4.
            if n_true.dot(-d) < 0.5 {
                continue;
            }
            assert!(hit, "sphere pixel ({x},{y}) missed");
            compared += 1;
            let p = v3(g.position.get(x, y));
            assert_vec("position", x, y, p, p_true, TOL);
            assert_close(
                "depth",
                x,
                y,
                f64::from(*g.depth.get(x, y)),
                w2c.transform_point3(p_true).z,
                TOL,
            );
            // Closed forms at the hit point.
            let to_cam = |v: DVec3| w2c.transform_vector3(v);
            let n = p.normalize();
            let v = (eye - p).normalize();
            let l = (light - p).normalize();
            assert_vec("normal", x, y, v3(g.normal.get(x, y)), to_cam(n), 1e-5);
            assert_vec("view", x, y, v3(g.view.get(x, y)), to_cam(v), 1e-5);
            assert_vec("light", x, y, v3(lm.direction.get(x, y)), to_cam(l), 1e-5);
            assert_close(
                "distance",
                x,
                y,
                f64::from(*lm.distance.get(x, y)),
                (light - p).length(),
                1e-5,
            );
            assert_close(
                "cos_nv",
                x,
                y,
                f64::from(*g.cos_nv.get(x, y)),
                n.dot(v),
                1e-5,
            );
            assert_close(
                "cos_nl",
                x,
                y,
                f64::from(*lm.cos_nl.get(x, y)),
                n.dot(l),
                1e-5,
            );
            let vs = v - n * v.dot(n);
            let ls = l - n * l.dot(n);
            if vs.length() > 1e-3 && ls.length() > 1e-3 {
                let want = vs.dot(ls) / (vs.length() * ls.length());
                assert_close("cos_vl", x, y, f64::from(*lm.cos_vl.get(x, y)), want, 1e-4);
            }
            // Also against the fully analytic normal at the true point.
            assert_vec(
                "normal (analytic)",
                x,
                y,
                v3(g.normal.get(x, y)),
                to_cam(n_true),
                2e-4,
            );
            assert_eq!(*lm.lit.get(x, y), n.dot(l) > 0.0, "lit at ({x},{y})");
        }
    }
    assert!(compared > 500, "only {compared} pixels compared");
}

/// The plane z = 0 (two triangles), seen obliquely.
fn plane_scene() -> RayCaster {
    RayCaster::new(quad(
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 4.0, 0.0),
    ))
}

fn ray_plane(o: DVec3, d: DVec3) -> Option<f64> {
    let t = -o.z / d.z;
    (t > 0.0).then_some(t)
}

#[test]
fn plane_maps_match_closed_forms_everywhere() {
    let scene = plane_scene();
    let eye = DVec3::new(0.3, -0.2, -2.0);
    let c2w = look_at(eye, DVec3::new(0.1, 0.1, 0.0), DVec3::new(0.0, -1.0, 0.0));
    let light = DVec3::new(-0.5, 0.4, -1.0);
    let mut intr = intrinsics(48, 50.0);
    intr.distortion = [-0.12, 0.03, 0.001, -0.002, 0.0];
    let cam = PinholeCamera::new(intr, c2w);
    let pos = position("p0", c2w, vec![point_light("flash", light)]);
    let maps = position_maps(&scene, &intr, &pos);
    let (g, lm) = (&maps.geometry, &maps.lights[0]);
    let w2c = cam.world_to_camera();
    let n_world = DVec3::new(0.0, 0.0, -1.0); // the side facing the camera
    for y in 0..48 {
        for x in 0..48 {
            let ray = cam.pixel_ray(x, y);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let p = o + d * ray_plane(o, d).unwrap();
            assert!(*g.mask.get(x, y));
            let n = n_world;
            let v = (eye - p).normalize();
            let l = (light - p).normalize();
            let to_cam = |u: DVec3| w2c.transform_vector3(u);
            assert_vec("position", x, y, v3(g.position.get(x, y)), p, TOL);
            assert_close(
                "depth",
                x,
                y,
                (*g.depth.get(x, y)).into(),
                w2c.transform_point3(p).z,
                TOL,
            );
            assert_vec("normal", x, y, v3(g.normal.get(x, y)), to_cam(n), TOL);
            assert_vec("view", x, y, v3(g.view.get(x, y)), to_cam(v), TOL);
            assert_vec("light", x, y, v3(lm.direction.get(x, y)), to_cam(l), TOL);
            assert_close(
                "distance",
                x,
                y,
                (*lm.distance.get(x, y)).into(),
                (light - p).length(),
                TOL,
            );
            assert_close("cos_nv", x, y, (*g.cos_nv.get(x, y)).into(), n.dot(v), TOL);
            assert_close("cos_nl", x, y, (*lm.cos_nl.get(x, y)).into(), n.dot(l), TOL);
            let vs = v - n * v.dot(n);
            let ls = l - n * l.dot(n);
            let want = vs.dot(ls) / (vs.length() * ls.length());
            assert_close("cos_vl", x, y, (*lm.cos_vl.get(x, y)).into(), want, TOL);
            assert!(*lm.lit.get(x, y));
            // The distortion round trip: the hit projects back to the centre.
            let q = cam.project(v3(g.position.get(x, y))).unwrap();
            let centre = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
            assert!((q - centre).length() < 1e-3, "({x},{y}) projects to {q}");
            // UV of the quad: (x + 2) / 4, (y + 2) / 4.
            let uv = g.uv.as_ref().unwrap().get(x, y);
            assert_close("u", x, y, uv[0].into(), (p.x + 2.0) / 4.0, TOL);
            assert_close("v", x, y, uv[1].into(), (p.y + 2.0) / 4.0, TOL);
        }
    }
}

#[test]
fn sphere_casts_its_analytic_shadow_on_a_plane_behind_it() {
    let mesh = merge(&[
        icosphere(Vec3::ZERO, 0.4, 4),
        quad(
            Vec3::new(-3.0, -3.0, 1.0),
            Vec3::new(0.0, 6.0, 0.0),
            Vec3::new(6.0, 0.0, 0.0),
        ),
    ]);
    let scene = RayCaster::new(mesh);
    let eye = DVec3::new(0.0, 0.0, -2.0);
    let light = DVec3::new(0.7, 0.2, -1.5);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let intr = intrinsics(48, 60.0);
    let cam = PinholeCamera::new(intr, c2w);
    let g = position_geometry(&scene, &cam);
    let lm = light_maps(&scene, &c2w, &g, "flash", LightSource::Point(light));
    let (mut shadowed, mut lit) = (0, 0);
    for y in 0..48 {
        for x in 0..48 {
            let p = v3(g.position.get(x, y));
            if (p.z - 1.0).abs() > 1e-4 {
                continue; // on the sphere
            }
            // Distance from the sphere centre to the segment p -> light.
            let d = (light - p).normalize();
            let t = (-p).dot(d).clamp(0.0, (light - p).length());
            let miss = (p + d * t).length();
            if miss < 0.4 - 0.01 {
                assert!(!*lm.lit.get(x, y), "({x},{y}) should be in shadow");
                shadowed += 1;
            } else if miss > 0.4 + 0.01 {
                assert!(*lm.lit.get(x, y), "({x},{y}) should be lit");
                lit += 1;
            }
        }
    }
    assert!(shadowed > 20 && lit > 200, "shadowed {shadowed}, lit {lit}");
    let shadow = lm.shadow(&g.mask);
    let total: f32 = shadow.data.iter().sum();
    assert!(total as usize >= shadowed);
}

fn all_finite(r: &Raster<[f32; 3]>) -> bool {
    r.data.iter().all(|p| p.iter().all(|v| v.is_finite()))
}

#[test]
fn light_behind_the_surface_gives_negative_cos_nl_and_no_light() {
    let scene = plane_scene();
    let eye = DVec3::new(0.0, 0.0, -2.0);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let behind = DVec3::new(0.2, 0.1, 1.0);
    let pos = position("p0", c2w, vec![point_light("behind", behind)]);
    let maps = position_maps(&scene, &intrinsics(16, 40.0), &pos);
    let lm = &maps.lights[0];
    for (i, &m) in maps.geometry.mask.data.iter().enumerate() {
        assert!(m);
        assert!(lm.cos_nl.data[i] < 0.0 && lm.cos_nl.data[i] >= -1.0);
        assert!(!lm.lit.data[i]);
        assert!(lm.cos_vl.data[i].is_finite());
    }
    assert!(all_finite(&lm.direction));
}

#[test]
fn zero_length_and_nan_mesh_normals_fall_back_to_the_face_normal() {
    let mut mesh = quad(
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 4.0, 0.0),
    );
    mesh.normals = Some(vec![Vec3::ZERO, Vec3::ZERO, Vec3::NAN, Vec3::ZERO]);
    let scene = RayCaster::new(mesh);
    let eye = DVec3::new(0.0, 0.0, -2.0);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let pos = position(
        "p0",
        c2w,
        vec![point_light("l", DVec3::new(0.3, 0.0, -1.0))],
    );
    let maps = position_maps(&scene, &intrinsics(16, 40.0), &pos);
    let w2c = c2w.inverse();
    let want = w2c.transform_vector3(DVec3::new(0.0, 0.0, -1.0));
    for n in &maps.geometry.normal.data {
        assert!((v3(n) - want).length() < 1e-6, "normal {n:?}");
    }
    assert!(maps.lights[0]
        .cos_nl
        .data
        .iter()
        .all(|c| c.is_finite() && *c > 0.0));
}

#[test]
fn silhouettes_grazing_views_and_degenerate_lights_stay_finite() {
    // A coarse sphere: many pixels graze it; a light at the camera centre,
    // one inside the sphere and one exactly on a vertex.
    let mesh = icosphere(Vec3::ZERO, 0.5, 2);
    let vertex = mesh.positions[0].as_dvec3();
    let scene = RayCaster::new(mesh);
    let eye = DVec3::new(0.0, 0.0, -1.5);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let pos = position(
        "p0",
        c2w,
        vec![
            point_light("at_camera", eye),
            point_light("inside", DVec3::ZERO),
            point_light("on_vertex", vertex),
        ],
    );
    let maps = position_maps(&scene, &intrinsics(64, 45.0), &pos);
    let g = &maps.geometry;
    for r in [&g.position, &g.normal, &g.geometric_normal, &g.view] {
        assert!(all_finite(r));
    }
    assert!(g
        .depth
        .data
        .iter()
        .chain(&g.cos_nv.data)
        .all(|v| v.is_finite()));
    for lm in &maps.lights {
        assert!(all_finite(&lm.direction));
        for s in [&lm.distance, &lm.cos_nl, &lm.cos_vl] {
            assert!(s.data.iter().all(|v| v.is_finite() && v.abs() <= 3.0));
        }
    }
    // The light inside the sphere reaches no visible point.
    assert!(maps.light("inside").unwrap().lit.data.iter().all(|l| !l));
    // Background pixels hold zeros.
    let bg = g.mask.data.iter().position(|m| !m).unwrap();
    assert_eq!(g.normal.data[bg], [0.0; 3]);
    assert_eq!(g.depth.data[bg], 0.0);
    assert_eq!(maps.lights[0].cos_nl.data[bg], 0.0);
}

#[test]
fn sphere_in_a_distorting_camera_projects_back_to_pixel_centres() {
    let scene = fine_sphere();
    let c2w = look_at(
        DVec3::new(0.2, 0.0, -1.4),
        DVec3::ZERO,
        DVec3::new(0.0, -1.0, 0.0),
    );
    let mut intr = intrinsics(32, 50.0);
    intr.distortion = [0.2, -0.05, 0.002, 0.001, 0.01];
    let cam = PinholeCamera::new(intr, c2w);
    let g = position_geometry(scene, &cam);
    let mut n = 0;
    for y in 0..32 {
        for x in 0..32 {
            if *g.mask.get(x, y) {
                let q = cam.project(v3(g.position.get(x, y))).unwrap();
                let centre = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                assert!((q - centre).length() < 1e-3, "({x},{y}) -> {q}");
                n += 1;
            }
        }
    }
    assert!(n > 100);
}

#[test]
fn projector_pattern_is_the_checker_at_the_analytic_projector_pixel() {
    let scene = plane_scene();
    let eye = DVec3::new(0.0, 0.0, -2.0);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let p2w = look_at(
        DVec3::new(0.4, 0.1, -2.0),
        DVec3::ZERO,
        DVec3::new(0.0, -1.0, 0.0),
    );
    let pintr = Intrinsics {
        width: 320,
        height: 200,
        fx: 250.0,
        fy: 250.0,
        cx: 160.0,
        cy: 100.0,
        distortion: [0.0; 5],
    };
    let pattern = Pattern::Checker {
        period_px: 16.0,
        phase_px: [3.0, 5.0],
        low: 0.1,
        high: 0.9,
    };
    let mut pos = position("p0", c2w, vec![projector("proj", p2w, pintr)]);
    pos.captures = vec![crate::synthetic::capture(
        "p0",
        "checker",
        &["proj"],
        Some(pattern),
    )];
    let intr = intrinsics(64, 70.0);
    let maps = position_maps(&scene, &intr, &pos);
    let pm = &maps.projectors[0];
    assert_eq!(pm.patterns.len(), 1);
    let (name, values) = &pm.patterns[0];
    assert_eq!(name, "checker");
    let cam = PinholeCamera::new(intr, c2w);
    let proj = PinholeCamera::new(pintr, p2w);
    let (mut inside, mut outside) = (0, 0);
    for y in 0..64 {
        for x in 0..64 {
            let ray = cam.pixel_ray(x, y);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let p = o + d * ray_plane(o, d).unwrap();
            let q = proj.project(p).unwrap();
            let in_image = q.x >= 0.0 && q.y >= 0.0 && q.x < 320.0 && q.y < 200.0;
            let near_edge =
                |c: f64, phase: f64| ((c - phase) / 8.0 - ((c - phase) / 8.0).round()).abs() < 1e-3;
            if !in_image {
                assert_eq!(*values.get(x, y), 0.0);
                assert!(!*maps.lights[0].lit.get(x, y));
                outside += 1;
                continue;
            }
            let [u, v] = *pm.pixel.get(x, y);
            assert!((f64::from(u) - q.x).abs() < 1e-2 && (f64::from(v) - q.y).abs() < 1e-2);
            if near_edge(q.x, 3.0) || near_edge(q.y, 5.0) {
                continue;
            }
            let want = pattern.value_at(q.x.floor() as i64, q.y.floor() as i64) as f32;
            assert_eq!(*values.get(x, y), want, "({x},{y})");
            inside += 1;
        }
    }
    assert!(
        inside > 1000 && outside > 50,
        "inside {inside}, outside {outside}"
    );
}

fn two_views() -> (DMat4, DMat4) {
    let up = DVec3::new(0.0, -1.0, 0.0);
    (
        look_at(DVec3::new(0.0, 0.0, -2.0), DVec3::ZERO, up),
        look_at(DVec3::new(0.8, 0.3, -1.8), DVec3::ZERO, up),
    )
}

#[test]
fn warp_maps_plane_points_to_their_analytic_pixels_and_resamples_bilinearly() {
    let scene = plane_scene();
    let (c0, c1) = two_views();
    let intr = intrinsics(40, 60.0);
    let m0 = position_maps(&scene, &intr, &position("p0", c0, vec![]));
    let m1 = position_maps(&scene, &intr, &position("p1", c1, vec![]));
    let corr = correspondence(&m0, &m1, &WarpOptions::default());
    let (cam0, cam1) = (PinholeCamera::new(intr, c0), PinholeCamera::new(intr, c1));
    // A photo affine in the pixel coordinates: bilinear resampling is exact.
    let f = |u: f64, v: f64| [(0.01 * u + 0.02 * v) as f32, (1.0 - 0.015 * u) as f32, 0.5];
    let photo = Raster::from_fn(40, 40, |x, y| f(f64::from(x) + 0.5, f64::from(y) + 0.5));
    let warped = corr.warp_rgb(&photo, "ambient").unwrap();
    let mut valid = 0;
    for y in 0..40 {
        for x in 0..40 {
            let ray = cam0.pixel_ray(x, y);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            let p = o + d * ray_plane(o, d).unwrap();
            let q = cam1.project(p).unwrap();
            let interior = q.x > 0.5 && q.y > 0.5 && q.x < 39.5 && q.y < 39.5;
            if interior {
                assert!(*corr.valid.get(x, y), "({x},{y}) should match");
                let [u, v] = *corr.coords.get(x, y);
                assert!((f64::from(u) - q.x).abs() < 1e-3 && (f64::from(v) - q.y).abs() < 1e-3);
                let got = warped.get(x, y);
                let want = f(q.x, q.y);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-4,
                        "({x},{y}) {got:?} {want:?}"
                    );
                }
                valid += 1;
            } else if !(q.x >= 0.0 && q.y >= 0.0 && q.x < 40.0 && q.y < 40.0) {
                assert!(!*corr.valid.get(x, y));
                assert_eq!(*warped.get(x, y), [0.0; 3]);
            }
        }
    }
    assert!(valid > 800, "{valid}");
    assert_eq!(
        corr.valid_pixels(),
        corr.valid.data.iter().filter(|v| **v).count()
    );
}

#[test]
fn warp_rejects_points_the_other_camera_cannot_see() {
    // A sphere in front of a plane: plane points behind the sphere as seen
    // from p1 (but visible from p0) must not match.
    let mesh: Mesh = merge(&[
        icosphere(Vec3::new(0.0, 0.0, -0.6), 0.3, 3),
        quad(
            Vec3::new(-3.0, -3.0, 0.0),
            Vec3::new(0.0, 6.0, 0.0),
            Vec3::new(6.0, 0.0, 0.0),
        ),
    ]);
    let sphere_centre = DVec3::new(0.0, 0.0, -0.6);
    let scene = RayCaster::new(mesh);
    let (c0, c1) = two_views();
    let intr = intrinsics(48, 60.0);
    let m0 = position_maps(&scene, &intr, &position("p0", c0, vec![]));
    let m1 = position_maps(&scene, &intr, &position("p1", c1, vec![]));
    let corr = correspondence(&m0, &m1, &WarpOptions::default());
    let eye1 = DVec3::new(0.8, 0.3, -1.8);
    let (mut hidden, mut seen) = (0, 0);
    for y in 0..48 {
        for x in 0..48 {
            let p = v3(m0.geometry.position.get(x, y));
            if p.z.abs() > 1e-4 {
                continue;
            }
            let d = (eye1 - p).normalize();
            let t = (sphere_centre - p).dot(d).max(0.0);
            let miss = (p + d * t - sphere_centre).length();
            if miss < 0.28 {
                assert!(
                    !*corr.valid.get(x, y),
                    "({x},{y}) hidden from p1 but matched"
                );
                hidden += 1;
            } else if miss > 0.33 && *corr.valid.get(x, y) {
                seen += 1;
            }
        }
    }
    assert!(hidden > 10 && seen > 300, "hidden {hidden}, seen {seen}");
}

#[test]
fn cos_vl_map_uses_the_documented_pole_value() {
    // Camera and light both straight above the plane centre: V and L are
    // parallel to N at the centre pixel, so eq. 3.4 is undefined there.
    let scene = plane_scene();
    let eye = DVec3::new(0.0, 0.0, -2.0);
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let pos = position("p0", c2w, vec![point_light("l", eye)]);
    let maps = position_maps(&scene, &intrinsics(9, 40.0), &pos);
    let n = v3(maps.geometry.normal.get(4, 4));
    let v = v3(maps.geometry.view.get(4, 4));
    assert!((n - v).length() < 1e-6);
    let got = *maps.lights[0].cos_vl.get(4, 4);
    assert_eq!(f64::from(got), angles::cos_vl(n, v, v));
    assert!(got.abs() < 1e-3);
}

/// The shadow scene (a sphere before a plane, one light) at scale `s`.
fn scaled_maps(s: f32) -> crate::maps::PixelMaps {
    let mesh = merge(&[
        icosphere(Vec3::ZERO, 0.4 * s, 3),
        quad(
            Vec3::new(-3.0, -3.0, 1.0) * s,
            Vec3::new(0.0, 6.0, 0.0) * s,
            Vec3::new(6.0, 0.0, 0.0) * s,
        ),
    ]);
    let caster = RayCaster::new(mesh);
    let s = f64::from(s);
    let eye = DVec3::new(0.0, 0.0, -2.0) * s;
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let pos = position(
        "p0",
        c2w,
        vec![point_light("l", DVec3::new(0.7, 0.2, -1.5) * s)],
    );
    position_maps(&caster, &intrinsics(32, 60.0), &pos)
}

#[test]
fn maps_are_scale_invariant_from_1e_minus_3_to_1e3() {
    let unit = scaled_maps(1.0);
    for s in [1e-3f32, 1e3] {
        let m = scaled_maps(s);
        let (g, u) = (&m.geometry, &unit.geometry);
        assert_eq!(g.mask, u.mask);
        for i in 0..g.mask.data.len() {
            assert!((g.depth.data[i] / s - u.depth.data[i]).abs() < 1e-4);
            assert!((g.cos_nv.data[i] - u.cos_nv.data[i]).abs() < 1e-4);
            let (a, b) = (&m.lights[0], &unit.lights[0]);
            assert!((a.cos_nl.data[i] - b.cos_nl.data[i]).abs() < 1e-4);
            assert!((a.distance.data[i] / s - b.distance.data[i]).abs() < 1e-4);
            assert!(a.cos_vl.data[i].is_finite());
        }
        let differ = m.lights[0]
            .lit
            .data
            .iter()
            .zip(&unit.lights[0].lit.data)
            .filter(|(a, b)| a != b)
            .count();
        assert!(differ <= 2, "scale {s}: {differ} shadow pixels differ");
    }
}

mod finite {
    use super::*;
    use crate::synthetic::blob;
    use proptest::prelude::*;

    fn blob_caster() -> &'static RayCaster {
        static CASTER: OnceLock<RayCaster> = OnceLock::new();
        CASTER.get_or_init(|| {
            let mut mesh = blob(Vec3::ZERO, 0.5, 0.15, 3);
            // Some zero-length vertex normals too.
            if let Some(n) = mesh.normals.as_mut() {
                n.iter_mut().step_by(7).for_each(|v| *v = Vec3::ZERO);
            }
            RayCaster::new(mesh)
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn every_map_is_finite_for_any_pose_and_light(
            eye in prop::array::uniform3(-3.0f64..3.0),
            light in prop::array::uniform3(-1.0f64..1.0),
            k1 in -0.2f64..0.2,
        ) {
            let eye = DVec3::from(eye);
            prop_assume!(eye.length() > 0.9);
            let up = if eye.cross(DVec3::Y).length() > 1e-3 { DVec3::Y } else { DVec3::X };
            let c2w = look_at(eye, DVec3::ZERO, up);
            let mut intr = intrinsics(16, 60.0);
            intr.distortion[0] = k1;
            let pos = position("p", c2w, vec![
                point_light("free", DVec3::from(light) * 2.0),
                point_light("at_eye", eye),
                point_light("on_surface", blob_caster().mesh.positions[3].as_dvec3()),
            ]);
            let m = position_maps(blob_caster(), &intr, &pos);
            let g = &m.geometry;
            for r in [&g.position, &g.normal, &g.geometric_normal, &g.view] {
                prop_assert!(all_finite(r));
            }
            for v in g.depth.data.iter().chain(&g.cos_nv.data) {
                prop_assert!(v.is_finite());
            }
            for l in &m.lights {
                prop_assert!(all_finite(&l.direction));
                for v in l.distance.data.iter().chain(&l.cos_nl.data).chain(&l.cos_vl.data) {
                    prop_assert!(v.is_finite());
                }
                for (c, _) in l.cos_nl.data.iter().zip(&l.lit.data).filter(|(_, &lit)| lit) {
                    prop_assert!(*c > 0.0);
                }
            }
        }
    }
}
