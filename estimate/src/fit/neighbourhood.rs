//! Metallic per pixel where a material's photos pin none: each pixel's
//! cost volume summed over a small square window around it.
//!
//! A material gathered by colour can hold metal and dielectric alike
//! (multimat draws metallic as a map of its own): its summed volume then
//! calls neither, and one pixel's few views rarely do. A neighbourhood
//! mostly lies inside one region of the metallic map, and together its
//! pixels hold enough views near a highlight to tell a metal's coloured
//! lobe from a dielectric's white one over its diffuse light. Only a
//! clear call is taken (the other metallic's least summed cost at least
//! `contrast` worse); a tie keeps the fallback's answer.
//!
//! A pinned material keeps its one call unless its own pixels' windows
//! (summed over its pixels alone, so a neighbour's rim casts no vote)
//! contradict it in a large share of their clear calls
//! ([`NeighbourhoodOptions::mixed_share`]): a material of one metallic
//! disagrees in at most an eighth of them on `tune` (near its rim or its
//! highlight's edge, which its material's whole sum decides better); a
//! material that holds metal and dielectric alike in two fifths to nearly
//! all, and its metallic then stays per pixel as an open material's
//! (docs/results.md, "a pinned material that holds metal and dielectric
//! alike"). Every material is read on its direct light, the scattering
//! ones too (whose metallic their total light decided).

use super::clearly_worse;

/// The window and how clear a call must be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeighbourhoodOptions {
    /// Pixels either side of the centre: a (2 radius + 1)² window.
    pub radius: usize,
    /// A call is taken where the other metallic's least summed cost
    /// exceeds the best by at least this fraction.
    pub contrast: f64,
    /// A pinned material counts as mixed (metal and dielectric alike)
    /// where at least this share of its pixels' clear calls contradicts
    /// its own.
    pub mixed_share: f64,
}

impl Default for NeighbourhoodOptions {
    /// Chosen on all of `tune` (docs/results.md): a 5 x 5 window, the
    /// other metallic at least 1.8 times the cost. Lower contrasts flip
    /// pixels the networks had right; larger windows straddle the
    /// metallic map's regions. On `tune` a pinned material's contrary
    /// share is either at most 0.12 (every material of the kinds with
    /// constant materials, two multimat ones) or at least 0.43 (four
    /// multimat ones): a quarter lies between.
    fn default() -> Self {
        NeighbourhoodOptions {
            radius: 2,
            contrast: 0.8,
            mixed_share: 0.25,
        }
    }
}

/// The calls of the pixels `members` (indices into a `width`-wide image),
/// each from its cost volume (`row_of`, `grid` roughnesses per metallic)
/// summed over the members in its window: `(pixel, metallic)` for every
/// clear call. The window sums run over the members' bounding box only.
pub fn member_calls<'a>(
    members: &[usize],
    row_of: impl Fn(usize) -> Option<&'a [f64]>,
    width: usize,
    grid: usize,
    options: &NeighbourhoodOptions,
) -> Vec<(usize, f32)> {
    if width == 0 || members.is_empty() {
        return Vec::new();
    }
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for &i in members {
        let (x, y) = (i % width, i / width);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let bw = x1 - x0 + 1;
    let local = |i: usize| (i / width - y0) * bw + (i % width - x0);
    let mut rows: Vec<Option<&[f64]>> = vec![None; bw * (y1 - y0 + 1)];
    for &i in members {
        rows[local(i)] = row_of(i);
    }
    let sums = window_sums(&rows, bw, 2 * grid, options.radius);
    members
        .iter()
        .filter_map(|&i| {
            let summed = sums[local(i)].as_deref()?;
            Some((i, call(summed, grid, options.contrast)?))
        })
        .collect()
}

/// The share of `calls` that contradict `metallic` (a call and a metallic
/// disagree when one is at least 0.5 and the other is not); `None`
/// without calls.
pub fn contrary_share(calls: &[(usize, f32)], metallic: f32) -> Option<f64> {
    let contrary = calls
        .iter()
        .filter(|(_, v)| (*v >= 0.5) != (metallic >= 0.5))
        .count();
    (!calls.is_empty()).then(|| contrary as f64 / calls.len() as f64)
}

/// Sums of `rows` (each pixel's `len` costs; `None` where the pixel takes
/// no part, and rows of another length or with a non-finite cost are left
/// out) over the window around each pixel of a `width`-wide image; `None`
/// where the window holds no row.
pub fn window_sums(
    rows: &[Option<&[f64]>],
    width: usize,
    len: usize,
    radius: usize,
) -> Vec<Option<Vec<f64>>> {
    let n = rows.len();
    if width == 0 || len == 0 || !n.is_multiple_of(width) {
        return vec![None; n];
    }
    let height = n / width;
    let mut flat = vec![0.0f64; n * len];
    let mut count = vec![0u32; n];
    for (i, row) in rows.iter().enumerate() {
        if let Some(row) = row.filter(|r| r.len() == len && r.iter().all(|c| c.is_finite())) {
            flat[i * len..(i + 1) * len].copy_from_slice(row);
            count[i] = 1;
        }
    }
    // The box is separable: along each image row, then along each column.
    let (flat, count) = box_pass(&flat, &count, len, radius, height, width, |line, k| {
        line * width + k
    });
    let (flat, count) = box_pass(&flat, &count, len, radius, width, height, |line, k| {
        k * width + line
    });
    (0..n)
        .map(|i| (count[i] > 0).then(|| flat[i * len..(i + 1) * len].to_vec()))
        .collect()
}

/// One pass of the box along `lines` lines of `span` pixels; `at(line,
/// k)` is the index of the `k`th pixel of a line.
fn box_pass(
    values: &[f64],
    count: &[u32],
    len: usize,
    radius: usize,
    lines: usize,
    span: usize,
    at: impl Fn(usize, usize) -> usize,
) -> (Vec<f64>, Vec<u32>) {
    let mut out = vec![0.0f64; values.len()];
    let mut out_count = vec![0u32; count.len()];
    for line in 0..lines {
        for k in 0..span {
            let o = at(line, k);
            for q in k.saturating_sub(radius)..=(k + radius).min(span - 1) {
                let s = at(line, q);
                if count[s] == 0 {
                    continue;
                }
                out_count[o] += count[s];
                for c in 0..len {
                    out[o * len + c] += values[s * len + c];
                }
            }
        }
    }
    (out, out_count)
}

/// The metallic a summed volume calls (its dielectric row, then its metal
/// row, `grid` costs each): 1 or 0 where the other is clearly worse,
/// `None` where they tie or the volume is malformed. A metal whose best
/// lobe is the grid's roughest is the degenerate call (a broad metal lobe
/// imitating diffuse light) and is never taken.
pub fn call(summed: &[f64], grid: usize, contrast: f64) -> Option<f32> {
    if grid == 0 || summed.len() != 2 * grid {
        return None;
    }
    let least = |row: &[f64]| {
        row.iter()
            .enumerate()
            .filter(|(_, c)| c.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(k, c)| (k, *c))
    };
    let (_, dielectric) = least(&summed[..grid])?;
    let (k, metal) = least(&summed[grid..])?;
    if k + 1 < grid && clearly_worse(dielectric, metal, contrast) {
        Some(1.0)
    } else if clearly_worse(metal, dielectric, contrast) {
        Some(0.0)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_sums_add_every_row_within_the_radius_and_skip_the_absent() {
        // 4 x 3 image, rows of two costs: pixel i holds [i, 10 i]; pixel 5
        // takes no part and pixel 6 holds a NaN.
        let owned: Vec<Vec<f64>> = (0..12).map(|i| vec![i as f64, 10.0 * i as f64]).collect();
        let nan = [f64::NAN, 1.0];
        let rows: Vec<Option<&[f64]>> = (0..12)
            .map(|i| match i {
                5 => None,
                6 => Some(&nan[..]),
                _ => Some(owned[i].as_slice()),
            })
            .collect();
        let sums = window_sums(&rows, 4, 2, 1);
        // Pixel 0's window: pixels 0, 1, 4 (5 absent).
        assert_eq!(sums[0], Some(vec![5.0, 50.0]));
        // Pixel 9's window: 4, 5, 6, 8, 9, 10 -> 4 + 8 + 9 + 10.
        assert_eq!(sums[9], Some(vec![31.0, 310.0]));
        // Radius 0 is the pixel itself; an absent pixel alone has no sum.
        let own = window_sums(&rows, 4, 2, 0);
        assert_eq!(own[3], Some(vec![3.0, 30.0]));
        assert_eq!(own[5], None);
        assert_eq!(own[6], None);
    }

    #[test]
    fn window_sums_of_a_malformed_image_are_absent() {
        let row = [1.0, 2.0];
        let rows = vec![Some(&row[..]); 5];
        assert!(window_sums(&rows, 2, 2, 1).iter().all(Option::is_none));
        assert!(window_sums(&rows, 0, 2, 1).iter().all(Option::is_none));
        // A row of the wrong length takes no part.
        let short = [1.0];
        let sums = window_sums(&[Some(&short[..])], 1, 2, 0);
        assert_eq!(sums, vec![None]);
    }

    #[test]
    fn a_clear_volume_calls_its_metallic_and_a_tie_calls_none() {
        // Four roughnesses: least at k = 1 in both rows.
        let volume = |dielectric: f64, metal: f64| {
            vec![
                dielectric + 5.0,
                dielectric,
                dielectric + 1.0,
                dielectric + 3.0,
                metal + 5.0,
                metal,
                metal + 1.0,
                metal + 3.0,
            ]
        };
        assert_eq!(call(&volume(20.0, 10.0), 4, 0.8), Some(1.0));
        assert_eq!(call(&volume(10.0, 20.0), 4, 0.8), Some(0.0));
        // 1.5 times is no clear call at contrast 0.8.
        assert_eq!(call(&volume(15.0, 10.0), 4, 0.8), None);
        assert_eq!(call(&volume(10.0, 10.0), 4, 0.0), None);
    }

    #[test]
    fn member_calls_sum_only_the_members_and_count_the_contrary() {
        // An 8 x 3 image; members (x, y) = (2..=5, 1) and (2, 2): metal at
        // x 2 and 3, dielectric at x 4 and 5. Every other pixel holds a
        // strong metal's volume that would turn x 4 metal if it voted
        // (three of them lie inside the members' bounding box).
        let metal = [100.0, 101.0, 102.0, 1.0, 2.0, 3.0];
        let dielectric = [1.0, 2.0, 3.0, 100.0, 101.0, 102.0];
        let strong_metal = [1000.0, 1000.0, 1000.0, 1.0, 2.0, 3.0];
        let at = |x: usize, y: usize| y * 8 + x;
        let members = [at(2, 1), at(3, 1), at(4, 1), at(5, 1), at(2, 2)];
        let row_of = |i: usize| -> Option<&[f64]> {
            Some(match (i % 8, members.contains(&i)) {
                (2 | 3, true) => &metal[..],
                (_, true) => &dielectric[..],
                _ => &strong_metal[..],
            })
        };
        let options = NeighbourhoodOptions {
            radius: 1,
            ..NeighbourhoodOptions::default()
        };
        let calls = member_calls(&members, row_of, 8, 3, &options);
        // x 3 sums metal, metal, dielectric and the metal below x 2 (301
        // against 103); x 4 sums metal, dielectric, dielectric (102
        // against 201).
        assert_eq!(
            calls,
            vec![
                (at(2, 1), 1.0),
                (at(3, 1), 1.0),
                (at(4, 1), 0.0),
                (at(5, 1), 0.0),
                (at(2, 2), 1.0)
            ]
        );
        assert_eq!(contrary_share(&calls, 1.0), Some(0.4));
        assert_eq!(contrary_share(&calls, 0.0), Some(0.6));
        assert_eq!(contrary_share(&calls[..0], 0.0), None);
        // Members without a volume call nothing; no members, no calls.
        assert!(member_calls(&members, |_| None, 8, 3, &options).is_empty());
        assert!(member_calls(&[], row_of, 8, 3, &options).is_empty());
        assert!(member_calls(&members, row_of, 0, 3, &options).is_empty());
    }

    #[test]
    fn a_metal_at_the_roughest_lobe_and_a_malformed_volume_call_nothing() {
        // The metal row falls to its last (roughest) entry.
        let falling = [9.0, 8.0, 7.0, 6.0, 9.0, 5.0, 3.0, 1.0];
        assert_eq!(call(&falling, 4, 0.8), None);
        assert_eq!(call(&falling[..7], 4, 0.8), None);
        assert_eq!(call(&[], 0, 0.8), None);
        let nan = [f64::NAN; 8];
        assert_eq!(call(&nan, 4, 0.8), None);
        // A dielectric at the roughest lobe is a rough surface: kept.
        let rough = [9.0, 5.0, 3.0, 1.0, 30.0, 20.0, 25.0, 30.0];
        assert_eq!(call(&rough, 4, 0.8), Some(0.0));
    }
}
