//! Random parameter maps, made the way thesis section 3.1.3.1 makes them.
//!
//! The thesis starts from three hand-drawn maps (round shapes, stripes, and a
//! "mixed" map with hard edges, smooth transitions and noise of varying
//! scale). We draw a fresh procedural stand-in for each of them every time
//! (metaballs, wavy bands of random width, and Voronoi cells with constant,
//! gradient, spot and fBm styles blended hard or smoothly at their borders),
//! then apply the thesis's modifications in its order:
//!
//! 1. a random rotation, then a crop to the largest axis-aligned square inside
//!    the rotated image, so no padding remains;
//! 2. a value change: binary maps are inverted on chance; non-binary maps get
//!    a random offset added and keep the fractional part;
//! 3. mirroring into a 2 x 2 arrangement, which makes the map seamlessly
//!    tileable (the crop is made at half the output size for this);
//! 4. a random translation with wrap-around.
//!
//! Rasters are square, `size` x `size` (at least 2), values in [0, 1]; binary
//! maps hold exactly 0.0 and 1.0. Boundaries: maps only; which map feeds
//! which material parameter is `super::kinds`' business.

use super::noise::{fbm2, hash64};
use glam::Vec2;
use matscan_scan::Raster;
use rand::Rng;
use rand_pcg::Pcg64;

/// The two binary base patterns of the thesis (its Figure 3.6a and 3.6b).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryShape {
    /// Mainly round shapes.
    Blobs,
    /// Mainly stripes.
    Stripes,
}

/// Binary maps are redrawn until their share of ones lies in this range, so
/// that both classes really show on the object.
const COVERAGE: std::ops::RangeInclusive<f32> = 0.15..=0.85;
const COVERAGE_TRIES: usize = 8;

fn side(size: u32) -> u32 {
    size.max(2)
}

/// A random binary map, round shapes or stripes with equal chance.
pub fn binary_map(rng: &mut Pcg64, size: u32) -> Raster<f32> {
    let shape = if rng.gen_bool(0.5) {
        BinaryShape::Blobs
    } else {
        BinaryShape::Stripes
    };
    binary_map_of(rng, size, shape)
}

/// A random binary map of the given base pattern: rotated, cropped, inverted
/// on chance, mirrored and translated.
pub fn binary_map_of(rng: &mut Pcg64, size: u32, shape: BinaryShape) -> Raster<f32> {
    let n = side(size);
    let mut map = Raster::filled(n, n, 0.0);
    for _ in 0..COVERAGE_TRIES {
        let base = match shape {
            BinaryShape::Blobs => base_blobs(rng, n),
            BinaryShape::Stripes => base_stripes(rng, n),
        };
        let invert = rng.gen_bool(0.5);
        map = reshape(rng, &base, n, Sampling::Nearest, |v| {
            if invert {
                1.0 - v
            } else {
                v
            }
        });
        if COVERAGE.contains(&coverage(&map)) {
            break;
        }
    }
    map
}

/// A non-binary map from the mixed base, values shifted by a random offset
/// (fractional part kept): the thesis's roughness maps.
pub fn mixed_map(rng: &mut Pcg64, size: u32) -> Raster<f32> {
    let n = side(size);
    let base = base_mixed(rng, n, n / 4);
    let offset: f32 = rng.gen();
    reshape(rng, &base, n, Sampling::Bilinear, |v| (v + offset).fract())
}

/// A mixed map multiplied by a random binary map, so that part of the object
/// has none of the parameter: the thesis's transmission and subsurface maps.
pub fn masked_map(rng: &mut Pcg64, size: u32) -> Raster<f32> {
    let values = mixed_map(rng, size);
    let mask = binary_map(rng, size);
    Raster {
        width: values.width,
        height: values.height,
        data: values
            .data
            .iter()
            .zip(&mask.data)
            .map(|(v, m)| v * m)
            .collect(),
    }
}

/// A colour map: one independent [`mixed_map`] per channel, as the thesis
/// makes basecolor.
pub fn color_map(rng: &mut Pcg64, size: u32) -> Raster<[f32; 3]> {
    let [r, g, b] = [0, 1, 2].map(|_| mixed_map(rng, size));
    Raster {
        width: r.width,
        height: r.height,
        data: (0..r.data.len())
            .map(|i| [r.data[i], g.data[i], b.data[i]])
            .collect(),
    }
}

/// A height map for displacement: the mixed base with the geometric
/// modifications but no value shift (a shift would add cliffs), and noise
/// limited to low frequencies so that a mesh vertex grid can follow it.
pub fn displacement_map(rng: &mut Pcg64, size: u32) -> Raster<f32> {
    let n = side(size);
    let base = base_mixed(rng, n, (n / 8).max(2));
    reshape(rng, &base, n, Sampling::Bilinear, |v| v)
}

/// Share of texels at or above one half.
pub fn coverage(map: &Raster<f32>) -> f32 {
    if map.data.is_empty() {
        return 0.0;
    }
    map.data.iter().filter(|&&v| v >= 0.5).count() as f32 / map.data.len() as f32
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sampling {
    /// Keeps binary maps binary.
    Nearest,
    Bilinear,
}

/// The thesis's geometric modifications around a pointwise value change:
/// rotate + crop (at half size), `value`, mirror, translate.
fn reshape(
    rng: &mut Pcg64,
    base: &Raster<f32>,
    n: u32,
    sampling: Sampling,
    value: impl Fn(f32) -> f32,
) -> Raster<f32> {
    let theta = rng.gen_range(0.0..std::f32::consts::TAU);
    let half = n.div_ceil(2);
    let quarter = rotate_crop(base, theta, half, sampling).map(|&v| value(v).clamp(0.0, 1.0));
    let tiled = mirror(&quarter, n);
    let (dx, dy) = (rng.gen_range(0..n), rng.gen_range(0..n));
    translate(&tiled, dx, dy)
}

/// Samples the largest axis-aligned square inside `src` rotated by `theta`
/// about its centre, into an `out` x `out` raster.
fn rotate_crop(src: &Raster<f32>, theta: f32, out: u32, sampling: Sampling) -> Raster<f32> {
    let (sin, cos) = theta.sin_cos();
    // A unit square rotated by theta contains an axis-aligned square of side
    // 1 / (|cos| + |sin|) about its centre.
    let scale = 1.0 / (cos.abs() + sin.abs());
    let n = src.width as f32;
    Raster::from_fn(out, out, |x, y| {
        let q = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / out as f32 - 0.5) * scale;
        let r = Vec2::new(q.x * cos - q.y * sin, q.x * sin + q.y * cos) + 0.5;
        let p = r * n - 0.5;
        match sampling {
            Sampling::Nearest => {
                let xi = (p.x.round().max(0.0) as u32).min(src.width - 1);
                let yi = (p.y.round().max(0.0) as u32).min(src.height - 1);
                *src.get(xi, yi)
            }
            Sampling::Bilinear => bilinear_clamped(src, p),
        }
    })
}

fn bilinear_clamped(src: &Raster<f32>, p: Vec2) -> f32 {
    let maxx = (src.width - 1) as f32;
    let maxy = (src.height - 1) as f32;
    let x = p.x.clamp(0.0, maxx);
    let y = p.y.clamp(0.0, maxy);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xa, ya) = (x0 as u32, y0 as u32);
    let (xb, yb) = ((xa + 1).min(src.width - 1), (ya + 1).min(src.height - 1));
    let top = src.get(xa, ya) + (src.get(xb, ya) - src.get(xa, ya)) * fx;
    let bottom = src.get(xa, yb) + (src.get(xb, yb) - src.get(xa, yb)) * fx;
    top + (bottom - top) * fy
}

/// Mirrors `quarter` (side `ceil(n / 2)`) into an `n` x `n` map whose
/// opposite edges hold equal texels, so wrap-around shows no seam.
fn mirror(quarter: &Raster<f32>, n: u32) -> Raster<f32> {
    let half = quarter.width;
    let fold = |i: u32| if i < half { i } else { n - 1 - i };
    Raster::from_fn(n, n, |x, y| *quarter.get(fold(x), fold(y)))
}

fn translate(src: &Raster<f32>, dx: u32, dy: u32) -> Raster<f32> {
    Raster::from_fn(src.width, src.height, |x, y| {
        *src.get((x + dx) % src.width, (y + dy) % src.height)
    })
}

/// Round shapes: the union of metaballs (a smooth sum of inverse square
/// falloffs, thresholded), which merges nearby disks into organic blobs.
fn base_blobs(rng: &mut Pcg64, n: u32) -> Raster<f32> {
    let balls: Vec<(Vec2, f32)> = (0..rng.gen_range(4..=10))
        .map(|_| {
            let c = Vec2::new(rng.gen(), rng.gen());
            let r: f32 = rng.gen_range(0.06..0.2);
            (c, r * r)
        })
        .collect();
    Raster::from_fn(n, n, |x, y| {
        let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / n as f32;
        let field: f32 = balls
            .iter()
            .map(|&(c, r2)| r2 / (p.distance_squared(c) + 1e-9))
            .sum();
        if field > 1.0 {
            1.0
        } else {
            0.0
        }
    })
}

/// Stripes: bands of random width, gently waved so they are not ruler
/// straight, alternating between the two classes.
fn base_stripes(rng: &mut Pcg64, n: u32) -> Raster<f32> {
    let amp: f32 = rng.gen_range(0.0..0.04);
    let waves = rng.gen_range(1..=3) as f32;
    let phase: f32 = rng.gen();
    let mut edges = vec![-0.1f32];
    while edges.last().is_some_and(|&e| e < 1.1) {
        let last = edges.last().copied().unwrap_or(1.1);
        edges.push(last + rng.gen_range(0.03..0.15));
    }
    Raster::from_fn(n, n, |x, y| {
        let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / n as f32;
        let s = p.x + amp * (std::f32::consts::TAU * (waves * p.y + phase)).sin();
        let band = edges.partition_point(|&e| e <= s);
        (band % 2) as f32
    })
}

/// How a Voronoi cell of the mixed map fills itself.
#[derive(Debug, Clone, Copy)]
enum CellStyle {
    Constant(f32),
    /// A linear ramp across the cell.
    Gradient {
        from: f32,
        to: f32,
        dir: Vec2,
        length: f32,
    },
    /// A soft round spot on a background value.
    Spot {
        inner: f32,
        outer: f32,
        radius: f32,
    },
    /// fBm around a mean with a contrast.
    Noise {
        seed: u64,
        freq: f32,
        octaves: u32,
        mean: f32,
        contrast: f32,
    },
}

struct Cell {
    center: Vec2,
    style: CellStyle,
    /// Half width of the smooth transition to neighbours; 0 = hard edge.
    blend: f32,
}

impl Cell {
    fn value(&self, p: Vec2) -> f32 {
        match self.style {
            CellStyle::Constant(v) => v,
            CellStyle::Gradient {
                from,
                to,
                dir,
                length,
            } => {
                let t = ((p - self.center).dot(dir) / length + 0.5).clamp(0.0, 1.0);
                from + (to - from) * t
            }
            CellStyle::Spot {
                inner,
                outer,
                radius,
            } => {
                let t = smoothstep(radius, 0.0, p.distance(self.center));
                outer + (inner - outer) * t
            }
            CellStyle::Noise {
                seed,
                freq,
                octaves,
                mean,
                contrast,
            } => {
                let v = fbm2(seed, p * freq, octaves, None);
                (mean + (v - 0.5) * contrast).clamp(0.0, 1.0)
            }
        }
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let d = e1 - e0;
    if d.abs() < 1e-12 {
        return if x < e0 { 0.0 } else { 1.0 };
    }
    let t = ((x - e0) / d).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The mixed map: Voronoi cells in various styles, with hard or smooth
/// borders. `max_cycles` caps the noise frequency (cycles across the map).
fn base_mixed(rng: &mut Pcg64, n: u32, max_cycles: u32) -> Raster<f32> {
    let max_cycles = max_cycles.max(2) as f32;
    let cells: Vec<Cell> = (0..rng.gen_range(6..=14))
        .map(|_| {
            let center = Vec2::new(rng.gen(), rng.gen());
            let style = match rng.gen_range(0..10) {
                0..=2 => CellStyle::Constant(rng.gen()),
                3..=4 => {
                    let a = rng.gen_range(0.0..std::f32::consts::TAU);
                    CellStyle::Gradient {
                        from: rng.gen(),
                        to: rng.gen(),
                        dir: Vec2::from_angle(a),
                        length: rng.gen_range(0.1..0.5),
                    }
                }
                5 => CellStyle::Spot {
                    inner: rng.gen(),
                    outer: rng.gen(),
                    radius: rng.gen_range(0.05..0.25),
                },
                _ => {
                    let octaves = rng.gen_range(1..=4u32);
                    let top = max_cycles / (1u32 << (octaves - 1)) as f32;
                    CellStyle::Noise {
                        seed: hash64(rng.gen()),
                        freq: rng.gen_range(2.0f32..32.0).min(top.max(1.0)),
                        octaves,
                        mean: rng.gen(),
                        contrast: rng.gen_range(0.5..2.0),
                    }
                }
            };
            let blend = if rng.gen_bool(0.5) {
                0.0
            } else {
                rng.gen_range(0.02..0.15)
            };
            Cell {
                center,
                style,
                blend,
            }
        })
        .collect();
    Raster::from_fn(n, n, |x, y| {
        let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / n as f32;
        let (mut i1, mut i2) = (0usize, 0usize);
        let (mut d1, mut d2) = (f32::MAX, f32::MAX);
        for (i, c) in cells.iter().enumerate() {
            let d = p.distance_squared(c.center);
            if d < d1 {
                (i2, d2) = (i1, d1);
                (i1, d1) = (i, d);
            } else if d < d2 {
                (i2, d2) = (i, d);
            }
        }
        let (a, b) = (&cells[i1], &cells[i2]);
        let va = a.value(p);
        let blend = 0.5 * (a.blend + b.blend);
        if i1 == i2 || blend < 0.005 {
            return va;
        }
        // Distance from p to the bisector of the two nearest centres.
        let gap = (d2 - d1) / (2.0 * a.center.distance(b.center).max(1e-6));
        let w = 0.5 + 0.5 * smoothstep(0.0, blend, gap);
        b.value(p) + (va - b.value(p)) * w
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn rng(seed: u64) -> Pcg64 {
        Pcg64::seed_from_u64(seed)
    }

    /// Largest jump between texels that wrap-around makes neighbours.
    fn wrap_edge_jump(m: &Raster<f32>) -> f32 {
        let (w, h) = (m.width, m.height);
        let rows = (0..h).map(|y| (m.get(0, y) - m.get(w - 1, y)).abs());
        let cols = (0..w).map(|x| (m.get(x, 0) - m.get(x, h - 1)).abs());
        rows.chain(cols).fold(0.0, f32::max)
    }

    /// Largest jump between ordinary horizontal or vertical neighbours.
    fn interior_jump(m: &Raster<f32>) -> f32 {
        let mut worst: f32 = 0.0;
        for y in 0..m.height {
            for x in 0..m.width {
                if x + 1 < m.width {
                    worst = worst.max((m.get(x, y) - m.get(x + 1, y)).abs());
                }
                if y + 1 < m.height {
                    worst = worst.max((m.get(x, y) - m.get(x, y + 1)).abs());
                }
            }
        }
        worst
    }

    /// Whether some column axis c reflects the map onto itself with
    /// wrap-around: m(x, y) == m((c - x) mod n, y), and likewise for rows.
    fn has_wrapped_mirror_axes(m: &Raster<f32>) -> bool {
        let n = m.width;
        let cols = (0..n)
            .any(|c| (0..n).all(|y| (0..n).all(|x| m.get(x, y) == m.get((c + n - x) % n, y))));
        let rows = (0..n)
            .any(|c| (0..n).all(|x| (0..n).all(|y| m.get(x, y) == m.get(x, (c + n - y) % n))));
        cols && rows
    }

    #[test]
    fn maps_are_seamless_under_wrap_around() {
        for seed in 0..6 {
            let mut r = rng(seed);
            for size in [48, 49] {
                for m in [
                    binary_map(&mut r, size),
                    mixed_map(&mut r, size),
                    displacement_map(&mut r, size),
                ] {
                    assert!(has_wrapped_mirror_axes(&m), "seed {seed} size {size}");
                    let (edge, inner) = (wrap_edge_jump(&m), interior_jump(&m));
                    assert!(edge <= inner, "seed {seed} size {size}: {edge} > {inner}");
                }
            }
        }
    }

    #[test]
    fn mirrored_tile_has_equal_texels_across_its_wrap_edges() {
        let mut r = rng(3);
        let base = base_mixed(&mut r, 40, 10);
        for n in [40u32, 41] {
            let q = rotate_crop(&base, 0.7, n.div_ceil(2), Sampling::Bilinear);
            let t = mirror(&q, n);
            assert_eq!(wrap_edge_jump(&t), 0.0);
        }
    }

    #[test]
    fn binary_maps_are_binary_and_show_both_classes() {
        for seed in 0..10 {
            let mut r = rng(seed);
            for shape in [BinaryShape::Blobs, BinaryShape::Stripes] {
                let m = binary_map_of(&mut r, 96, shape);
                assert!(m.data.iter().all(|&v| v == 0.0 || v == 1.0));
                let c = coverage(&m);
                assert!(COVERAGE.contains(&c), "seed {seed} {shape:?}: {c}");
            }
        }
    }

    #[test]
    fn mixed_maps_spread_over_the_value_range() {
        for seed in 0..6 {
            let m = mixed_map(&mut rng(seed), 128);
            let mean = m.data.iter().sum::<f32>() / m.data.len() as f32;
            let var = m.data.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / m.data.len() as f32;
            assert!(var.sqrt() > 0.08, "seed {seed}: std {}", var.sqrt());
            let distinct = {
                let mut d: Vec<u32> = m.data.iter().map(|v| (v * 50.0) as u32).collect();
                d.sort_unstable();
                d.dedup();
                d.len()
            };
            assert!(distinct > 10, "seed {seed}: only {distinct} levels");
        }
    }

    #[test]
    fn masked_maps_leave_part_of_the_map_at_zero() {
        for seed in 0..6 {
            let m = masked_map(&mut rng(seed), 96);
            let zeros = m.data.iter().filter(|&&v| v == 0.0).count() as f32 / m.data.len() as f32;
            assert!((0.1..0.9).contains(&zeros), "seed {seed}: {zeros}");
        }
    }

    #[test]
    fn maps_are_deterministic_per_seed() {
        assert_eq!(mixed_map(&mut rng(5), 48), mixed_map(&mut rng(5), 48));
        assert_ne!(mixed_map(&mut rng(5), 48), mixed_map(&mut rng(6), 48));
    }
}
