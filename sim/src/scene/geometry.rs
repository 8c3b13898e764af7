//! Procedural object meshes with UVs (thesis section 3.1.3), and the
//! preparation of a user's mesh for the simulator.
//!
//! Generated shapes: a UV sphere, a torus, a superquadric with random
//! exponents, a blob (a sphere with low-frequency radial noise) and "leaves"
//! (several thin curved sheets, randomly arranged, for transmission): the
//! thesis's families, among which scenes without a named geometry pick
//! ([`GeometryKind::PICKED`]). Four more families resemble scanned objects
//! and are kept for held-out evaluation: a vase (a surface of revolution
//! with a neck and bevelled rims), a bevelled box or can (flat faces,
//! rounded edges), a rock (lumps cut by flat facets, fine relief) and a
//! figurine (a union of round lobes with concave, self-shadowing creases).
//! Each is
//! built at unit size, displaced along its normals by a random height map
//! (thesis 3.1.3.1: magnitude 0.005 to 0.015 of the object size), scaled per
//! axis, rotated and moved at random, and finally fitted so that it stays
//! inside the 1 x 1 x 1 box around the origin with a small margin.
//!
//! Topology: every generated mesh is closed and consistently oriented
//! (counter-clockwise seen from outside). Vertices are split where the UVs
//! jump (the u = 0 / u = 1 seams, the sphere's poles), but split copies have
//! bit-identical positions, and displacement and normals are computed on the
//! welded vertex, so the surface has no cracks and no shading seam. Leaves are
//! thin closed slabs (two offset sheets joined by a rim), not single-sided
//! sheets, so that transmission and subsurface random walks always find an
//! exit.
//!
//! Displacement UVs: the thesis moves, rotates and scales (by 1 to 4) the UVs
//! of the height map. We restrict the rotation to quarter turns and the scale
//! to integers, the transforms that keep a tileable map continuous across the
//! mesh's UV seams.
//!
//! Boundaries: geometry only. Materials are `super::kinds`' job; the renderer
//! builds its own acceleration structure from the [`Mesh`].

use super::maps::displacement_map;
use super::model::{SceneError, Texture};
use super::noise::{fbm3, hash64};
use glam::{Affine3A, DVec3, Mat3, Quat, Vec2, Vec3};
use matscan_scan::Mesh;
use rand::Rng;
use rand_pcg::Pcg64;
use std::collections::HashMap;
use std::f32::consts::{PI, TAU};
use std::fmt;
use std::str::FromStr;

/// Half the side of the box every object stays in (the thesis's unit box).
pub const BOX_HALF: f32 = 0.5;
/// Distance kept from the box faces.
const BOX_MARGIN: f32 = 0.01;
/// Thickness of a leaf slab, in box units.
pub const LEAF_THICKNESS: f32 = 0.006;
/// Resolution of the displacement height map.
const DISPLACEMENT_MAP_SIZE: u32 = 64;

/// The procedural shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GeometryKind {
    Sphere,
    Torus,
    Superquadric,
    Blob,
    Leaves,
    Vase,
    Box,
    Rock,
    Figurine,
}

impl GeometryKind {
    pub const ALL: [GeometryKind; 9] = [
        GeometryKind::Sphere,
        GeometryKind::Torus,
        GeometryKind::Superquadric,
        GeometryKind::Blob,
        GeometryKind::Leaves,
        GeometryKind::Vase,
        GeometryKind::Box,
        GeometryKind::Rock,
        GeometryKind::Figurine,
    ];

    /// The families a scene without a named geometry picks among: the
    /// thesis's five. The others stay out of every random draw, so sets
    /// that name no geometry never contain a held-out family.
    pub const PICKED: [GeometryKind; 5] = [
        GeometryKind::Sphere,
        GeometryKind::Torus,
        GeometryKind::Superquadric,
        GeometryKind::Blob,
        GeometryKind::Leaves,
    ];

    pub fn name(self) -> &'static str {
        match self {
            GeometryKind::Sphere => "sphere",
            GeometryKind::Torus => "torus",
            GeometryKind::Superquadric => "superquadric",
            GeometryKind::Blob => "blob",
            GeometryKind::Leaves => "leaves",
            GeometryKind::Vase => "vase",
            GeometryKind::Box => "box",
            GeometryKind::Rock => "rock",
            GeometryKind::Figurine => "figurine",
        }
    }
}

impl fmt::Display for GeometryKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for GeometryKind {
    type Err = SceneError;

    fn from_str(s: &str) -> Result<Self, SceneError> {
        GeometryKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| SceneError::UnknownGeometry {
                name: s.to_string(),
                expected: GeometryKind::ALL.map(GeometryKind::name).join(", "),
            })
    }
}

/// How a procedural mesh is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeometryOptions {
    /// Segments around the longest loop (clamped to 16..=1024). The default
    /// 256 gives 25k to 66k triangles (leaves: 3 to 6 slabs of about 8.5k
    /// each), smooth at 256 x 256 pixels.
    pub segments: u32,
    /// Random displacement along the normals (thesis 3.1.3.1).
    pub displacement: bool,
    /// Random per-axis scale, rotation and translation; without it the
    /// object is only centred and scaled to fit.
    pub random_placement: bool,
}

impl Default for GeometryOptions {
    fn default() -> Self {
        GeometryOptions {
            segments: 256,
            displacement: true,
            random_placement: true,
        }
    }
}

/// A random procedural mesh of `kind`, inside the unit box, with unit vertex
/// normals and UVs in [0, 1].
pub fn generate_mesh(kind: GeometryKind, rng: &mut Pcg64, options: &GeometryOptions) -> Mesh {
    let segments = options.segments.clamp(16, 1024);
    let displacement = options.displacement.then(|| Displacement::random(rng));
    if kind == GeometryKind::Leaves {
        return leaves(
            rng,
            segments,
            displacement.as_ref(),
            options.random_placement,
        );
    }
    let mut shell = match kind {
        GeometryKind::Sphere => sphere(segments),
        GeometryKind::Torus => torus(rng, segments),
        GeometryKind::Superquadric => superquadric(rng, segments),
        GeometryKind::Vase => vase(rng, segments),
        GeometryKind::Box => bevelled(rng, segments),
        GeometryKind::Rock => rock(rng, segments),
        GeometryKind::Figurine => figurine(rng, segments),
        GeometryKind::Blob | GeometryKind::Leaves => blob(rng, segments),
    };
    if let Some(d) = &displacement {
        shell.displace(d);
    }
    let placement = placement(rng, &shell.positions, options.random_placement);
    shell.transform(&placement);
    shell.orient_outward();
    shell.into_mesh()
}

/// A random height field on the UVs: `(2 h - 1) * magnitude` along the
/// normal, so white pushes out and black pulls in, as in the thesis.
#[derive(Debug, Clone, PartialEq)]
pub struct Displacement {
    map: Texture<f32>,
    scale: u32,
    quarter_turns: u32,
    offset: Vec2,
    magnitude: f32,
}

impl Displacement {
    pub fn random(rng: &mut Pcg64) -> Self {
        Displacement {
            map: Texture::Map(displacement_map(rng, DISPLACEMENT_MAP_SIZE)),
            scale: rng.gen_range(1..=4),
            quarter_turns: rng.gen_range(0..4),
            offset: Vec2::new(rng.gen(), rng.gen()),
            magnitude: rng.gen_range(0.005..=0.015),
        }
    }

    /// Signed height at `uv`, in units of the object size.
    pub fn height(&self, uv: Vec2) -> f32 {
        let r = match self.quarter_turns % 4 {
            0 => uv,
            1 => Vec2::new(-uv.y, uv.x),
            2 => -uv,
            _ => Vec2::new(uv.y, -uv.x),
        };
        let q = r * self.scale as f32 + self.offset;
        (2.0 * self.map.sample(q) - 1.0) * self.magnitude
    }

    pub fn magnitude(&self) -> f32 {
        self.magnitude
    }
}

/// A triangle mesh under construction, with each vertex's welded
/// (position-identical) representative.
#[derive(Debug, Clone, Default)]
struct Shell {
    positions: Vec<Vec3>,
    uvs: Vec<Vec2>,
    triangles: Vec<[u32; 3]>,
    /// `canon[i]`: the first vertex with exactly `positions[i]`.
    canon: Vec<u32>,
}

/// Bits of a position, with -0.0 folded into +0.0 so both weld.
fn position_key(p: Vec3) -> [u32; 3] {
    [
        (p.x + 0.0).to_bits(),
        (p.y + 0.0).to_bits(),
        (p.z + 0.0).to_bits(),
    ]
}

fn weld(positions: &[Vec3]) -> Vec<u32> {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(positions.len());
    positions
        .iter()
        .enumerate()
        .map(|(i, &p)| *first.entry(position_key(p)).or_insert(i as u32))
        .collect()
}

impl Shell {
    /// A `(nu + 1) x (nv + 1)` vertex grid; `point(i, j)` must return
    /// bit-identical positions wherever the surface closes on itself (so
    /// callers wrap `i % nu` and special-case poles). UV = (i / nu, 1 - j / nv).
    /// Triangles that collapse after welding (at poles) are left out.
    fn from_grid(nu: u32, nv: u32, point: impl Fn(u32, u32) -> Vec3) -> Shell {
        let mut positions = Vec::with_capacity(((nu + 1) * (nv + 1)) as usize);
        let mut uvs = Vec::with_capacity(positions.capacity());
        for j in 0..=nv {
            for i in 0..=nu {
                positions.push(point(i, j));
                uvs.push(Vec2::new(i as f32 / nu as f32, 1.0 - j as f32 / nv as f32));
            }
        }
        let canon = weld(&positions);
        let index = |i: u32, j: u32| j * (nu + 1) + i;
        let mut triangles = Vec::with_capacity((2 * nu * nv) as usize);
        for j in 0..nv {
            for i in 0..nu {
                let (a, b) = (index(i, j), index(i + 1, j));
                let (c, d) = (index(i + 1, j + 1), index(i, j + 1));
                for t in [[a, b, c], [a, c, d]] {
                    let [x, y, z] = t.map(|v| canon[v as usize]);
                    if x != y && y != z && x != z {
                        triangles.push(t);
                    }
                }
            }
        }
        Shell {
            positions,
            uvs,
            triangles,
            canon,
        }
    }

    /// Area-weighted normals accumulated on welded vertices, so split copies
    /// share one normal.
    fn welded_normals(&self) -> Vec<Vec3> {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            for &i in t {
                acc[self.canon[i as usize] as usize] += n;
            }
        }
        self.canon
            .iter()
            .map(|&c| acc[c as usize].try_normalize().unwrap_or(Vec3::Y))
            .collect()
    }

    fn displace(&mut self, d: &Displacement) {
        let normals = self.welded_normals();
        let moved: Vec<Vec3> = (0..self.positions.len())
            .map(|i| {
                let c = self.canon[i] as usize;
                if c == i {
                    self.positions[i] + normals[i] * d.height(self.uvs[i])
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        for i in 0..self.positions.len() {
            self.positions[i] = moved[self.canon[i] as usize];
        }
    }

    fn transform(&mut self, t: &Affine3A) {
        for p in &mut self.positions {
            *p = t.transform_point3(*p);
        }
    }

    /// Six times the signed volume enclosed (positive when the triangles
    /// face outward).
    fn signed_volume6(&self, triangles: &[[u32; 3]]) -> f64 {
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize].as_dvec3());
                a.dot(b.cross(c))
            })
            .sum()
    }

    fn orient_outward(&mut self) {
        if self.signed_volume6(&self.triangles) < 0.0 {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
    }

    /// Appends `other`, re-indexing its triangles and welds.
    fn append(&mut self, other: Shell) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.uvs.extend(other.uvs);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
        self.canon.extend(other.canon.iter().map(|&c| c + base));
    }

    fn into_mesh(self) -> Mesh {
        let normals = self.welded_normals();
        Mesh {
            positions: self.positions,
            normals: Some(normals),
            uvs: Some(self.uvs),
            triangles: self.triangles,
        }
    }
}

/// Unit direction of grid vertex (i, j) on a latitude-longitude sphere with
/// +Y at j = 0; exact at the poles and identical at the u seam.
fn sphere_dir(i: u32, j: u32, nu: u32, nv: u32) -> Vec3 {
    if j == 0 {
        return Vec3::Y;
    }
    if j >= nv {
        return -Vec3::Y;
    }
    let (st, ct) = (PI * j as f32 / nv as f32).sin_cos();
    let (sp, cp) = (TAU * (i % nu) as f32 / nu as f32).sin_cos();
    Vec3::new(st * cp, ct, st * sp)
}

fn sphere(segments: u32) -> Shell {
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| sphere_dir(i, j, nu, nv) * 0.5)
}

fn torus(rng: &mut Pcg64, segments: u32) -> Shell {
    let ratio: f32 = rng.gen_range(0.25..0.6);
    let major = 0.5 / (1.0 + ratio);
    let minor = major * ratio;
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let (sp, cp) = (TAU * (i % nu) as f32 / nu as f32).sin_cos();
        let (ss, cs) = (TAU * (j % nv) as f32 / nv as f32).sin_cos();
        let ring = major + minor * cs;
        Vec3::new(ring * cp, minor * ss, ring * sp)
    })
}

/// `sign(x) |x|^e`: the superquadric's signed power.
fn spow(x: f32, e: f32) -> f32 {
    x.signum() * x.abs().powf(e)
}

fn superquadric(rng: &mut Pcg64, segments: u32) -> Shell {
    // Below 1 the shape turns boxy, above 1 pinched; 0.3..1.8 stays clear of
    // the knife-edged extremes a triangle grid cannot resolve.
    let e1: f32 = rng.gen_range(0.3..1.8);
    let e2: f32 = rng.gen_range(0.3..1.8);
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let d = sphere_dir(i, j, nu, nv);
        if j == 0 || j >= nv {
            return d * 0.5;
        }
        let (st, ct) = (PI * j as f32 / nv as f32).sin_cos();
        let (sp, cp) = (TAU * (i % nu) as f32 / nu as f32).sin_cos();
        let ring = spow(st, e1);
        Vec3::new(ring * spow(cp, e2), spow(ct, e1), ring * spow(sp, e2)) * 0.5
    })
}

fn blob(rng: &mut Pcg64, segments: u32) -> Shell {
    let seed = hash64(rng.gen());
    let amount: f32 = rng.gen_range(0.15..0.35);
    let freq: f32 = rng.gen_range(1.0..2.5);
    let offset = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 16.0;
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let d = sphere_dir(i, j, nu, nv);
        let n = fbm3(seed, d * freq + offset, 3);
        d * 0.5 * (1.0 + amount * (2.0 * n - 1.0))
    })
}

/// Grid rows of a meridian that runs from the foot's centre to the lip's
/// centre of a surface of revolution about +Y.
fn revolve(nu: u32, meridian: &[(f32, f32)]) -> Shell {
    let nv = meridian.len() as u32 - 1;
    Shell::from_grid(nu, nv, |i, j| {
        // At r = 0 every i gives (+-0, y, +-0), which welding folds into
        // one pole vertex.
        let (r, y) = meridian[j as usize];
        let (sp, cp) = (TAU * (i % nu) as f32 / nu as f32).sin_cos();
        Vec3::new(r * cp, y, r * sp)
    })
}

/// A vase or bottle: a surface of revolution whose profile has a body, a
/// waist or neck and a slightly flared lip, closed by flat discs at the
/// foot and the lip with rounded (bevelled) rims.
fn vase(rng: &mut Pcg64, segments: u32) -> Shell {
    let body: f32 = rng.gen_range(0.28..0.45);
    let neck = rng.gen_range(0.1f32..0.22).min(body * 0.8);
    let centre: f32 = rng.gen_range(0.25..0.5);
    let width: f32 = rng.gen_range(0.2..0.35);
    let flare: f32 = rng.gen_range(0.0..0.05);
    let bevel = 0.02f32;
    let radius = |t: f32| {
        let bump = (-((t - centre) / width).powi(2)).exp();
        let lip = ((t - 0.85) / 0.15).clamp(0.0, 1.0);
        neck + (body - neck) * bump + flare * lip * lip
    };
    let nv = (segments / 2).max(32) as usize;
    let (disc, rim) = (8usize, 6usize);
    let profile = nv - 2 * (disc + rim);
    let (bottom, top) = (-0.5f32, 0.5f32);
    let (r0, r1) = (radius(0.0), radius(1.0));
    let mut meridian = Vec::with_capacity(nv + 1);
    for k in 0..disc {
        meridian.push(((r0 - bevel) * k as f32 / disc as f32, bottom));
    }
    for k in 0..rim {
        let a = -std::f32::consts::FRAC_PI_2 * (1.0 - k as f32 / rim as f32);
        meridian.push((
            r0 - bevel + bevel * a.cos(),
            bottom + bevel + bevel * a.sin(),
        ));
    }
    for k in 0..=profile {
        let t = k as f32 / profile as f32;
        let y = bottom + bevel + t * (top - bottom - 2.0 * bevel);
        meridian.push((radius(t), y));
    }
    for k in 1..=rim {
        let a = std::f32::consts::FRAC_PI_2 * k as f32 / rim as f32;
        meridian.push((r1 - bevel + bevel * a.cos(), top - bevel + bevel * a.sin()));
    }
    for k in (0..disc).rev() {
        meridian.push(((r1 - bevel) * k as f32 / disc as f32, top));
    }
    revolve(segments, &meridian)
}

/// Where the ray from the origin along `d` leaves the convex solid `sdf`
/// (negative inside) that holds the origin, by bisection within `far`.
fn radial_surface(d: Vec3, far: f32, sdf: &impl Fn(Vec3) -> f32) -> f32 {
    let (mut inside, mut outside) = (0.0f32, far);
    for _ in 0..48 {
        let mid = 0.5 * (inside + outside);
        if sdf(d * mid) < 0.0 {
            inside = mid;
        } else {
            outside = mid;
        }
    }
    0.5 * (inside + outside)
}

/// A box with rounded (bevelled) edges, or a can: a cylinder with rounded
/// rims; flat faces meeting at sharp but resolved edges.
fn bevelled(rng: &mut Pcg64, segments: u32) -> Shell {
    let bevel: f32 = rng.gen_range(0.025..0.07);
    let can = rng.gen_bool(0.4);
    let half = Vec3::new(0.5, rng.gen_range(0.25..0.5), rng.gen_range(0.25..0.5));
    let sdf = move |p: Vec3| -> f32 {
        if can {
            let q = Vec2::new(
                Vec2::new(p.x, p.z).length() - (half.z - bevel),
                p.y.abs() - (half.x - bevel),
            );
            q.max(Vec2::ZERO).length() + q.x.max(q.y).min(0.0) - bevel
        } else {
            let q = p.abs() - (half - Vec3::splat(bevel));
            q.max(Vec3::ZERO).length() + q.max_element().min(0.0) - bevel
        }
    };
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let d = sphere_dir(i, j, nu, nv);
        d * radial_surface(d, 2.0, &sdf)
    })
}

/// A unit vector drawn uniformly on the sphere.
fn random_direction(rng: &mut Pcg64) -> Vec3 {
    let z: f32 = rng.gen_range(-1.0..=1.0);
    let phi: f32 = rng.gen_range(0.0..TAU);
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// A rock: a lumpy body cut by a few planes (flat facets with sharp
/// edges), with fine relief over everything.
fn rock(rng: &mut Pcg64, segments: u32) -> Shell {
    let seed = hash64(rng.gen());
    let fine_seed = hash64(rng.gen());
    let offset = Vec3::new(rng.gen(), rng.gen(), rng.gen()) * 16.0;
    let lumps: f32 = rng.gen_range(0.1..0.2);
    let relief: f32 = rng.gen_range(0.015..0.035);
    let cuts: Vec<(Vec3, f32)> = (0..rng.gen_range(4..=8))
        .map(|_| (random_direction(rng), rng.gen_range(0.3..0.44)))
        .collect();
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let d = sphere_dir(i, j, nu, nv);
        let mut r = 0.5 * (1.0 + lumps * (2.0 * fbm3(seed, d * 1.3 + offset, 3) - 1.0));
        for &(n, h) in &cuts {
            let c = d.dot(n);
            if c > 1e-3 {
                r = r.min(h / c);
            }
        }
        let fine = 2.0 * fbm3(fine_seed, d * 9.0 + offset, 5) - 1.0;
        d * r * (1.0 + relief * fine)
    })
}

/// A figurine-like union of round lobes (a body, a head, limbs) with
/// concave creases where they meet, so parts shadow each other. Every
/// lobe holds the origin, so the union is star-shaped about it and each
/// direction's surface point is where the farthest lobe ends; a soft
/// maximum (a p-norm) rounds the creases a little.
fn figurine(rng: &mut Pcg64, segments: u32) -> Shell {
    let mut lobes = vec![(Vec3::ZERO, rng.gen_range(0.26..0.34))];
    for _ in 0..rng.gen_range(3..=6) {
        let radius: f32 = rng.gen_range(0.16..0.32);
        let reach: f32 = rng.gen_range(0.55..0.85);
        lobes.push((random_direction(rng) * radius * reach, radius));
    }
    const P: f32 = 12.0;
    let (nu, nv) = (segments, (segments / 2).max(4));
    Shell::from_grid(nu, nv, |i, j| {
        let d = sphere_dir(i, j, nu, nv);
        let sum: f32 = lobes
            .iter()
            .map(|&(c, radius)| {
                // Exit of the ray from the origin, which every lobe holds.
                let b = d.dot(c);
                let t = b
                    + (b * b - c.length_squared() + radius * radius)
                        .max(0.0)
                        .sqrt();
                (t / 0.5).powf(P)
            })
            .sum();
        d * 0.5 * sum.powf(1.0 / P)
    })
}

/// A uniformly random rotation (Shoemake's method).
fn random_rotation(rng: &mut Pcg64) -> Quat {
    let (u1, u2, u3): (f32, f32, f32) = (rng.gen(), rng.gen(), rng.gen());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (s2, c2) = (TAU * u2).sin_cos();
    let (s3, c3) = (TAU * u3).sin_cos();
    Quat::from_xyzw(a * s2, a * c2, b * s3, b * c3).normalize()
}

/// The transform that puts `points` into the unit box: with `random`, a
/// per-axis scale in 0.6..1, a uniform rotation, a largest extent of
/// 0.7..0.95 and a translation anywhere the box still holds the object;
/// otherwise centred with a largest extent of 0.9.
fn placement(rng: &mut Pcg64, points: &[Vec3], random: bool) -> Affine3A {
    let (linear, target) = if random {
        let scale = Vec3::new(
            rng.gen_range(0.6..=1.0),
            rng.gen_range(0.6..=1.0),
            rng.gen_range(0.6..=1.0),
        );
        let rotation = Mat3::from_quat(random_rotation(rng));
        (
            rotation * Mat3::from_diagonal(scale),
            rng.gen_range(0.7..0.95),
        )
    } else {
        (Mat3::IDENTITY, 0.9)
    };
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| {
            let q = linear * p;
            (lo.min(q), hi.max(q))
        },
    );
    if points.is_empty() {
        return Affine3A::IDENTITY;
    }
    let extent = hi - lo;
    let k = target / extent.max_element().max(1e-12);
    let slack = (Vec3::splat(2.0 * (BOX_HALF - BOX_MARGIN)) - extent * k).max(Vec3::ZERO);
    let shift = if random {
        Vec3::new(
            rng.gen_range(-0.5..=0.5) * slack.x,
            rng.gen_range(-0.5..=0.5) * slack.y,
            rng.gen_range(-0.5..=0.5) * slack.z,
        )
    } else {
        Vec3::ZERO
    };
    let centre = (lo + hi) * 0.5;
    Affine3A::from_mat3_translation(linear * k, shift - centre * k)
}

/// The mid-surface of one leaf: a grid of points over (s, t) in [0, 1]^2, s
/// along the leaf.
struct LeafGrid {
    nu: u32,
    nv: u32,
    points: Vec<Vec3>,
}

impl LeafGrid {
    fn at(&self, i: u32, j: u32) -> Vec3 {
        self.points[(j * (self.nu + 1) + i) as usize]
    }

    /// Every 4th grid point, and the longest diagonal of the cells they span:
    /// any point of the sheet lies within half that diagonal of a sample.
    fn samples(&self) -> (Vec<Vec3>, f32) {
        let step = 4;
        let is: Vec<u32> = (0..=self.nu).step_by(step).chain([self.nu]).collect();
        let js: Vec<u32> = (0..=self.nv).step_by(step).chain([self.nv]).collect();
        let mut diagonal: f32 = 0.0;
        for w in js.windows(2) {
            for v in is.windows(2) {
                diagonal = diagonal
                    .max(self.at(v[0], w[0]).distance(self.at(v[1], w[1])))
                    .max(self.at(v[1], w[0]).distance(self.at(v[0], w[1])));
            }
        }
        let pts = js
            .iter()
            .flat_map(|&j| is.iter().map(move |&i| (i, j)))
            .map(|(i, j)| self.at(i, j))
            .collect();
        (pts, diagonal)
    }

    /// Whether the two sheets are certainly apart (with `margin` to spare):
    /// at a crossing both would have samples within half a diagonal of it.
    fn clear_of(&self, other: &LeafGrid, margin: f32) -> bool {
        let (a, da) = self.samples();
        let (b, db) = other.samples();
        let need = 0.5 * (da + db) + margin;
        let need2 = need * need;
        a.iter()
            .all(|p| b.iter().all(|q| p.distance_squared(*q) > need2))
    }
}

fn random_leaf(rng: &mut Pcg64, nu: u32, nv: u32, displacement: Option<&Displacement>) -> LeafGrid {
    let length: f32 = rng.gen_range(0.5..0.9);
    let width: f32 = rng.gen_range(0.2..0.4);
    let bend_s: f32 = rng.gen_range(-0.8..0.8);
    let bend_t: f32 = rng.gen_range(-1.5..1.5);
    let twist: f32 = rng.gen_range(-0.6..0.6);
    let uv_offset = Vec2::new(rng.gen(), rng.gen());
    let rotation = random_rotation(rng);
    let centre = loop {
        let c = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if c.length_squared() <= 1.0 {
            break c * 0.35;
        }
    };
    let mut points = Vec::with_capacity(((nu + 1) * (nv + 1)) as usize);
    for j in 0..=nv {
        for i in 0..=nu {
            let (s, t) = (i as f32 / nu as f32, j as f32 / nv as f32);
            let x = (s - 0.5) * length;
            // Rounded ends that keep a tenth of the width, so tip triangles
            // do not collapse.
            let half = 0.5 * width * (0.2 + 0.8 * (PI * s).sin().max(0.0).powf(0.7));
            let y = (2.0 * t - 1.0) * half;
            let h = displacement.map_or(0.0, |d| d.height(Vec2::new(s, t) + uv_offset));
            let z = bend_s * x * x + bend_t * y * y + twist * x * y + h;
            points.push(rotation * Vec3::new(x, y, z) + centre);
        }
    }
    LeafGrid { nu, nv, points }
}

fn leaves(
    rng: &mut Pcg64,
    segments: u32,
    displacement: Option<&Displacement>,
    random: bool,
) -> Mesh {
    let (nu, nv) = ((segments / 4).max(8), (segments / 8).max(4));
    let wanted = rng.gen_range(3..=6);
    let mut placed: Vec<LeafGrid> = Vec::with_capacity(wanted);
    for _ in 0..wanted {
        for _ in 0..40 {
            let leaf = random_leaf(rng, nu, nv, displacement);
            // 0.03 leaves room for the slab thickness at any fitting scale
            // (the arrangement is at least one leaf long, >= 0.5).
            if placed.iter().all(|other| leaf.clear_of(other, 0.03)) {
                placed.push(leaf);
                break;
            }
        }
    }
    let all: Vec<Vec3> = placed.iter().flat_map(|l| l.points.clone()).collect();
    let t = placement(rng, &all, random);
    let count = placed.len() as f32;
    let mut shell = Shell::default();
    for (k, mut leaf) in placed.into_iter().enumerate() {
        for p in &mut leaf.points {
            *p = t.transform_point3(*p);
        }
        // Each leaf gets its own column of the UV square, long axis along v,
        // so no two leaves share texels.
        let uv = |s: f32, tt: f32| Vec2::new((k as f32 + 0.02 + 0.96 * tt) / count, s);
        shell.append(slab(&leaf, uv));
    }
    shell.into_mesh()
}

/// Thickens a mid-surface into a closed slab: a top and a bottom sheet
/// offset by half the thickness along the sheet normal, joined by a rim
/// along the boundary. Both sheets share the mid-surface UVs.
fn slab(leaf: &LeafGrid, uv: impl Fn(f32, f32) -> Vec2) -> Shell {
    let (nu, nv) = (leaf.nu, leaf.nv);
    let index = |i: u32, j: u32| j * (nu + 1) + i;
    let grid_count = (nu + 1) * (nv + 1);
    let mut positions = vec![Vec3::ZERO; 2 * grid_count as usize];
    let mut uvs = vec![Vec2::ZERO; 2 * grid_count as usize];
    for j in 0..=nv {
        for i in 0..=nu {
            let ds = leaf.at((i + 1).min(nu), j) - leaf.at(i.saturating_sub(1), j);
            let dt = leaf.at(i, (j + 1).min(nv)) - leaf.at(i, j.saturating_sub(1));
            let n = ds.cross(dt).try_normalize().unwrap_or(Vec3::Z);
            let p = leaf.at(i, j);
            let k = index(i, j) as usize;
            positions[k] = p + n * (0.5 * LEAF_THICKNESS);
            positions[k + grid_count as usize] = p - n * (0.5 * LEAF_THICKNESS);
            let w = uv(i as f32 / nu as f32, j as f32 / nv as f32);
            uvs[k] = w;
            uvs[k + grid_count as usize] = w;
        }
    }
    let mut top = Vec::with_capacity((2 * nu * nv) as usize);
    for j in 0..nv {
        for i in 0..nu {
            let (a, b) = (index(i, j), index(i + 1, j));
            let (c, d) = (index(i + 1, j + 1), index(i, j + 1));
            top.push([a, b, c]);
            top.push([a, c, d]);
        }
    }
    let mut triangles = top.clone();
    triangles.extend(
        top.iter()
            .map(|&[a, b, c]| [a + grid_count, c + grid_count, b + grid_count]),
    );
    // A directed top edge without its reverse lies on the boundary; the rim
    // quad uses it reversed so the slab stays consistently oriented.
    let mut edges: HashMap<(u32, u32), ()> = HashMap::new();
    for t in &top {
        for e in 0..3 {
            edges.insert((t[e], t[(e + 1) % 3]), ());
        }
    }
    let mut boundary: Vec<(u32, u32)> = edges
        .keys()
        .copied()
        .filter(|&(a, b)| !edges.contains_key(&(b, a)))
        .collect();
    boundary.sort_unstable();
    for (a, b) in boundary {
        let (ab, bb) = (a + grid_count, b + grid_count);
        triangles.push([b, a, ab]);
        triangles.push([b, ab, bb]);
    }
    let canon = weld(&positions);
    let mut shell = Shell {
        positions,
        uvs,
        triangles,
        canon,
    };
    shell.orient_outward();
    shell
}

/// How a user mesh without UVs gets them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UvProjection {
    /// Box (cube) projection into a 3 x 2 atlas: each triangle goes to the
    /// cell of its dominant normal axis and sign and is projected along that
    /// axis, so UVs stay in [0, 1] and never overlap (good for baking
    /// textures). Vertices are split where neighbouring triangles fall into
    /// different cells; material maps show seams at those cube edges.
    #[default]
    Box,
    /// Spherical projection about the bounding-box centre: u = longitude,
    /// v = latitude. Continuous except at the back seam, where triangles
    /// that straddle it get split vertices with u + 1, so u lies in
    /// [0, 1.5) (textures wrap, so lookups stay correct). Best for roundish,
    /// star-shaped objects.
    Spherical,
}

/// A user's mesh, validated and prepared for the simulator: centred and
/// uniformly scaled to a largest extent of 0.9 (inside the unit box, shape
/// kept), unit vertex normals (its own if valid, otherwise area-weighted
/// welded ones) and UVs (its own, otherwise projected). It is not displaced:
/// a user mesh is the known geometry of a real object.
#[derive(Debug, Clone, PartialEq)]
pub struct UserMesh(Mesh);

impl UserMesh {
    pub fn new(mesh: Mesh, projection: UvProjection) -> Result<UserMesh, SceneError> {
        validate(&mesh)?;
        let mut mesh = mesh;
        fit_centred(&mut mesh.positions)?;
        let normals_ok = mesh.normals.as_ref().is_some_and(|n| {
            n.iter()
                .all(|v| v.is_finite() && v.length_squared() > 1e-20)
        });
        if normals_ok {
            if let Some(n) = mesh.normals.as_mut() {
                n.iter_mut().for_each(|v| *v = v.normalize());
            }
        } else {
            let shell = Shell {
                canon: weld(&mesh.positions),
                positions: mesh.positions.clone(),
                uvs: Vec::new(),
                triangles: mesh.triangles.clone(),
            };
            mesh.normals = Some(shell.welded_normals());
        }
        if mesh.uvs.is_none() {
            mesh = match projection {
                UvProjection::Box => box_uvs(&mesh),
                UvProjection::Spherical => spherical_uvs(&mesh),
            };
        }
        Ok(UserMesh(mesh))
    }

    pub fn mesh(&self) -> &Mesh {
        &self.0
    }

    pub fn into_mesh(self) -> Mesh {
        self.0
    }
}

fn validate(mesh: &Mesh) -> Result<(), SceneError> {
    let count = mesh.positions.len();
    if mesh.triangles.is_empty() {
        return Err(SceneError::EmptyMesh);
    }
    for (triangle, t) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = t.iter().find(|&&i| i as usize >= count) {
            return Err(SceneError::IndexOutOfRange {
                triangle,
                index,
                count,
            });
        }
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(SceneError::NonFinitePosition(i));
    }
    for (what, got) in [
        ("normals", mesh.normals.as_ref().map(Vec::len)),
        ("uvs", mesh.uvs.as_ref().map(Vec::len)),
    ] {
        if let Some(got) = got.filter(|&g| g != count) {
            return Err(SceneError::AttributeLength { what, got, count });
        }
    }
    if let Some(i) = mesh
        .uvs
        .as_ref()
        .and_then(|uv| uv.iter().position(|t| !t.is_finite()))
    {
        return Err(SceneError::NonFiniteUv(i));
    }
    Ok(())
}

/// Centres the vertices and scales them to a largest extent of 0.9, in f64
/// so that coordinates near the f32 limits neither overflow nor underflow.
fn fit_centred(positions: &mut [Vec3]) -> Result<(), SceneError> {
    let (lo, hi) = positions.iter().fold(
        (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
        |(lo, hi), &p| (lo.min(p.as_dvec3()), hi.max(p.as_dvec3())),
    );
    let extent = (hi - lo).max_element();
    // Relative to the coordinates' magnitude, so a millimetre-sized object
    // far from its origin is still accepted.
    let magnitude = lo.abs().max(hi.abs()).max_element();
    if extent <= 1e-6 * magnitude || extent <= 0.0 {
        return Err(SceneError::Degenerate);
    }
    let k = 0.9 / extent;
    let centre = (lo + hi) * 0.5;
    for p in positions {
        *p = ((p.as_dvec3() - centre) * k).as_vec3();
    }
    Ok(())
}

/// Rebuilds `mesh` with new per-corner UVs, splitting a vertex once per
/// distinct `(vertex, key)` pair.
fn split_with_uvs(mesh: &Mesh, corner: impl Fn(usize, usize) -> (u32, Vec2)) -> Mesh {
    let mut map: HashMap<(u32, u32), u32> = HashMap::new();
    let mut positions = Vec::with_capacity(mesh.positions.len());
    let mut normals = Vec::with_capacity(mesh.positions.len());
    let mut uvs = Vec::with_capacity(mesh.positions.len());
    let src_normals = mesh.normals.as_deref();
    let triangles = mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(ti, t)| {
            let mut out = [0u32; 3];
            for (c, &v) in t.iter().enumerate() {
                let (key, uv) = corner(ti, c);
                out[c] = *map.entry((v, key)).or_insert_with(|| {
                    positions.push(mesh.positions[v as usize]);
                    normals.push(src_normals.map_or(Vec3::Z, |n| n[v as usize]));
                    uvs.push(uv);
                    (positions.len() - 1) as u32
                });
            }
            out
        })
        .collect();
    Mesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        triangles,
    }
}

fn box_uvs(mesh: &Mesh) -> Mesh {
    let (lo, hi) = mesh.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
    let size = (hi - lo).max(Vec3::splat(1e-12));
    let cell_size = Vec2::new(1.0 / 3.0, 0.5);
    let margin = 0.02;
    split_with_uvs(mesh, |ti, c| {
        let n = mesh.geometric_normal(ti as u32);
        let a = n.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let negative = n[axis] < 0.0;
        let group = axis as u32 * 2 + negative as u32;
        let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
        let p = (mesh.positions[mesh.triangles[ti][c] as usize] - lo) / size;
        let mut local = Vec2::new(p[a1], p[a2]).clamp(Vec2::ZERO, Vec2::ONE);
        if negative {
            local.x = 1.0 - local.x;
        }
        let origin = Vec2::new((group % 3) as f32, (group / 3) as f32) * cell_size;
        let uv = origin + (Vec2::splat(margin) + local * (1.0 - 2.0 * margin)) * cell_size;
        (group, uv)
    })
}

fn spherical_uvs(mesh: &Mesh) -> Mesh {
    let (lo, hi) = mesh.bounds().unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let centre = (lo + hi) * 0.5;
    // (uv, on the polar axis): longitude is undefined on the axis.
    let base: Vec<(Vec2, bool)> = mesh
        .positions
        .iter()
        .map(|&p| {
            let d = p - centre;
            let r = d.length();
            if r <= 1e-12 {
                return (Vec2::splat(0.5), true);
            }
            let polar = Vec2::new(d.x, d.z).length() <= 1e-6 * r;
            let u = 0.5 + d.z.atan2(d.x) / TAU;
            let v = 0.5 + (d.y / r).clamp(-1.0, 1.0).asin() / PI;
            (Vec2::new(u.clamp(0.0, 1.0), v.clamp(0.0, 1.0)), polar)
        })
        .collect();
    split_with_uvs(mesh, |ti, c| {
        let corners = mesh.triangles[ti].map(|v| base[v as usize]);
        let off_axis = || corners.iter().filter(|(_, polar)| !polar);
        let (min, max) = off_axis().fold((f32::MAX, f32::MIN), |(a, b), (t, _)| {
            (a.min(t.x), b.max(t.x))
        });
        let straddles = max - min > 0.5;
        let shifted = |uv: Vec2| {
            if straddles && uv.x < 0.5 {
                uv + Vec2::X
            } else {
                uv
            }
        };
        let (uv, polar) = corners[c];
        if polar {
            // A corner on the axis takes the mean longitude of the others, so
            // the triangle does not smear across the map; one copy per
            // triangle.
            let (sum, n) = off_axis().fold((0.0, 0), |(s, n), (t, _)| (s + shifted(*t).x, n + 1));
            let u = if n > 0 { sum / n as f32 } else { uv.x };
            return (2 + ti as u32, Vec2::new(u, uv.y));
        }
        if shifted(uv) != uv {
            (1, shifted(uv))
        } else {
            (0, uv)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn rng(seed: u64) -> Pcg64 {
        Pcg64::seed_from_u64(seed)
    }

    /// Every undirected edge of the welded mesh is used exactly twice, once
    /// in each direction: closed, manifold and consistently oriented.
    fn assert_closed_and_oriented(mesh: &Mesh, what: &str) {
        let canon = weld(&mesh.positions);
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &mesh.triangles {
            let w = t.map(|i| canon[i as usize]);
            for e in 0..3 {
                *directed.entry((w[e], w[(e + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            assert_eq!(n, 1, "{what}: edge {a}->{b} used {n} times");
            assert_eq!(
                directed.get(&(b, a)),
                Some(&1),
                "{what}: edge {a}->{b} has no twin"
            );
        }
    }

    fn signed_volume(mesh: &Mesh) -> f64 {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn every_kind_is_closed_outward_inside_the_box_with_unit_normals_and_uvs() {
        for kind in GeometryKind::ALL {
            for seed in 0..3 {
                let mesh = generate_mesh(kind, &mut rng(seed), &GeometryOptions::default());
                let what = format!("{kind} seed {seed}");
                assert_closed_and_oriented(&mesh, &what);
                assert!(signed_volume(&mesh) > 0.0, "{what}: inward");
                let (lo, hi) = mesh.bounds().unwrap();
                assert!(
                    lo.min_element() >= -BOX_HALF && hi.max_element() <= BOX_HALF,
                    "{what}: {lo} {hi}"
                );
                assert!((hi - lo).max_element() > 0.6, "{what}: too small {lo} {hi}");
                let normals = mesh.normals.as_ref().unwrap();
                assert_eq!(normals.len(), mesh.positions.len());
                assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
                let uvs = mesh.uvs.as_ref().unwrap();
                assert_eq!(uvs.len(), mesh.positions.len());
                assert!(uvs
                    .iter()
                    .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
                let tris = mesh.triangle_count();
                assert!(
                    (20_000..=80_000).contains(&tris),
                    "{what}: {tris} triangles"
                );
                assert!(mesh.positions.iter().all(|p| p.is_finite()));
            }
        }
    }

    /// Fraction of vertices whose normal points away from `centre`.
    fn outward_fraction(mesh: &Mesh, centre: impl Fn(Vec3) -> Vec3) -> f32 {
        let normals = mesh.normals.as_ref().unwrap();
        let good = mesh
            .positions
            .iter()
            .zip(normals)
            .filter(|(p, n)| n.dot(**p - centre(**p)) > 0.0)
            .count();
        good as f32 / mesh.positions.len() as f32
    }

    #[test]
    fn star_shaped_kinds_have_outward_normals_about_their_centre() {
        for (seed, make) in [
            (0, sphere as fn(u32) -> Shell),
            (1, |s| superquadric(&mut rng(1), s)),
            (2, |s| superquadric(&mut rng(7), s)),
            (3, |s| blob(&mut rng(3), s)),
            (4, |s| bevelled(&mut rng(4), s)),
            (5, |s| bevelled(&mut rng(12), s)),
            (6, |s| rock(&mut rng(6), s)),
            (7, |s| figurine(&mut rng(7), s)),
        ] {
            let mut shell = make(128);
            let t = placement(&mut rng(seed), &shell.positions, true);
            shell.transform(&t);
            shell.orient_outward();
            let origin = t.transform_point3(Vec3::ZERO);
            let mesh = shell.into_mesh();
            assert_eq!(outward_fraction(&mesh, |_| origin), 1.0, "shape {seed}");
        }
    }

    #[test]
    fn torus_normals_point_away_from_the_tube_axis() {
        let mut shell = torus(&mut rng(4), 128);
        shell.orient_outward();
        let mesh = shell.into_mesh();
        // Row j = 0 is the outer equator (major + minor), row j = 32 of 64 the
        // inner one (major - minor); their mean radius is the tube axis.
        let outer = mesh.positions[0].length();
        let inner = mesh.positions[32 * 129].length();
        assert!(outer > inner && inner > 0.0);
        let ring = 0.5 * (outer + inner);
        let frac = outward_fraction(&mesh, |p| {
            Vec3::new(p.x, 0.0, p.z).normalize_or_zero() * ring
        });
        assert_eq!(frac, 1.0);
    }

    #[test]
    fn displacement_bumps_the_surface_within_its_magnitude() {
        let mut r = rng(9);
        let d = Displacement::random(&mut r);
        let mut shell = sphere(128);
        let before: Vec<f32> = shell.positions.iter().map(|p| p.length()).collect();
        shell.displace(&d);
        let deltas: Vec<f32> = shell
            .positions
            .iter()
            .zip(&before)
            .map(|(p, b)| p.length() - b)
            .collect();
        let worst = deltas.iter().fold(0.0f32, |a, b| a.max(b.abs()));
        assert!(
            worst <= d.magnitude() * 1.001 && worst > 0.2 * d.magnitude(),
            "{worst}"
        );
        let spread = deltas.iter().fold(f32::MIN, |a, &b| a.max(b))
            - deltas.iter().fold(f32::MAX, |a, &b| a.min(b));
        assert!(spread > 0.5 * d.magnitude(), "{spread}");
        // Displaced meshes stay closed (split seam copies moved together).
        assert_closed_and_oriented(&shell.into_mesh(), "displaced sphere");
    }

    #[test]
    fn displaced_star_shapes_keep_nearly_all_normals_outward() {
        for kind in [
            GeometryKind::Sphere,
            GeometryKind::Blob,
            GeometryKind::Superquadric,
        ] {
            let mut r = rng(21);
            let options = GeometryOptions {
                random_placement: false,
                ..GeometryOptions::default()
            };
            let mesh = generate_mesh(kind, &mut r, &options);
            let (lo, hi) = mesh.bounds().unwrap();
            let c = (lo + hi) * 0.5;
            let frac = outward_fraction(&mesh, |_| c);
            assert!(frac > 0.97, "{kind}: {frac}");
        }
    }

    #[test]
    fn leaves_are_separate_thin_slabs() {
        let mesh = generate_mesh(
            GeometryKind::Leaves,
            &mut rng(5),
            &GeometryOptions::default(),
        );
        // Connected components of the welded mesh: one per leaf, 3 to 6.
        let canon = weld(&mesh.positions);
        let mut parent: Vec<u32> = (0..mesh.positions.len() as u32).collect();
        fn find(p: &mut [u32], mut x: u32) -> u32 {
            while p[x as usize] != x {
                p[x as usize] = p[p[x as usize] as usize];
                x = p[x as usize];
            }
            x
        }
        for t in &mesh.triangles {
            let w = t.map(|i| canon[i as usize]);
            for e in 0..3 {
                let (a, b) = (find(&mut parent, w[e]), find(&mut parent, w[(e + 1) % 3]));
                parent[a as usize] = b;
            }
        }
        let mut roots: Vec<u32> = mesh
            .triangles
            .iter()
            .map(|t| find(&mut parent, canon[t[0] as usize]))
            .collect();
        roots.sort_unstable();
        roots.dedup();
        assert!((3..=6).contains(&roots.len()), "{} leaves", roots.len());
        // Thin: volume is about thickness x area.
        let area: f64 = mesh
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
                (b - a).cross(c - a).length() / 2.0
            })
            .sum();
        let thickness = 2.0 * signed_volume(&mesh) / area;
        assert!(
            (thickness - LEAF_THICKNESS as f64).abs() < 0.3 * LEAF_THICKNESS as f64,
            "{thickness}"
        );
    }

    #[test]
    fn geometry_is_deterministic_per_seed() {
        let o = GeometryOptions::default();
        for kind in [GeometryKind::Blob, GeometryKind::Leaves] {
            assert_eq!(
                generate_mesh(kind, &mut rng(8), &o),
                generate_mesh(kind, &mut rng(8), &o)
            );
            assert_ne!(
                generate_mesh(kind, &mut rng(8), &o),
                generate_mesh(kind, &mut rng(9), &o)
            );
        }
    }

    #[test]
    fn held_out_families_are_never_picked_at_random() {
        for kind in [
            GeometryKind::Vase,
            GeometryKind::Box,
            GeometryKind::Rock,
            GeometryKind::Figurine,
        ] {
            assert!(GeometryKind::ALL.contains(&kind));
            assert!(!GeometryKind::PICKED.contains(&kind), "{kind}");
        }
    }

    #[test]
    fn bevelled_boxes_and_cans_have_flat_faces_and_rounded_edges() {
        for seed in 0..6 {
            let mesh = bevelled(&mut rng(seed), 128).into_mesh();
            let normals = mesh.normals.as_ref().expect("normals");
            let (_, hi) = mesh.bounds().expect("bounds");
            // The flat faces: vertices at the largest extent along an axis,
            // most with that axis as their normal (a box has three such
            // faces on the positive side, a can one, its lid).
            let mut flat_faces = 0;
            for axis in 0..3 {
                let face: Vec<usize> = (0..mesh.positions.len())
                    .filter(|&i| (mesh.positions[i][axis] - hi[axis]).abs() < 1e-4)
                    .collect();
                let aligned = face.iter().filter(|&&i| normals[i][axis] > 0.999).count();
                if face.len() > 20 && aligned * 2 > face.len() {
                    flat_faces += 1;
                }
            }
            assert!(flat_faces >= 1, "seed {seed}: no flat face");
            // Rounded edges: some normals lie between a face and its side.
            let turned = normals.iter().filter(|n| n.y > 0.3 && n.y < 0.9).count();
            assert!(turned > 0, "seed {seed}");
        }
    }

    #[test]
    fn a_vase_is_round_about_its_axis_with_a_flat_foot() {
        let mesh = vase(&mut rng(2), 128).into_mesh();
        let (lo, hi) = mesh.bounds().expect("bounds");
        assert!((lo.y + 0.5).abs() < 1e-6 && (hi.y - 0.5).abs() < 1e-6);
        // Every grid row (129 vertices around the axis) is a circle.
        for row in mesh.positions.chunks(129) {
            let radii: Vec<f32> = row.iter().map(|p| (p.x * p.x + p.z * p.z).sqrt()).collect();
            let (a, b) = radii
                .iter()
                .fold((f32::MAX, 0.0f32), |(a, b), &r| (a.min(r), b.max(r)));
            assert!(b - a < 1e-5, "{a} {b}");
            assert!(row.iter().all(|p| p.y == row[0].y));
        }
        let foot = mesh
            .positions
            .iter()
            .filter(|p| (p.y + 0.5).abs() < 1e-6)
            .count();
        assert!(foot > 100, "{foot} vertices on the foot");
    }

    #[test]
    fn a_figurine_has_concave_creases() {
        let mesh = figurine(&mut rng(3), 128).into_mesh();
        let radii: Vec<f32> = mesh.positions.iter().map(|p| p.length()).collect();
        let (min, max) = radii
            .iter()
            .fold((f32::MAX, 0.0f32), |(a, b), &r| (a.min(r), b.max(r)));
        // Lobes reach out and creases dip in: far from a sphere.
        assert!(max > 1.4 * min, "{min} {max}");
    }

    #[test]
    fn kind_names_round_trip_and_unknown_names_are_rejected() {
        for kind in GeometryKind::ALL {
            assert_eq!(kind.to_string().parse::<GeometryKind>(), Ok(kind));
        }
        let err = "cube".parse::<GeometryKind>().unwrap_err();
        assert!(err.to_string().contains("cube") && err.to_string().contains("torus"));
    }

    /// An axis-aligned cube, 8 shared vertices, no normals or UVs, far from
    /// the origin and in millimetres.
    fn cube() -> Mesh {
        let positions = (0..8)
            .map(|i| {
                Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * 40.0
                    + 1000.0
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        Mesh {
            positions,
            normals: None,
            uvs: None,
            triangles,
        }
    }

    #[test]
    fn user_mesh_is_fitted_into_the_box_with_box_projected_uvs() {
        let user = UserMesh::new(cube(), UvProjection::Box).unwrap();
        let m = user.mesh();
        let (lo, hi) = m.bounds().unwrap();
        assert!((lo + Vec3::splat(0.45)).abs().max_element() < 1e-5, "{lo}");
        assert!((hi - Vec3::splat(0.45)).abs().max_element() < 1e-5, "{hi}");
        let uvs = m.uvs.as_ref().unwrap();
        assert!(uvs
            .iter()
            .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
        // Each face went to its own atlas cell: 6 faces x 4 corners.
        assert_eq!(m.positions.len(), 24);
        assert_closed_and_oriented(m, "cube");
        // Faces of different cells do not overlap in UV: cell index from UV
        // matches per triangle.
        let cells: Vec<(u32, u32)> = m
            .triangles
            .iter()
            .map(|t| {
                let c = t
                    .map(|i| uvs[i as usize])
                    .iter()
                    .fold(Vec2::ZERO, |a, &b| a + b)
                    / 3.0;
                ((c.x * 3.0) as u32, (c.y * 2.0) as u32)
            })
            .collect();
        let mut distinct = cells.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), 6);
        let normals = m.normals.as_ref().unwrap();
        assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
    }

    #[test]
    fn spherical_projection_keeps_seam_triangles_narrow_in_u() {
        let mut sphere_mesh = sphere(48).into_mesh();
        sphere_mesh.uvs = None;
        sphere_mesh.normals = None;
        let user = UserMesh::new(sphere_mesh, UvProjection::Spherical).unwrap();
        let m = user.mesh();
        let uvs = m.uvs.as_ref().unwrap();
        assert!(uvs
            .iter()
            .all(|t| (0.0..1.5).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
        for t in &m.triangles {
            let us = t.map(|i| uvs[i as usize].x);
            let span = us.iter().fold(f32::MIN, |a, &b| a.max(b))
                - us.iter().fold(f32::MAX, |a, &b| a.min(b));
            assert!(span < 0.5, "{us:?}");
        }
        // Normals were computed (none given) and point outward.
        assert_eq!(outward_fraction(m, |_| Vec3::ZERO), 1.0);
    }

    #[test]
    fn user_meshes_at_extreme_scales_are_fitted_into_the_box() {
        for scale in [1e-30f32, 1e-3, 1e3, 1e30] {
            let mut m = cube();
            m.positions.iter_mut().for_each(|p| *p *= scale);
            let user = UserMesh::new(m, UvProjection::Box).unwrap();
            let (lo, hi) = user.mesh().bounds().unwrap();
            assert!(
                (hi - lo - Vec3::splat(0.9)).abs().max_element() < 1e-4,
                "{scale}: {lo} {hi}"
            );
            assert!(((hi + lo) * 0.5).abs().max_element() < 1e-4, "{scale}");
        }
    }

    #[test]
    fn user_mesh_keeps_its_own_uvs() {
        let mut m = cube();
        m.uvs = Some(vec![Vec2::new(0.25, 0.75); 8]);
        let user = UserMesh::new(m, UvProjection::Box).unwrap();
        assert_eq!(user.mesh().uvs.as_ref().unwrap().len(), 8);
        assert_eq!(user.mesh().uvs.as_ref().unwrap()[3], Vec2::new(0.25, 0.75));
    }

    #[test]
    fn invalid_user_meshes_are_rejected_with_the_reason() {
        let empty = Mesh::default();
        assert_eq!(
            UserMesh::new(empty, UvProjection::Box),
            Err(SceneError::EmptyMesh)
        );
        let mut bad = cube();
        bad.triangles[3][1] = 99;
        assert!(matches!(
            UserMesh::new(bad, UvProjection::Box),
            Err(SceneError::IndexOutOfRange {
                triangle: 3,
                index: 99,
                count: 8
            })
        ));
        let mut nan = cube();
        nan.positions[2].y = f32::NAN;
        assert_eq!(
            UserMesh::new(nan, UvProjection::Box),
            Err(SceneError::NonFinitePosition(2))
        );
        let mut flat = cube();
        flat.positions
            .iter_mut()
            .for_each(|p| *p = Vec3::splat(3.0));
        assert_eq!(
            UserMesh::new(flat, UvProjection::Box),
            Err(SceneError::Degenerate)
        );
        let mut short = cube();
        short.normals = Some(vec![Vec3::Z; 3]);
        assert!(matches!(
            UserMesh::new(short, UvProjection::Box),
            Err(SceneError::AttributeLength {
                what: "normals",
                got: 3,
                count: 8
            })
        ));
    }
}
