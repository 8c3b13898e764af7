//! The surface split into materials: k-means over each pixel's apparent
//! albedo, with the number of materials chosen by how much another one
//! explains.
//!
//! One pixel rarely sees a highlight; a material seen over a region does.
//! The split only has to gather pixels that share roughness and metallic,
//! so colour is the feature (scanned objects change material where they
//! change colour); a pixel's own choice of roughness or metallic from its
//! few views is too noisy to split by.
//!
//! Deterministic: k-means++ seeding with a fixed-seed generator over the
//! pixels in index order, so the same scan always splits the same way.

/// One pixel's features; `None` for pixels the photos say nothing of.
pub type Feature = [f32; 4];

/// The features of a pixel: its square-root apparent albedo (closer to
/// perceived difference than linear), and the share of the backlight
/// panel's light seen through it (0 where none passes or no backlight was
/// read): two parts of one colour that differ in what they let through
/// are two materials. The share enters linearly: its square root, which
/// weighs a faint passage as much as a colour, split `tune`'s materials
/// worse (docs/results.md).
pub fn feature(albedo: [f32; 3], through: f32) -> Feature {
    let [r, g, b] = albedo.map(|v| v.max(0.0).sqrt());
    [r, g, b, through.max(0.0)]
}

/// How the split is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitOptions {
    /// Materials at most.
    pub max_materials: usize,
    /// Another material is added only while it lowers the within-material
    /// spread by at least this fraction.
    pub min_gain: f64,
    /// A material smaller than this share of the fitted pixels is merged
    /// into its nearest neighbour.
    pub min_share: f64,
}

impl Default for SplitOptions {
    fn default() -> Self {
        SplitOptions {
            max_materials: 8,
            min_gain: 0.25,
            min_share: 0.01,
        }
    }
}

/// A split: a material index per pixel (`None` where the pixel had no
/// feature) and the number of materials.
#[derive(Clone, Debug, PartialEq)]
pub struct Split {
    pub labels: Vec<Option<usize>>,
    pub count: usize,
}

/// Splits `features` into materials.
pub fn split(features: &[Option<Feature>], options: &SplitOptions) -> Split {
    let points: Vec<(usize, Feature)> = features
        .iter()
        .enumerate()
        .filter_map(|(i, f)| f.map(|f| (i, f)))
        .collect();
    if points.is_empty() {
        return Split {
            labels: vec![None; features.len()],
            count: 0,
        };
    }
    // k-means on a subsample is enough to place the centres; every pixel
    // is then assigned to the nearest.
    let stride = (points.len() / 4096).max(1);
    let sample: Vec<Feature> = points.iter().step_by(stride).map(|(_, f)| *f).collect();
    let mut best = kmeans(&sample, 1);
    let mut best_spread = spread(&sample, &best);
    for k in 2..=options.max_materials.max(1).min(sample.len()) {
        let centres = kmeans(&sample, k);
        let s = spread(&sample, &centres);
        if best_spread <= 1e-12 || (best_spread - s) / best_spread < options.min_gain {
            break;
        }
        best = centres;
        best_spread = s;
    }
    let mut centres = best;
    // Merge materials too small to pin anything into their neighbours.
    loop {
        let counts = counts(&sample, &centres);
        let min = (options.min_share * sample.len() as f64).ceil() as usize;
        let Some((small, _)) = counts
            .iter()
            .enumerate()
            .filter(|(_, &c)| c < min)
            .min_by_key(|(_, &c)| c)
        else {
            break;
        };
        if centres.len() == 1 {
            break;
        }
        centres.remove(small);
    }
    let mut labels = vec![None; features.len()];
    for (i, f) in points {
        labels[i] = Some(nearest(&centres, &f).0);
    }
    Split {
        labels,
        count: centres.len(),
    }
}

fn distance2(a: &Feature, b: &Feature) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn nearest(centres: &[Feature], f: &Feature) -> (usize, f32) {
    centres
        .iter()
        .enumerate()
        .map(|(j, c)| (j, distance2(c, f)))
        .fold(
            (0, f32::INFINITY),
            |best, x| if x.1 < best.1 { x } else { best },
        )
}

fn spread(points: &[Feature], centres: &[Feature]) -> f64 {
    points
        .iter()
        .map(|p| f64::from(nearest(centres, p).1))
        .sum()
}

fn counts(points: &[Feature], centres: &[Feature]) -> Vec<usize> {
    let mut c = vec![0; centres.len()];
    for p in points {
        c[nearest(centres, p).0] += 1;
    }
    c
}

/// Lloyd's k-means with k-means++ seeding from a fixed seed.
fn kmeans(points: &[Feature], k: usize) -> Vec<Feature> {
    let mut rng = SplitMix(0x6d61_7473_6361_6e00 ^ k as u64);
    let mut centres = vec![points[(rng.next() % points.len() as u64) as usize]];
    while centres.len() < k {
        let d: Vec<f64> = points
            .iter()
            .map(|p| f64::from(nearest(&centres, p).1))
            .collect();
        let total: f64 = d.iter().sum();
        if total <= 0.0 {
            break;
        }
        let mut t = rng.unit() * total;
        let mut pick = points.len() - 1;
        for (i, di) in d.iter().enumerate() {
            t -= di;
            if t <= 0.0 {
                pick = i;
                break;
            }
        }
        centres.push(points[pick]);
    }
    for _ in 0..30 {
        let mut sums = vec![[0.0f64; 4]; centres.len()];
        let mut n = vec![0usize; centres.len()];
        for p in points {
            let j = nearest(&centres, p).0;
            n[j] += 1;
            for (s, v) in sums[j].iter_mut().zip(p) {
                *s += f64::from(*v);
            }
        }
        let mut moved = 0.0f32;
        for j in 0..centres.len() {
            if n[j] == 0 {
                continue;
            }
            let c: Feature = std::array::from_fn(|d| (sums[j][d] / n[j] as f64) as f32);
            moved = moved.max(distance2(&c, &centres[j]));
            centres[j] = c;
        }
        if moved < 1e-8 {
            break;
        }
    }
    centres
}

/// A small deterministic generator (SplitMix64): seeding needs no more.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(base: [f32; 3], n: usize, seed: u64) -> Vec<Option<Feature>> {
        noisy_through(base, 0.0, n, seed)
    }

    fn noisy_through(base: [f32; 3], through: f32, n: usize, seed: u64) -> Vec<Option<Feature>> {
        let mut rng = SplitMix(seed);
        (0..n)
            .map(|_| {
                let j = |v: f32, rng: &mut SplitMix| v + 0.02 * (rng.unit() as f32 - 0.5);
                Some(feature(base.map(|v| j(v, &mut rng)), through))
            })
            .collect()
    }

    #[test]
    fn one_colour_that_passes_backlight_in_part_splits_in_two() {
        let mut f = noisy_through([0.4, 0.4, 0.4], 0.0, 400, 5);
        f.extend(noisy_through([0.4, 0.4, 0.4], 0.08, 400, 6));
        let s = split(&f, &SplitOptions::default());
        assert_eq!(s.count, 2);
        assert_ne!(s.labels[0], s.labels[400]);
        assert!((0..400).all(|i| s.labels[i] == s.labels[0]));
        assert!((400..800).all(|i| s.labels[i] == s.labels[400]));
    }

    #[test]
    fn three_colours_split_into_three_materials() {
        let mut f = noisy([0.8, 0.2, 0.1], 400, 1);
        f.extend(noisy([0.1, 0.3, 0.7], 300, 2));
        f.extend(noisy([0.05, 0.05, 0.05], 300, 3));
        f.push(None);
        let s = split(&f, &SplitOptions::default());
        assert_eq!(s.count, 3);
        let l = |i: usize| s.labels[i].unwrap();
        assert!((0..400).all(|i| l(i) == l(0)));
        assert!((400..700).all(|i| l(i) == l(400)));
        assert!((700..1000).all(|i| l(i) == l(700)));
        assert!(l(0) != l(400) && l(0) != l(700) && l(400) != l(700));
        assert_eq!(s.labels[1000], None);
    }

    #[test]
    fn one_uniform_material_stays_one_and_nothing_splits_into_nothing() {
        let s = split(&noisy([0.5; 3], 500, 4), &SplitOptions::default());
        assert_eq!(s.count, 1);
        let none = split(&[None, None], &SplitOptions::default());
        assert_eq!((none.count, none.labels), (0, vec![None, None]));
    }
}
