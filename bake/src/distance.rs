//! Euclidean distance transform of a mask: for every object pixel, the
//! distance in pixels to the nearest background pixel. The fusion uses it
//! to trust pixels near the silhouette less, since their footprint mixes
//! object and background.
//!
//! Exact, separable (Felzenszwalb and Huttenlocher 2012): one pass of the
//! lower envelope of parabolas per column, then per row. Pixels beyond the
//! image border count as object, not background: an object cut by the
//! frame has no silhouette there.

/// Distance of each pixel of a `width` x `height` row-major mask to the
/// nearest `false` pixel: 0 on the background, and `width + height` (more
/// than any in-image distance) everywhere when there is no background.
pub fn distance_to_background(mask: &[bool], width: usize, height: usize) -> Vec<f32> {
    let far = (width + height) as f32;
    if !mask.iter().any(|&m| !m) {
        return vec![far; mask.len()];
    }
    let big = far * far * 4.0;
    let mut sq: Vec<f32> = mask.iter().map(|&m| if m { big } else { 0.0 }).collect();
    let mut column = vec![0.0f32; height];
    let mut out = vec![0.0f32; height.max(width)];
    for x in 0..width {
        for y in 0..height {
            column[y] = sq[y * width + x];
        }
        envelope(&column, &mut out[..height]);
        for y in 0..height {
            sq[y * width + x] = out[y];
        }
    }
    for y in 0..height {
        let row = &mut sq[y * width..(y + 1) * width];
        envelope(row, &mut out[..width]);
        row.copy_from_slice(&out[..width]);
    }
    sq.into_iter().map(|d| d.sqrt().min(far)).collect()
}

/// 1D squared distance transform of sampled function `f` into `d`.
fn envelope(f: &[f32], d: &mut [f32]) {
    let n = f.len();
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f32; n + 1];
    let mut k = 0usize;
    z[0] = f32::NEG_INFINITY;
    z[1] = f32::INFINITY;
    let inter = |q: usize, p: usize| {
        let (qf, pf) = (q as f32, p as f32);
        ((f[q] + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf))
    };
    for q in 1..n {
        let mut s = inter(q, v[k]);
        // z[0] is -inf, so the envelope never loses its first parabola.
        while k > 0 && s <= z[k] {
            k -= 1;
            s = inter(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f32::INFINITY;
    }
    k = 0;
    for (q, out) in d.iter_mut().enumerate() {
        while z[k + 1] < q as f32 {
            k += 1;
        }
        let dq = q as f32 - v[k] as f32;
        *out = dq * dq + f[v[k]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(mask: &[bool], w: usize, h: usize) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                (0..w * h)
                    .filter(|&j| !mask[j])
                    .map(|j| {
                        let (bx, by) = ((j % w) as f32, (j / w) as f32);
                        ((x - bx).powi(2) + (y - by).powi(2)).sqrt()
                    })
                    .fold(f32::INFINITY, f32::min)
            })
            .collect()
    }

    #[test]
    fn matches_brute_force_on_an_irregular_mask() {
        let (w, h) = (13, 9);
        let mask: Vec<bool> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                (x * 7 + y * 3) % 11 != 0 && x > 0 && !(x == 6 && y == 4)
            })
            .collect();
        let fast = distance_to_background(&mask, w, h);
        for (i, (a, b)) in fast.iter().zip(brute(&mask, w, h)).enumerate() {
            assert!((a - b).abs() < 1e-4, "pixel {i}: {a} vs {b}");
        }
    }

    #[test]
    fn all_object_is_far_from_any_silhouette() {
        let d = distance_to_background(&[true; 6], 3, 2);
        assert!(d.iter().all(|&v| v == 5.0));
    }
}
