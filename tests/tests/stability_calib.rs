//! Numerical stability of the calibration angle maps (`calib::position_maps`)
//! across the crate boundary: a whole scene (mesh, camera, lights) scaled by
//! 1e-3 to 1e3 gives the same cosines; a light exactly on the surface or
//! behind it, zero-length vertex normals and zero-area triangles give finite
//! maps in range, never NaN or Inf.

use glam::{DVec3, Vec3};
use matscan_calib::synthetic::{icosphere, intrinsics, merge, point_light, quad};
use matscan_calib::{position_maps, PixelMaps};
use matscan_scan::bvh::RayCaster;
use matscan_scan::camera::look_at;
use matscan_scan::{Mesh, Position};
use proptest::prelude::*;

const SIZE: u32 = 20;

/// Cosines of one scene at two scales agree within this. The maps store
/// unit vectors and cosines in f32 (relative rounding 6e-8) computed from
/// f32 hit points whose rounding is relative to the scene's size, so the
/// scale cancels up to a few f32 ulps of the hit point over the distance to
/// the light or camera (~1e-6); 1e-4 leaves room for a pixel whose ray
/// lands on the neighbouring triangle of the 1280-triangle sphere at
/// another scale, where interpolated normals agree to ~1e-5.
const COS_TOL: f32 = 1e-4;
/// `cos_vl` is Lipschitz with slope 1/`AZIMUTH_EPSILON` = 1e4 per radian near
/// the pole (see `calib::angles::cos_vl`), so the same 1e-7 rad of f32 noise
/// in the normal can move it by 1e-3 there; elsewhere it is as stable as the
/// other cosines.
const COS_VL_TOL: f32 = 2e-3;

fn position(camera_to_world: glam::DMat4, lights: Vec<matscan_scan::Light>) -> Position {
    Position {
        name: "p0".into(),
        camera_to_world,
        lights,
        captures: vec![],
        white_reference_mask: None,
    }
}

/// A sphere in front of a backdrop, scaled by `s`, with a camera on `dir`
/// and lights: `light` (free), one exactly on a sphere vertex, one behind the
/// backdrop.
fn scene(s: f64, dir: DVec3, light: DVec3) -> (RayCaster, Position) {
    let sf = s as f32;
    let mesh = merge(&[
        icosphere(Vec3::ZERO, 0.4 * sf, 3),
        quad(
            Vec3::new(-3.0, -3.0, 1.0) * sf,
            Vec3::new(0.0, 6.0, 0.0) * sf,
            Vec3::new(6.0, 0.0, 0.0) * sf,
        ),
    ]);
    let on_surface = mesh.positions[5].as_dvec3();
    let caster = RayCaster::new(mesh);
    let eye = dir * 2.0 * s;
    let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
    let lights = vec![
        point_light("free", light * s),
        point_light("on_surface", on_surface),
        point_light("behind", DVec3::new(0.1, 0.2, 3.0) * s),
    ];
    (caster, position(c2w, lights))
}

fn maps(caster: &RayCaster, pos: &Position) -> PixelMaps {
    position_maps(caster, &intrinsics(SIZE, 60.0), pos)
}

/// Every value finite; cosines in [-1, 1]; unit vectors unit or zero.
fn assert_sane(m: &PixelMaps) -> Result<(), TestCaseError> {
    let g = &m.geometry;
    for r in [&g.position, &g.normal, &g.geometric_normal, &g.view] {
        prop_assert!(r.data.iter().flatten().all(|v| v.is_finite()));
    }
    for (i, &hit) in g.mask.data.iter().enumerate() {
        for v in [&g.normal, &g.geometric_normal, &g.view] {
            let len = Vec3::from(v.data[i]).length();
            if hit {
                prop_assert!((len - 1.0).abs() < 1e-5, "length {len}");
            } else {
                prop_assert_eq!(len, 0.0);
            }
        }
    }
    prop_assert!(g.depth.data.iter().all(|d| d.is_finite() && *d >= 0.0));
    prop_assert!(g.cos_nv.data.iter().all(|c| (-1.0..=1.0).contains(c)));
    for l in &m.lights {
        prop_assert!(l.direction.data.iter().flatten().all(|v| v.is_finite()));
        prop_assert!(l.distance.data.iter().all(|d| d.is_finite() && *d >= 0.0));
        for c in l.cos_nl.data.iter().chain(&l.cos_vl.data) {
            prop_assert!((-1.0..=1.0).contains(c), "{} cosine {c}", l.light);
        }
        for (c, lit) in l.cos_nl.data.iter().zip(&l.lit.data) {
            if *lit {
                prop_assert!(*c > 0.0, "{} lit with cos_nl {c}", l.light);
            }
        }
    }
    Ok(())
}

fn direction() -> impl Strategy<Value = DVec3> {
    // Cameras in front of the backdrop (z < 0 side), any direction there.
    (-1.0f64..1.0, -1.0f64..1.0, 0.3f64..1.0).prop_map(|(x, y, z)| DVec3::new(x, y, -z).normalize())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn cosines_do_not_depend_on_the_scale_of_the_scene(
        dir in direction(),
        light in prop::array::uniform3(-1.5f64..1.5),
        exponent in prop_oneof![Just(-3.0f64), Just(3.0f64), -3.0f64..3.0],
    ) {
        let s = 10f64.powf(exponent);
        let light = DVec3::from(light) + DVec3::new(0.0, 0.0, -1.0);
        let (c1, p1) = scene(1.0, dir, light);
        let (cs, ps) = scene(s, dir, light);
        let (unit, scaled) = (maps(&c1, &p1), maps(&cs, &ps));
        assert_sane(&unit)?;
        assert_sane(&scaled)?;
        let (gu, gs) = (&unit.geometry, &scaled.geometry);
        let differing = gu.mask.data.iter().zip(&gs.mask.data).filter(|(a, b)| a != b).count();
        // Only float ties on silhouette edges may flip.
        prop_assert!(differing <= 2, "scale {s}: {differing} mask pixels differ");
        for i in 0..gu.mask.data.len() {
            if !(gu.mask.data[i] && gs.mask.data[i]) {
                continue;
            }
            let d = (gu.cos_nv.data[i] - gs.cos_nv.data[i]).abs();
            prop_assert!(d <= COS_TOL, "scale {s} pixel {i}: cos_nv differs by {d}");
            let rel_depth = (gs.depth.data[i] as f64 / s - gu.depth.data[i] as f64).abs();
            prop_assert!(rel_depth <= 1e-4 * gu.depth.data[i] as f64, "depth at {i}");
            for (a, b) in unit.lights.iter().zip(&scaled.lights) {
                if a.light == "on_surface" {
                    // Where the light sits on the very point a pixel sees,
                    // the direction to it is rounding noise at any scale:
                    // only sanity (checked above) is promised there.
                    continue;
                }
                let d = (a.cos_nl.data[i] - b.cos_nl.data[i]).abs();
                prop_assert!(d <= COS_TOL, "scale {s} {} pixel {i}: cos_nl differs by {d}", a.light);
                let d = (a.cos_vl.data[i] - b.cos_vl.data[i]).abs();
                prop_assert!(d <= COS_VL_TOL, "scale {s} {} pixel {i}: cos_vl differs by {d}", a.light);
            }
        }
    }

    #[test]
    fn zero_normals_and_zero_area_triangles_change_nothing_and_stay_finite(
        dir in direction(),
        every in 2usize..6,
    ) {
        let clean = icosphere(Vec3::ZERO, 0.5, 2);
        let mut broken = clean.clone();
        // Zero-length normals on every `every`-th vertex: the shading
        // normal falls back towards the face normal there, so only sanity
        // is checked for the broken mesh's normals.
        if let Some(n) = broken.normals.as_mut() {
            n.iter_mut().step_by(every).for_each(|v| *v = Vec3::ZERO);
        }
        // Zero-area triangles: a repeated vertex and three coincident ones.
        let extra: Vec<[u32; 3]> = (0..clean.triangles.len() as u32)
            .step_by(every)
            .flat_map(|t| {
                let [a, b, _] = clean.triangles[t as usize];
                [[a, a, b], [b, b, b]]
            })
            .collect();
        broken.triangles.extend(extra);
        let eye = dir * 1.6;
        let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
        let pos = position(c2w, vec![
            point_light("free", DVec3::new(0.5, -0.3, -1.2)),
            point_light("on_vertex", clean.positions[every].as_dvec3()),
        ]);
        let a = maps(&RayCaster::new(clean), &pos);
        let b = maps(&RayCaster::new(broken), &pos);
        assert_sane(&a)?;
        assert_sane(&b)?;
        // The degenerate triangles can never be hit: same mask, same
        // geometric normals, same depth.
        prop_assert_eq!(&a.geometry.mask, &b.geometry.mask);
        prop_assert_eq!(&a.geometry.geometric_normal, &b.geometry.geometric_normal);
        prop_assert_eq!(&a.geometry.depth, &b.geometry.depth);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    /// The rig's flash sits at the camera, so at the sphere's centre pixel
    /// the view and the light are both along the normal: eq. 3.4's pole.
    /// Moving the light by `d` turns its direction at a point at distance
    /// `dist` by at most `d / dist` radians; `cos_nl` has slope <= 1 in that
    /// angle and `cos_vl` slope <= 1 / AZIMUTH_EPSILON = 1e4 (the fade near
    /// the pole), so a pixel's cosines may move by at most that times the
    /// angle, plus 1e-5 for f32 rounding of the stored maps.
    #[test]
    fn cosines_move_continuously_when_a_flash_at_the_camera_moves(
        d in prop::array::uniform3(-1e-6f64..1e-6),
    ) {
        let eye = DVec3::new(0.0, 0.0, -2.0);
        let c2w = look_at(eye, DVec3::ZERO, DVec3::new(0.0, -1.0, 0.0));
        let caster = RayCaster::new(icosphere(Vec3::ZERO, 0.5, 4));
        // An odd size puts the centre pixel's ray exactly on the optical
        // axis, through the sphere's pole as seen from the flash.
        let at = |light: DVec3| {
            let pos = position(c2w, vec![point_light("flash", light)]);
            position_maps(&caster, &intrinsics(21, 60.0), &pos)
        };
        let moved = DVec3::from(d);
        let (a, b) = (at(eye), at(eye + moved));
        let (la, lb) = (&a.lights[0], &b.lights[0]);
        let centre = 10 * 21 + 10;
        prop_assert!(a.geometry.mask.data[centre]);
        prop_assert!(la.cos_nl.data[centre] > 0.999_999);
        for i in 0..la.cos_nl.data.len() {
            if !a.geometry.mask.data[i] {
                continue;
            }
            let angle = moved.length() / f64::from(la.distance.data[i]);
            let nl = (la.cos_nl.data[i] - lb.cos_nl.data[i]).abs() as f64;
            let vl = (la.cos_vl.data[i] - lb.cos_vl.data[i]).abs() as f64;
            prop_assert!(nl <= angle + 1e-5, "pixel {i}: cos_nl moved {nl} for {angle} rad");
            prop_assert!(
                vl <= angle / matscan_calib::angles::AZIMUTH_EPSILON + 1e-5,
                "pixel {i}: cos_vl moved {vl} for {angle} rad"
            );
        }
    }
}

#[test]
fn a_mesh_of_only_zero_area_triangles_gives_an_empty_finite_map() {
    let p = Vec3::new(0.1, 0.2, 0.3);
    let mesh = Mesh {
        positions: vec![p, p, p + Vec3::X],
        normals: Some(vec![Vec3::ZERO; 3]),
        uvs: None,
        triangles: vec![[0, 1, 2], [0, 0, 0], [2, 2, 1]],
    };
    let c2w = look_at(
        DVec3::new(0.0, 0.0, -2.0),
        DVec3::ZERO,
        DVec3::new(0.0, -1.0, 0.0),
    );
    let pos = position(c2w, vec![point_light("l", p.as_dvec3())]);
    let m = maps(&RayCaster::new(mesh), &pos);
    assert_eq!(m.geometry.object_pixels(), 0);
    assert!(m.geometry.depth.data.iter().all(|d| *d == 0.0));
    assert!(m.lights[0]
        .cos_nl
        .data
        .iter()
        .chain(&m.lights[0].cos_vl.data)
        .all(|c| *c == 0.0));
}

#[test]
fn a_light_on_the_surface_plane_gives_zero_cos_nl_and_no_light() {
    // A flat backdrop facing the camera, the light in its plane.
    let mesh = quad(
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 4.0, 0.0),
    );
    let c2w = look_at(
        DVec3::new(0.0, 0.0, -2.0),
        DVec3::ZERO,
        DVec3::new(0.0, -1.0, 0.0),
    );
    let pos = position(
        c2w,
        vec![
            point_light("in_plane", DVec3::new(0.3, 0.1, 0.0)),
            point_light("far_in_plane", DVec3::new(1e6, 0.0, 0.0)),
        ],
    );
    let m = maps(&RayCaster::new(mesh), &pos);
    assert_eq!(m.geometry.object_pixels(), (SIZE * SIZE) as usize);
    for l in &m.lights {
        assert!(l.lit.data.iter().all(|lit| !lit), "{}", l.light);
        for c in &l.cos_nl.data {
            assert!(c.abs() < 1e-6, "{}: cos_nl {c}", l.light);
        }
        assert!(l.cos_vl.data.iter().all(|c| (-1.0..=1.0).contains(c)));
    }
}
