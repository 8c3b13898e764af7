//! Lattice value noise and its fractal sums (fBm), in 2D (optionally
//! periodic) and 3D, plus the integer hash they stand on.
//!
//! Every value is a pure function of `(seed, point)`: no generator state is
//! consumed, so a map or a surface can be sampled in any order and still be
//! identical per seed. Boundaries: no images, no meshes; callers scale the
//! coordinates.

use glam::{Vec2, Vec3};

/// SplitMix64's finalizer: a cheap, well-mixed 64-bit hash.
pub fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A hash folded into [0, 1) with 24 bits, exactly representable in f32.
fn unit(h: u64) -> f32 {
    (h >> 40) as f32 / (1u64 << 24) as f32
}

fn lattice2(seed: u64, x: i64, y: i64) -> f32 {
    unit(hash64(
        seed ^ hash64((x as u64).wrapping_mul(0x8CB9_2BA7_2F3D_8DD7) ^ (y as u64)),
    ))
}

fn lattice3(seed: u64, x: i64, y: i64, z: i64) -> f32 {
    let h = hash64((x as u64).wrapping_mul(0x8CB9_2BA7_2F3D_8DD7) ^ (y as u64));
    unit(hash64(
        seed ^ hash64(h ^ (z as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93)),
    ))
}

/// Quintic fade: C2-continuous, so summed octaves show no lattice creases.
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Keeps lattice coordinates finite and in i64 range for any input.
fn cell(v: f32) -> (i64, f32) {
    let v = if v.is_finite() {
        v.clamp(-1.0e9, 1.0e9)
    } else {
        0.0
    };
    let f = v.floor();
    (f as i64, v - f)
}

/// Value noise in [0, 1] at `p` (lattice units). With `period = Some(n)` the
/// lattice repeats every `n` cells in x and y, so the noise tiles.
pub fn value2(seed: u64, p: Vec2, period: Option<u32>) -> f32 {
    let (ix, fx) = cell(p.x);
    let (iy, fy) = cell(p.y);
    let wrap = |i: i64| match period {
        Some(n) if n > 0 => i.rem_euclid(n as i64),
        _ => i,
    };
    let (x0, x1, y0, y1) = (wrap(ix), wrap(ix + 1), wrap(iy), wrap(iy + 1));
    let (u, v) = (fade(fx), fade(fy));
    lerp(
        lerp(lattice2(seed, x0, y0), lattice2(seed, x1, y0), u),
        lerp(lattice2(seed, x0, y1), lattice2(seed, x1, y1), u),
        v,
    )
}

/// Value noise in [0, 1] at `p` (lattice units).
pub fn value3(seed: u64, p: Vec3) -> f32 {
    let (ix, fx) = cell(p.x);
    let (iy, fy) = cell(p.y);
    let (iz, fz) = cell(p.z);
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let l = |dx: i64, dy: i64, dz: i64| lattice3(seed, ix + dx, iy + dy, iz + dz);
    let z0 = lerp(
        lerp(l(0, 0, 0), l(1, 0, 0), u),
        lerp(l(0, 1, 0), l(1, 1, 0), u),
        v,
    );
    let z1 = lerp(
        lerp(l(0, 0, 1), l(1, 0, 1), u),
        lerp(l(0, 1, 1), l(1, 1, 1), u),
        v,
    );
    lerp(z0, z1, w)
}

/// Fractal sum of `octaves` 2D value-noise octaves (each twice the frequency
/// and half the amplitude of the last), normalized to [0, 1]. A period, if
/// given, applies to the first octave and doubles with the frequency.
pub fn fbm2(seed: u64, p: Vec2, octaves: u32, period: Option<u32>) -> f32 {
    let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves.max(1) {
        let per = period.map(|n| n.saturating_mul(1 << o.min(16)));
        sum += amp * value2(hash64(seed ^ o as u64), p * freq, per);
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

/// Fractal sum of 3D value noise, normalized to [0, 1].
pub fn fbm3(seed: u64, p: Vec3, octaves: u32) -> f32 {
    let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves.max(1) {
        sum += amp * value3(hash64(seed ^ o as u64), p * freq);
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    sum / norm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_noise_stays_in_unit_range_and_interpolates_lattice_values() {
        for i in 0..2000 {
            let p = Vec2::new(i as f32 * 0.137 - 50.0, i as f32 * 0.071 + 3.0);
            let v = value2(7, p, None);
            assert!((0.0..=1.0).contains(&v), "{v}");
            let w = value3(7, p.extend(i as f32 * 0.05));
            assert!((0.0..=1.0).contains(&w), "{w}");
            let f = fbm2(9, p, 5, None);
            assert!((0.0..=1.0).contains(&f), "{f}");
        }
        assert_eq!(value2(3, Vec2::new(2.0, 5.0), None), lattice2(3, 2, 5));
    }

    #[test]
    fn periodic_noise_repeats_after_its_period() {
        for i in 0..200 {
            let p = Vec2::new(i as f32 * 0.31, i as f32 * 0.17);
            let a = fbm2(11, p, 4, Some(5));
            let b = fbm2(11, p + Vec2::new(5.0, -10.0), 4, Some(5));
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
    }

    #[test]
    fn noise_is_finite_for_non_finite_and_huge_inputs() {
        for p in [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -1e30] {
            assert!(value2(1, Vec2::splat(p), Some(4)).is_finite());
            assert!(value3(1, Vec3::splat(p)).is_finite());
        }
    }

    #[test]
    fn different_seeds_give_different_noise() {
        let p = Vec2::new(0.4, 0.6);
        assert_ne!(value2(1, p, None), value2(2, p, None));
    }
}
