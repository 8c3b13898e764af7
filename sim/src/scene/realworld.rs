//! The `realworld` kind: materials that look like the surfaces scanned
//! objects are made of, after the thesis's "textureheaven" set. Each is
//! drawn from a few octaves of tiling value noise, stripes and weaves in UV
//! space (all maps tile, so UV seams stay invisible), with metallic 0 or 1
//! per region, as real objects are nearly never half metal.
//!
//! - **wood**: growth rings (distance from a random axis, warped by noise)
//!   between an early and a late wood colour, varnish roughness 0.25..0.6
//!   darkened along the rings;
//! - **stone**: marble veins (`|sin|` of a warped coordinate) or granite
//!   speckle over a warm or cold grey, roughness 0.45..0.9; marble gets a
//!   subsurface of 0.1..0.4 (light enters a few millimetres);
//! - **fabric**: a woven plaid of two or three dyes (thread stripes in u and
//!   v, over and under), roughness 0.8..1;
//! - **painted metal**: paint (dielectric, roughness 0.3..0.6) chipped where
//!   a noise field falls below a threshold, showing bare metal underneath
//!   (steel, aluminium, brass or copper reflectance, roughness 0.15..0.4
//!   with brushed streaks).
//!
//! None has transmission. Boundaries: materials only; the scene kind
//! dispatch is `super::kinds`.

use super::color::hsv_to_rgb;
use super::model::{MaterialField, Texture};
use super::noise::fbm2;
use glam::{Vec2, Vec3};
use matscan_bsdf::material::DEFAULT_SUBSURFACE_RADIUS;
use matscan_scan::Raster;
use rand::Rng;
use rand_pcg::Pcg64;
use std::f32::consts::TAU;

/// The four families, for naming and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surface {
    Wood,
    Stone,
    Fabric,
    PaintedMetal,
}

impl Surface {
    pub const ALL: [Surface; 4] = [
        Surface::Wood,
        Surface::Stone,
        Surface::Fabric,
        Surface::PaintedMetal,
    ];

    /// The family of scene `seed`: the four in turn, so that any ten
    /// consecutive seeds hold each at least twice.
    pub fn of_seed(seed: u64) -> Surface {
        Surface::ALL[(seed % Surface::ALL.len() as u64) as usize]
    }
}

/// Texels per side of a map at least (finer than the thesis's 64 maps, since
/// wood rings and threads need it).
const MIN_MAP: u32 = 256;

/// The material of a `realworld` scene.
pub fn material(rng: &mut Pcg64, seed: u64, map_size: u32) -> MaterialField {
    let n = map_size.max(MIN_MAP);
    let noise_seed: u64 = rng.gen();
    match Surface::of_seed(seed) {
        Surface::Wood => wood(rng, noise_seed, n),
        Surface::Stone => stone(rng, noise_seed, n),
        Surface::Fabric => fabric(rng, n),
        Surface::PaintedMetal => painted_metal(rng, noise_seed, n),
    }
}

/// UV of texel (x, y) of an n x n map, in [0, 1).
fn uv(x: u32, y: u32, n: u32) -> Vec2 {
    Vec2::new((x as f32 + 0.5) / n as f32, (y as f32 + 0.5) / n as f32)
}

/// Tiling fbm at `uv` with `cells` lattice cells across the map.
fn tiled(seed: u64, uv: Vec2, cells: u32, octaves: u32) -> f32 {
    fbm2(seed, uv * cells as f32, octaves, Some(cells))
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn mix3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

fn rgb_map(n: u32, f: impl Fn(Vec2) -> Vec3) -> Raster<[f32; 3]> {
    Raster::from_fn(n, n, |x, y| {
        f(uv(x, y, n)).clamp(Vec3::ZERO, Vec3::ONE).to_array()
    })
}

fn scalar_map(n: u32, f: impl Fn(Vec2) -> f32) -> Raster<f32> {
    Raster::from_fn(n, n, |x, y| f(uv(x, y, n)).clamp(0.0, 1.0))
}

fn wood(rng: &mut Pcg64, seed: u64, n: u32) -> MaterialField {
    let hue = rng.gen_range(0.05..0.1);
    let early = hsv_to_rgb(hue, rng.gen_range(0.35..0.6), rng.gen_range(0.55..0.8));
    let late = hsv_to_rgb(hue, rng.gen_range(0.55..0.8), rng.gen_range(0.2..0.4));
    // Rings are circles around a point off the map; an integer ring count
    // per unit of u keeps them tiling in u, noise warps them.
    let rings = rng.gen_range(6..14) as f32;
    let warp = rng.gen_range(0.3..0.8);
    let varnish = rng.gen_range(0.25..0.6);
    let ring = move |p: Vec2| {
        let w = tiled(seed, p, 4, 4) - 0.5;
        let s = ((p.x + warp * 0.15 * w) * rings * TAU).sin() * 0.5 + 0.5;
        smoothstep(0.25, 0.85, s + 0.2 * (tiled(seed ^ 7, p, 32, 3) - 0.5))
    };
    MaterialField {
        basecolor: Texture::Map(rgb_map(n, |p| mix3(early, late, ring(p)))),
        roughness: Texture::Map(scalar_map(n, |p| varnish + 0.15 * ring(p))),
        metallic: Texture::Constant(0.0),
        transmission: Texture::Constant(0.0),
        subsurface: Texture::Constant(0.0),
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

fn stone(rng: &mut Pcg64, seed: u64, n: u32) -> MaterialField {
    let hue = if rng.gen_bool(0.5) { 0.08 } else { 0.6 };
    let base = hsv_to_rgb(hue, rng.gen_range(0.03..0.15), rng.gen_range(0.45..0.85));
    let vein = hsv_to_rgb(hue, rng.gen_range(0.05..0.2), rng.gen_range(0.1..0.35));
    let marble = rng.gen_bool(0.5);
    let rough = rng.gen_range(0.45..0.9);
    let frequency = rng.gen_range(2..5) as f32;
    let amount = move |p: Vec2| {
        if marble {
            let t = (p.x + p.y) * frequency + 2.5 * tiled(seed, p, 4, 5);
            (1.0 - (t * TAU * 0.5).sin().abs()).powi(6)
        } else {
            smoothstep(0.55, 0.7, tiled(seed, p, 48, 2))
        }
    };
    let subsurface = if marble { rng.gen_range(0.1..0.4) } else { 0.0 };
    MaterialField {
        basecolor: Texture::Map(rgb_map(n, |p| {
            let mottle = 0.85 + 0.3 * (tiled(seed ^ 3, p, 8, 4) - 0.5);
            mix3(base * mottle, vein, amount(p))
        })),
        roughness: Texture::Map(scalar_map(n, |p| {
            rough + 0.2 * (tiled(seed ^ 5, p, 16, 3) - 0.5)
        })),
        metallic: Texture::Constant(0.0),
        transmission: Texture::Constant(0.0),
        subsurface: Texture::Constant(subsurface),
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

fn fabric(rng: &mut Pcg64, n: u32) -> MaterialField {
    let dyes: Vec<Vec3> = (0..rng.gen_range(2..=3))
        .map(|_| hsv_to_rgb(rng.gen(), rng.gen_range(0.3..0.9), rng.gen_range(0.2..0.9)))
        .collect();
    // Stripe and thread counts divide the map, so the weave tiles.
    let stripes = [4u32, 6, 8][rng.gen_range(0..3)];
    let threads = n / 4;
    let rough = rng.gen_range(0.8..1.0);
    let dye = move |t: f32| dyes[((t * stripes as f32) as usize) % dyes.len()];
    let color = move |p: Vec2| {
        // Over-under: the warp (dyed in stripes along u) shows on even
        // thread crossings, the weft (stripes along v) on odd ones; thread
        // edges are a little darker.
        let (i, j) = ((p.x * threads as f32) as u32, (p.y * threads as f32) as u32);
        let warp_up = (i + j) % 2 == 0;
        let across = (if warp_up { p.x } else { p.y } * threads as f32).fract();
        let shade = 0.75 + 0.25 * (across * std::f32::consts::PI).sin();
        let t = if warp_up { p.x } else { p.y };
        dye(t) * shade
    };
    MaterialField {
        basecolor: Texture::Map(rgb_map(n, color)),
        roughness: Texture::Constant(rough),
        metallic: Texture::Constant(0.0),
        transmission: Texture::Constant(0.0),
        subsurface: Texture::Constant(0.0),
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

/// Reflectances (linear RGB) of bare metals: steel, aluminium, brass,
/// copper (after Hoffman's "Physics and Math of Shading" table).
const METALS: [[f32; 3]; 4] = [
    [0.56, 0.57, 0.58],
    [0.91, 0.92, 0.92],
    [0.91, 0.78, 0.42],
    [0.95, 0.64, 0.54],
];

fn painted_metal(rng: &mut Pcg64, seed: u64, n: u32) -> MaterialField {
    let paint = hsv_to_rgb(rng.gen(), rng.gen_range(0.4..0.9), rng.gen_range(0.3..0.85));
    let metal = Vec3::from_array(METALS[rng.gen_range(0..METALS.len())]);
    let paint_rough = rng.gen_range(0.3..0.6);
    let metal_rough = rng.gen_range(0.15..0.4);
    // A fifth to a half of the surface chipped.
    let threshold = rng.gen_range(0.35..0.5);
    let bare = move |p: Vec2| tiled(seed, p, 6, 5) < threshold;
    let brushed =
        move |p: Vec2| fbm2(seed ^ 11, Vec2::new(p.x * 4.0, p.y * 128.0), 2, Some(4)) - 0.5;
    MaterialField {
        basecolor: Texture::Map(rgb_map(n, |p| if bare(p) { metal } else { paint })),
        roughness: Texture::Map(scalar_map(n, |p| {
            if bare(p) {
                metal_rough + 0.15 * brushed(p)
            } else {
                paint_rough
            }
        })),
        metallic: Texture::Map(scalar_map(n, |p| if bare(p) { 1.0 } else { 0.0 })),
        transmission: Texture::Constant(0.0),
        subsurface: Texture::Constant(0.0),
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn field(seed: u64) -> MaterialField {
        material(&mut Pcg64::seed_from_u64(seed), seed, 64)
    }

    fn values<T: Copy>(t: &Texture<T>) -> Vec<T> {
        match t {
            Texture::Constant(v) => vec![*v],
            Texture::Map(r) => r.data.clone(),
        }
    }

    #[test]
    fn ten_consecutive_seeds_hold_every_family_at_least_twice() {
        for start in [0u64, 7, 1001] {
            for s in Surface::ALL {
                let count = (start..start + 10)
                    .filter(|&k| Surface::of_seed(k) == s)
                    .count();
                assert!(count >= 2, "{s:?} {count} times from seed {start}");
            }
        }
    }

    #[test]
    fn metallic_is_zero_or_one_and_every_value_is_in_range() {
        for seed in 0..8 {
            let f = field(seed);
            assert!(values(&f.metallic).iter().all(|&m| m == 0.0 || m == 1.0));
            assert!(values(&f.transmission).iter().all(|&t| t == 0.0));
            for v in values(&f.roughness).iter().chain(&values(&f.subsurface)) {
                assert!((0.0..=1.0).contains(v), "seed {seed}: {v}");
            }
            for c in values(&f.basecolor) {
                assert!(
                    c.iter().all(|v| (0.0..=1.0).contains(v)),
                    "seed {seed}: {c:?}"
                );
            }
        }
    }

    #[test]
    fn painted_metal_shows_both_paint_and_bare_metal() {
        let seed = 3;
        assert_eq!(Surface::of_seed(seed), Surface::PaintedMetal);
        let m = values(&field(seed).metallic);
        let bare = m.iter().filter(|&&v| v == 1.0).count() as f32 / m.len() as f32;
        assert!((0.05..0.8).contains(&bare), "bare share {bare}");
    }

    #[test]
    fn wood_varies_along_u_across_its_rings() {
        let seed = 0;
        assert_eq!(Surface::of_seed(seed), Surface::Wood);
        let Texture::Map(b) = field(seed).basecolor else {
            panic!("wood basecolor is a map");
        };
        let row: Vec<f32> = (0..b.width).map(|x| b.get(x, b.height / 2)[0]).collect();
        let (lo, hi) = row
            .iter()
            .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        assert!(hi - lo > 0.15, "ring contrast {}", hi - lo);
    }

    #[test]
    fn maps_tile_across_the_uv_seam() {
        for seed in 0..4 {
            let Texture::Map(r) = field(seed).roughness else {
                continue;
            };
            let n = r.width;
            // The jump across the seam is no larger than between
            // neighbours inside the map, plus a small margin.
            let inner: f32 = (0..n)
                .map(|y| (r.get(n / 2, y) - r.get(n / 2 - 1, y)).abs())
                .fold(0.0, f32::max);
            let seam: f32 = (0..n)
                .map(|y| (r.get(0, y) - r.get(n - 1, y)).abs())
                .fold(0.0, f32::max);
            assert!(
                seam <= inner + 0.05,
                "seed {seed}: seam {seam}, inner {inner}"
            );
        }
    }
}
