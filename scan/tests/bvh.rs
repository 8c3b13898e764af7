//! The BVH against brute force, watertightness on closed meshes, robust
//! offsets across scene scales, and degenerate input.

use glam::{Vec2, Vec3};
use matscan_scan::bvh::{intersect_triangle, offset_origin, Bvh, Hit, Ray, RayCaster};
use matscan_scan::Mesh;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn rng(seed: u64) -> Pcg64 {
    Pcg64::seed_from_u64(seed)
}

fn unit_vector(rng: &mut Pcg64) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if (1e-4..=1.0).contains(&v.length_squared()) {
            return v.normalize();
        }
    }
}

/// Closest hit over every triangle with the same triangle test the BVH uses.
fn brute_force(mesh: &Mesh, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let mut r = *ray;
    for t in 0..mesh.triangle_count() as u32 {
        if let Some((t_hit, u, v)) = intersect_triangle(&r, &mesh.triangle_vertices(t)) {
            r.t_max = t_hit;
            best = Some(Hit {
                t: t_hit,
                triangle: t,
                u,
                v,
            });
        }
    }
    best
}

/// Triangles of all sizes and orientations, some degenerate (a repeated
/// vertex, collinear vertices), some sharing vertices.
fn random_soup(rng: &mut Pcg64, count: usize) -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..count {
        let centre = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let size = 10f32.powf(rng.gen_range(-3.0..-0.3));
        let base = positions.len() as u32;
        let a = centre + unit_vector(rng) * size;
        let b = centre + unit_vector(rng) * size;
        let c = match i % 17 {
            0 => a,                  // repeated vertex
            1 => a + (b - a) * 0.25, // collinear
            _ => centre + unit_vector(rng) * size,
        };
        positions.extend([a, b, c]);
        triangles.push([base, base + 1, base + 2]);
        if i % 5 == 0 && base >= 3 {
            // Shares an edge with the previous triangle.
            positions.push(centre + unit_vector(rng) * size);
            triangles.push([base - 3, base - 2, base + 3]);
        }
    }
    Mesh {
        positions,
        normals: None,
        uvs: None,
        triangles,
    }
}

/// Rays of every kind: random, axis-aligned (zero direction components),
/// starting on box planes, with finite and offset ranges.
fn random_rays(rng: &mut Pcg64, mesh: &Mesh, count: usize) -> Vec<Ray> {
    (0..count)
        .map(|i| {
            let origin = Vec3::new(
                rng.gen_range(-1.6..1.6),
                rng.gen_range(-1.6..1.6),
                rng.gen_range(-1.6..1.6),
            );
            let dir = match i % 7 {
                0 => [Vec3::X, Vec3::NEG_Y, Vec3::Z][i % 3],
                1 => {
                    let target = mesh.positions[rng.gen_range(0..mesh.positions.len())];
                    (target - origin).try_normalize().unwrap_or(Vec3::X)
                }
                _ => unit_vector(rng),
            };
            let origin = if i % 11 == 0 {
                // On the plane of a vertex coordinate (a leaf box face).
                let p = mesh.positions[rng.gen_range(0..mesh.positions.len())];
                Vec3::new(p.x, origin.y, origin.z)
            } else {
                origin
            };
            match i % 5 {
                0 => Ray::segment(origin, dir, 0.5, 2.0),
                1 => Ray::segment(origin, dir, 0.0, rng.gen_range(0.1..3.0)),
                _ => Ray::new(origin, dir),
            }
        })
        .collect()
}

fn assert_same_hit(mesh: &Mesh, bvh: &Bvh, ray: &Ray) {
    let expected = brute_force(mesh, ray);
    let got = bvh.intersect(ray);
    match (got, expected) {
        (None, None) => {}
        (Some(g), Some(e)) => {
            assert!(
                (g.t - e.t).abs() <= 1e-5 * e.t.abs().max(1e-6),
                "t {} != brute force {} for {ray:?}",
                g.t,
                e.t
            );
            if g.triangle != e.triangle {
                // Only a tie may pick another triangle: the brute-force test
                // of the BVH's triangle must give the same distance.
                let (t_other, _, _) = intersect_triangle(ray, &mesh.triangle_vertices(g.triangle))
                    .expect("the BVH's triangle is hit");
                assert_eq!(t_other, e.t, "not a tie for {ray:?}");
            } else {
                assert_eq!((g.u, g.v), (e.u, e.v));
            }
        }
        _ => panic!("BVH {got:?} but brute force {expected:?} for {ray:?}"),
    }
    assert_eq!(
        bvh.occluded(ray),
        expected.is_some(),
        "occluded for {ray:?}"
    );
}

#[test]
fn bvh_closest_hits_equal_brute_force_on_random_soups() {
    let mut rng = rng(1);
    let mut hits = 0;
    for (seed, count) in [(0, 1), (1, 2), (2, 5), (3, 40), (4, 700), (5, 3000)] {
        let mesh = random_soup(&mut rng, count);
        let bvh = Bvh::build(&mesh);
        for ray in random_rays(&mut rng, &mesh, 1500) {
            assert_same_hit(&mesh, &bvh, &ray);
            hits += usize::from(bvh.intersect(&ray).is_some());
        }
        let _ = seed;
    }
    assert!(hits > 1000, "too few hits ({hits}) to prove anything");
}

/// UV sphere: rings of isosceles trapezoids (planar quads) and pole fans,
/// so the mesh is a convex polyhedron.
fn uv_sphere(centre: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut positions = vec![centre + Vec3::Z * radius];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let d = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            positions.push(centre + d * radius);
        }
    }
    positions.push(centre - Vec3::Z * radius);
    let bottom = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        triangles.push([bottom, ring(rings - 1, s + 1), ring(rings - 1, s)]);
        for r in 1..rings - 1 {
            triangles.push([ring(r, s), ring(r + 1, s), ring(r + 1, s + 1)]);
            triangles.push([ring(r, s), ring(r + 1, s + 1), ring(r, s + 1)]);
        }
    }
    let mut mesh = Mesh {
        positions,
        normals: None,
        uvs: None,
        triangles,
    };
    mesh.compute_vertex_normals();
    mesh
}

#[test]
fn bvh_closest_hits_equal_brute_force_on_a_sphere() {
    let mut rng = rng(2);
    let mesh = uv_sphere(Vec3::new(0.1, -0.2, 0.05), 1.0, 40, 64);
    let bvh = Bvh::build(&mesh);
    let mut hits = 0;
    for ray in random_rays(&mut rng, &mesh, 3000) {
        assert_same_hit(&mesh, &bvh, &ray);
        hits += usize::from(bvh.intersect(&ray).is_some());
    }
    assert!(hits > 600, "too few hits ({hits})");
}

#[test]
fn triangle_test_matches_a_double_precision_reference() {
    let mut rng = rng(3);
    let mut checked = 0;
    for _ in 0..20_000 {
        let tri = [0; 3].map(|_| unit_vector(&mut rng) * rng.gen_range(0.1..2.0));
        let origin = unit_vector(&mut rng) * 3.0;
        let target = tri[0] * 0.3 + tri[1] * 0.3 + tri[2] * 0.4 + unit_vector(&mut rng) * 0.3;
        let ray = Ray::new(origin, (target - origin).normalize());
        let reference = moller_trumbore_f64(&ray, &tri);
        let got = intersect_triangle(&ray, &tri);
        match (got, reference) {
            (Some((t, u, v)), Some((rt, ru, rv, margin))) => {
                // t and the barycentrics are ill-conditioned at grazing
                // incidence: the tolerance grows with 1 / sin(elevation).
                let [a, b, c] = tri.map(|p| p.as_dvec3());
                let sin = (b - a)
                    .cross(c - a)
                    .normalize()
                    .dot(ray.dir.as_dvec3())
                    .abs();
                let tol = 2e-6 / sin.max(1e-3);
                assert!((f64::from(t) - rt).abs() <= tol * rt, "t {t} vs {rt}");
                assert!((f64::from(u) - ru).abs() < 10.0 * tol);
                assert!((f64::from(v) - rv).abs() < 10.0 * tol);
                checked += usize::from(margin > 1e-4);
            }
            (None, None) => {}
            (Some(_), None) | (None, Some(_)) => {
                // Only rays that pass within rounding of an edge may differ.
                let margin = reference.map_or_else(|| edge_margin(&ray, &tri), |r| r.3);
                assert!(
                    margin < 1e-5,
                    "disagreement {got:?} vs {reference:?}, margin {margin}"
                );
            }
        }
    }
    assert!(checked > 3000, "too few hits ({checked})");
}

/// Möller–Trumbore in f64: (t, u, v, smallest barycentric).
fn moller_trumbore_f64(ray: &Ray, tri: &[Vec3; 3]) -> Option<(f64, f64, f64, f64)> {
    let [a, b, c] = tri.map(|p| p.as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    let margin = u.min(v).min(1.0 - u - v);
    (margin >= 0.0 && t > f64::from(ray.t_min) && t < f64::from(ray.t_max))
        .then_some((t, u, v, margin))
}

/// How far outside the triangle (in barycentrics) the ray passes.
fn edge_margin(ray: &Ray, tri: &[Vec3; 3]) -> f64 {
    let [a, b, c] = tri.map(|p| p.as_dvec3());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let s = o - a;
    let u = s.dot(p) / det;
    let v = d.dot(s.cross(e1)) / det;
    u.min(v).min(1.0 - u - v).abs()
}

#[test]
fn rays_through_shared_edges_and_vertices_of_a_closed_mesh_always_hit() {
    for (centre, radius) in [
        (Vec3::ZERO, 1.0),
        (Vec3::splat(1e-3), 1e-3),
        (Vec3::new(700.0, -300.0, 200.0), 1e3),
        (Vec3::new(0.3, 0.1, -0.2), 0.05),
    ] {
        let mesh = uv_sphere(centre, radius, 24, 36);
        let bvh = Bvh::build(&mesh);
        let inside = centre + Vec3::new(0.11, -0.07, 0.05) * radius;
        let mut targets: Vec<Vec3> = mesh.positions.clone();
        for tri in &mesh.triangles {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            targets.extend([(a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]);
        }
        for target in targets {
            let ray = Ray::new(inside, (target - inside).normalize());
            let hit = bvh.intersect(&ray);
            assert!(
                hit.is_some(),
                "ray through {target} escaped (scale {radius})"
            );
            let t = hit.map(|h| h.t).unwrap_or(0.0);
            let expected = (target - inside).length();
            assert!(
                (t - expected).abs() < 1e-3 * expected,
                "t {t} vs {expected}"
            );
        }
    }
}

#[test]
fn hit_points_lie_on_the_ray_and_surface_data_is_consistent() {
    let mut rng = rng(4);
    let mut mesh = uv_sphere(Vec3::ZERO, 1.0, 30, 40);
    mesh.uvs = Some(
        mesh.positions
            .iter()
            .map(|p| Vec2::new(p.x * 0.5 + 0.5, p.z * 0.5 + 0.5))
            .collect(),
    );
    let caster = RayCaster::new(mesh);
    let mut hits = 0;
    for _ in 0..2000 {
        let origin = unit_vector(&mut rng) * 3.0;
        let ray = Ray::new(origin, (unit_vector(&mut rng) * 0.8 - origin).normalize());
        let Some((hit, surface)) = caster.closest(&ray) else {
            continue;
        };
        hits += 1;
        assert!((ray.at(hit.t) - surface.position).length() < 1e-5);
        assert!((surface.position.length() - 1.0).abs() < 0.01);
        // Outward geometric normal (counter-clockwise winding), unit shading
        // normal close to the sphere normal, interpolated uv.
        assert!(surface.geometric_normal.dot(surface.position) > 0.99);
        assert!((surface.shading_normal.length() - 1.0).abs() < 1e-5);
        assert!(surface.shading_normal.dot(surface.position.normalize()) > 0.999);
        let uv = surface.uv.expect("mesh has uvs");
        assert!((uv.x - (surface.position.x * 0.5 + 0.5)).abs() < 1e-4);
        assert!(hit.u >= 0.0 && hit.v >= 0.0 && hit.u + hit.v <= 1.0);
    }
    assert!(hits > 1000);
}

#[test]
fn offset_rays_leaving_a_convex_surface_never_hit_it_at_any_scale() {
    let mut rng = rng(5);
    for (centre, radius) in [
        (Vec3::ZERO, 1e-3),
        (Vec3::new(2e-3, -1e-3, 0.0), 1e-3),
        (Vec3::ZERO, 1.0),
        (Vec3::new(0.5, 0.2, -1.5), 0.1),
        (Vec3::ZERO, 1e3),
        (Vec3::new(1e3, 5e2, -2e3), 1e2),
    ] {
        let caster = RayCaster::new(uv_sphere(centre, radius, 48, 64));
        let mut grazing = 0;
        for i in 0..3000 {
            let origin = centre + unit_vector(&mut rng) * (3.0 * radius);
            let ray = Ray::new(origin, (centre - origin).normalize());
            let Some((_, s)) = caster.closest(&ray) else {
                continue;
            };
            let n = s.geometric_normal;
            // Outward: any direction in the normal's hemisphere, some grazing.
            let mut d = unit_vector(&mut rng);
            if d.dot(n) < 0.0 {
                d = -d;
            }
            if i % 3 == 0 {
                d = (d - n * d.dot(n)).normalize() + n * 1e-3;
                grazing += 1;
            }
            let d = d.normalize();
            let out = if i % 2 == 0 && centre == Vec3::ZERO && radius <= 1.0 {
                offset_origin(s.position, n)
            } else {
                caster.offset(s.position, n)
            };
            let escaping = caster.bvh.intersect(&Ray::new(out, d));
            assert!(
                escaping.is_none(),
                "outward ray re-hit {escaping:?} at scale {radius}"
            );
            // Inward from just below the surface: reaches the far side.
            let inner = caster.offset(s.position, -n);
            let back = caster.bvh.intersect(&Ray::new(inner, -n));
            let t = back.map_or(0.0, |h| h.t);
            assert!(
                t > 1.5 * radius,
                "inward ray stopped at {t} at scale {radius}"
            );
        }
        assert!(grazing > 500);
    }
}

#[test]
fn scene_scaled_offsets_clear_large_triangles_near_the_world_origin() {
    let mut rng = rng(9);
    // A 2000 x 2000 ground quad through the origin: hit points near the
    // origin carry errors of the vertices' magnitude, not of |p|.
    let ground = Mesh {
        positions: vec![
            Vec3::new(-1e3, 0.0, -1e3),
            Vec3::new(1e3, 0.0, -1e3),
            Vec3::new(1e3, 0.0, 1e3),
            Vec3::new(-1e3, 0.0, 1e3),
        ],
        normals: None,
        uvs: None,
        triangles: vec![[0, 2, 1], [0, 3, 2]],
    };
    let caster = RayCaster::new(ground);
    for _ in 0..2000 {
        let target = Vec3::new(rng.gen_range(-1e-2..1e-2), 0.0, rng.gen_range(-1e-2..1e-2));
        let origin = Vec3::new(0.0, 5.0, 0.0) + unit_vector(&mut rng) * 2.0;
        let Some((_, s)) = caster.closest(&Ray::new(origin, (target - origin).normalize())) else {
            panic!("ray at the ground near {target} missed");
        };
        let n = Vec3::Y;
        let mut d = unit_vector(&mut rng);
        if d.dot(n) < 0.0 {
            d = -d;
        }
        let d = (d + n * 1e-3).normalize();
        let out = caster.offset(s.position, n);
        assert_eq!(caster.bvh.intersect(&Ray::new(out, d)), None, "from {out}");
        assert!(caster.visible(s.position, s.position + n * 10.0));
    }
}

#[test]
fn visibility_between_surface_points_respects_occluders() {
    let mut rng = rng(6);
    let caster = RayCaster::new(uv_sphere(Vec3::ZERO, 1.0, 32, 48));
    for _ in 0..500 {
        // Two points on the sphere see each other through its inside, and
        // a point outside is hidden from the far side.
        let hit = |rng: &mut Pcg64| {
            let o = unit_vector(rng) * 3.0;
            caster
                .closest(&Ray::new(o, -o.normalize()))
                .map(|(_, s)| s.position)
                .expect("ray at the centre hits")
        };
        let (p, q) = (hit(&mut rng), hit(&mut rng));
        // A chord well inside (not grazing along a facet, where "visible"
        // is ambiguous) is not blocked by the surface at its ends.
        if p.dot(q) < 0.4f32.cos() {
            assert!(caster.visible(p, q), "chord {p} -> {q} blocked");
            assert!(caster.visible(q, p));
        }
        let outside = p * 2.0;
        assert!(caster.visible(p, outside));
        assert!(!caster.visible(-p, outside), "the sphere hides {outside}");
    }
    assert!(caster.visible(Vec3::ONE, Vec3::ONE));
    assert!(!caster.visible(Vec3::NAN, Vec3::ONE));
}

#[test]
fn rays_in_or_parallel_to_a_triangle_plane_miss_without_nan() {
    let mesh = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2]],
    };
    let bvh = Bvh::build(&mesh);
    for ray in [
        Ray::new(Vec3::new(-1.0, 0.2, 0.0), Vec3::X),
        Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X),
        Ray::new(Vec3::new(-1.0, 0.2, 1e-3), Vec3::X),
        Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::Y),
    ] {
        assert_eq!(bvh.intersect(&ray), None, "{ray:?}");
        assert!(!bvh.occluded(&ray));
    }
    // Axis-aligned ray through the plane: a hit with exact barycentrics.
    let hit = bvh
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::Z))
        .expect("perpendicular ray hits");
    assert_eq!((hit.t, hit.u, hit.v), (2.0, 0.25, 0.5));
    // From the other side too (two-sided).
    let back = bvh
        .intersect(&Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::NEG_Z))
        .expect("two-sided");
    assert_eq!(back.t, 2.0);
}

#[test]
fn rays_starting_on_a_surface_give_finite_results() {
    let mut rng = rng(7);
    let caster = RayCaster::new(uv_sphere(Vec3::ZERO, 1.0, 24, 32));
    for _ in 0..2000 {
        let o = unit_vector(&mut rng) * 2.0;
        let Some((_, s)) = caster.closest(&Ray::new(o, -o.normalize())) else {
            continue;
        };
        // No offset: the own triangle may or may not be hit at t ~ 0, but
        // whatever comes back is finite and in range.
        let ray = Ray::new(s.position, unit_vector(&mut rng));
        if let Some(h) = caster.bvh.intersect(&ray) {
            assert!(h.t.is_finite() && h.t > 0.0 && h.u.is_finite() && h.v.is_finite());
        }
    }
}

#[test]
fn empty_degenerate_and_invalid_input_is_handled() {
    let ray = Ray::new(Vec3::new(0.1, 0.1, -1.0), Vec3::Z);
    let empty = Bvh::build(&Mesh::default());
    assert_eq!(empty.bounds(), None);
    assert_eq!(empty.intersect(&ray), None);
    assert!(!empty.occluded(&ray));

    let degenerate = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::NAN],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2], [0, 0, 0], [0, 1, 3], [0, 1, 99]],
    };
    let bvh = Bvh::build(&degenerate);
    assert_eq!(bvh.bounds(), None);
    assert_eq!(
        bvh.intersect(&Ray::new(Vec3::new(0.5, -1.0, 0.0), Vec3::Y)),
        None
    );

    let mesh = uv_sphere(Vec3::ZERO, 1.0, 8, 8);
    let bvh = Bvh::build(&mesh);
    let (lo, hi) = bvh.bounds().expect("bounds");
    assert!((lo + Vec3::ONE).abs().max_element() < 1e-6);
    assert!((hi - Vec3::ONE).abs().max_element() < 1e-6);
    for bad in [
        Ray::new(Vec3::NAN, Vec3::Z),
        Ray::new(Vec3::new(0.0, 0.0, -3.0), Vec3::ZERO),
        Ray::new(Vec3::new(0.0, 0.0, -3.0), Vec3::new(f32::NAN, 0.0, 1.0)),
        Ray::new(
            Vec3::new(0.0, 0.0, -3.0),
            Vec3::new(f32::INFINITY, 0.0, 1.0),
        ),
        Ray::segment(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, f32::NAN, 10.0),
        Ray::segment(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, 5.0, 1.0),
    ] {
        assert_eq!(bvh.intersect(&bad), None, "{bad:?}");
        assert!(!bvh.occluded(&bad), "{bad:?}");
    }
    assert_eq!(offset_origin(Vec3::ONE, Vec3::ZERO), Vec3::ONE);
    assert_eq!(offset_origin(Vec3::ONE, Vec3::NAN), Vec3::ONE);
}

#[test]
fn pathological_triangle_distributions_build_and_match_brute_force() {
    let mut rng = rng(8);
    // 3000 copies of one triangle (no split separates them), and triangles
    // at exponentially shrinking positions (deep SAH trees).
    let copies = Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: None,
        uvs: None,
        triangles: vec![[0, 1, 2]; 3000],
    };
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..2000u32 {
        let x = 0.97f32.powi(i as i32);
        positions.extend([
            Vec3::new(x, 0.0, 0.0),
            Vec3::new(x, 1.0, 0.0),
            Vec3::new(x, 0.0, 1.0),
        ]);
        triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let deep = Mesh {
        positions,
        normals: None,
        uvs: None,
        triangles,
    };
    // A row of equal, axis-aligned triangles: every pair of neighbours has
    // the same merge cost (ties).
    let row = Mesh {
        positions: (0..2000)
            .flat_map(|i| {
                let x = i as f32 * 1e-3;
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 1e-3, 0.0, 0.0),
                    Vec3::new(x, 1.0, 0.0),
                ]
            })
            .collect(),
        normals: None,
        uvs: None,
        triangles: (0..2000).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
    };
    for (mesh, probe) in [
        (copies, Ray::new(Vec3::new(0.1, 0.1, -1.0), Vec3::Z)),
        (deep, Ray::new(Vec3::new(-1.0, 0.1, 0.1), Vec3::X)),
        (row, Ray::new(Vec3::new(0.5, 0.2, -1.0), Vec3::Z)),
    ] {
        let bvh = Bvh::build(&mesh);
        for ray in random_rays(&mut rng, &mesh, 400) {
            assert_same_hit(&mesh, &bvh, &ray);
        }
        assert_same_hit(&mesh, &bvh, &probe);
        assert!(bvh.intersect(&probe).is_some());
    }
}

#[test]
fn hits_closer_than_any_fixed_epsilon_are_found() {
    // A sphere of radius 1e-5: every hit is at t < 1e-4, where a traversal
    // with a fixed minimum distance (obvhs's own box test uses 1e-4) would
    // cull every box.
    let mut rng = rng(10);
    let mesh = uv_sphere(Vec3::splat(1e-5), 1e-5, 16, 24);
    let bvh = Bvh::build(&mesh);
    let mut hits = 0;
    for _ in 0..1000 {
        let origin = Vec3::splat(1e-5) + unit_vector(&mut rng) * 3e-5;
        let target = Vec3::splat(1e-5) + unit_vector(&mut rng) * 0.5e-5;
        let ray = Ray::new(origin, (target - origin).normalize());
        assert_same_hit(&mesh, &bvh, &ray);
        hits += usize::from(bvh.intersect(&ray).is_some_and(|h| h.t < 1e-4));
    }
    assert!(hits > 900, "too few hits ({hits})");
}
