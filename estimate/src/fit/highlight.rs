//! A metal's colour from its highlights.
//!
//! A metal reflects nothing but its specular lobe, and the lobe's colour
//! is its basecolor. Pixel by pixel that colour trades off against the
//! lobe's width: a lobe a little too wide predicts light in its tail that
//! the photo does not show, and each tail pixel's own least-squares answer
//! drags the colour toward black (on `tune`, glossy metals whose fitted
//! roughness is 0.24 against a truth of 0.19 read a basecolor of 0.2
//! against 0.7). The light a highlight carries in all does not depend on
//! the lobe's width, which the microfacet distribution normalizes away. So
//! the material's colour is the ratio of the light its highlights show to
//! the light its fitted lobe predicts there at basecolor 1, both summed
//! over every observation where either is bright: a small error of width
//! or of placement moves light between those observations, not out of
//! their sum.

use super::linear::{Noise, Response, Sample};
use serde::{Deserialize, Serialize};

/// How highlights are pooled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HighlightOptions {
    /// An observation belongs to the highlights where its predicted lobe
    /// at basecolor 1 or its observed light is at least this fraction of
    /// the material's brightest.
    pub region: f64,
    /// The brightest predicted lobe must reach this many times the
    /// photos' absolute noise for the material to show a highlight.
    pub min_signal: f64,
    /// Above this share of the highlights' observed light in clipped
    /// channels, the sum is a bound, not a measurement.
    pub max_clipped: f64,
    /// The pooled colour is kept where it and the mean of the pixels' own
    /// answers differ in no channel by more than this fraction of the
    /// larger (plus 0.02, for dark channels): see [`checked`].
    pub agreement: f32,
}

impl Default for HighlightOptions {
    fn default() -> Self {
        HighlightOptions {
            region: 0.001,
            min_signal: 5.0,
            max_clipped: 0.1,
            agreement: 0.25,
        }
    }
}

/// What a metal's highlights said of its colour.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum HighlightColour {
    /// The colour, from `observations` highlight observations.
    Measured {
        colour: [f32; 3],
        observations: usize,
        /// Share of the highlights' light in clipped channels.
        clipped: f32,
    },
    /// The highlights cannot say; the reason, for `result.toml`.
    Blind { reason: String },
}

impl HighlightColour {
    pub fn colour(&self) -> Option<[f32; 3]> {
        match self {
            HighlightColour::Measured { colour, .. } => Some(*colour),
            HighlightColour::Blind { .. } => None,
        }
    }
}

/// The colour of a metal from its observations (every pixel's, each with
/// its response at the material's roughness and metallic).
pub fn colour<'a>(
    observations: impl Iterator<Item = (&'a Sample, &'a Response)> + Clone,
    noise: &Noise,
    options: &HighlightOptions,
) -> HighlightColour {
    let lobe = |p: &Response| -> f64 { (0..3).map(|c| p.b[c] + p.q[c]).sum::<f64>() / 3.0 };
    let seen = |s: &Sample, p: &Response| -> f64 {
        (0..3)
            .map(|c| f64::from(s.observation.observed[c]) - p.a[c])
            .sum::<f64>()
            / 3.0
    };
    let usable = |s: &Sample| s.observation.weight > 0.0;
    let (mut top_lobe, mut top_seen) = (0.0f64, 0.0f64);
    for (s, p) in observations.clone().filter(|(s, _)| usable(s)) {
        let (l, o) = (lobe(p), seen(s, p));
        if l.is_finite() && o.is_finite() {
            top_lobe = top_lobe.max(l);
            top_seen = top_seen.max(o);
        }
    }
    if top_lobe.is_nan() || top_lobe < options.min_signal * noise.abs {
        return HighlightColour::Blind {
            reason: "no highlight: the fitted lobe predicts none above the photos' noise \
                     in any view"
                .into(),
        };
    }
    let in_region = |s: &Sample, p: &Response| {
        let (l, o) = (lobe(p), seen(s, p));
        l.is_finite()
            && o.is_finite()
            && (l >= options.region * top_lobe || o >= options.region * top_seen.max(0.0))
    };
    // Per channel: observed minus the basecolor-free part, the response's
    // slope and curvature, summed over the highlights.
    let (mut o, mut b, mut q) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    let (mut clipped, mut light, mut count) = (0.0f64, 0.0f64, 0usize);
    for (s, p) in observations.filter(|(s, p)| usable(s) && in_region(s, p)) {
        count += 1;
        for c in 0..3 {
            let v = f64::from(s.observation.observed[c]);
            o[c] += v - p.a[c];
            b[c] += p.b[c];
            q[c] += p.q[c];
            light += v.max(0.0);
            if s.clipped[c] {
                clipped += v.max(0.0);
            }
        }
    }
    let clipped = if light > 0.0 { clipped / light } else { 0.0 };
    if clipped > options.max_clipped {
        return HighlightColour::Blind {
            reason: format!(
                "highlights clipped: {:.0} % of their light is in saturated channels, \
                 so their sum is only a bound",
                100.0 * clipped
            ),
        };
    }
    let colour: [f32; 3] = std::array::from_fn(|c| solve_sum(o[c], b[c], q[c]));
    if colour.iter().any(|v| !v.is_finite()) {
        return HighlightColour::Blind {
            reason: "the highlights' sums are not finite".into(),
        };
    }
    HighlightColour::Measured {
        colour,
        observations: count,
        clipped: clipped as f32,
    }
}

/// `pooled` kept where the lobe's width is right, judged by the photos
/// alone: the pooled colour does not depend on the width, the mean of the
/// pixels' own least-squares answers (`pixels`) does, and strongly (a
/// lobe too wide pulls each tail pixel's answer toward black). Where the
/// two agree the lobe explains the photos both ways; where they part it
/// does not, and neither colour is trusted. On `tune` the metals whose
/// fitted roughness is near the truth agree within 0.92 to 1.19, the
/// glossy ones read as broad lobes part by 1.35 to 9.
pub fn checked(
    pooled: HighlightColour,
    pixels: [f32; 3],
    options: &HighlightOptions,
) -> HighlightColour {
    let Some(colour) = pooled.colour() else {
        return pooled;
    };
    let apart = (0..3).any(|c| {
        let (h, p) = (colour[c], pixels[c]);
        let gap = (h - p).abs();
        gap.is_nan() || gap > options.agreement * h.max(p) + 0.02
    });
    if apart {
        HighlightColour::Blind {
            reason: format!(
                "lobe width in doubt: the highlights' colour {} and the pixels' own {} \
                 differ by more than {:.0} %",
                rgb(colour),
                rgb(pixels),
                100.0 * options.agreement
            ),
        }
    } else {
        pooled
    }
}

fn rgb(c: [f32; 3]) -> String {
    format!("({:.2}, {:.2}, {:.2})", c[0], c[1], c[2])
}

/// Two independent readings of one material's texture, per channel: each
/// pixel's value over its reading's mean, less 1 (the fit's own
/// least-squares answer, and the networks'). Where the material has a
/// texture both readings show it and their deviations agree; where it has
/// none each carries only its own error (a lobe's tail, a network's
/// guess), and the two do not agree. Their covariance estimates the true
/// texture's variance (the errors, being independent, average out of it),
/// so the share of the combined reading's variance it makes up is how much
/// of that reading to keep: a Wiener gain, with no threshold to tune.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TextureReadings {
    /// Sum over the pixels of the two deviations' product.
    cross: [f64; 3],
    /// Sum over the pixels of their mean's square.
    spread: [f64; 3],
}

impl TextureReadings {
    /// Adds one pixel's deviations in channel `c`.
    pub fn add(&mut self, c: usize, own: f64, networks: f64) {
        if own.is_finite() && networks.is_finite() {
            self.cross[c] += own * networks;
            let mean = 0.5 * (own + networks);
            self.spread[c] += mean * mean;
        }
    }

    /// Per channel, the share in [0, 1] of the combined reading's
    /// deviation that is texture: 0 where the readings do not agree (or
    /// show none), 1 where they agree exactly.
    pub fn kept(&self) -> [f32; 3] {
        std::array::from_fn(|c| {
            let (cross, spread) = (self.cross[c], self.spread[c]);
            if spread > 0.0 && cross.is_finite() {
                (cross / spread).clamp(0.0, 1.0) as f32
            } else {
                0.0
            }
        })
    }
}

/// The `x` in [0, 1] with `b·x + q·x² = o`: the secant answer, then
/// Newton steps for the curvature (the multiple-scattering term of a rough
/// metal).
fn solve_sum(o: f64, b: f64, q: f64) -> f32 {
    let slope = b + q;
    if slope.is_nan() || slope <= 1e-12 || !o.is_finite() {
        return 0.0;
    }
    let mut x = (o / slope).clamp(0.0, 1.0);
    for _ in 0..3 {
        let d = b + 2.0 * q * x;
        if d.is_nan() || d.abs() <= 1e-12 {
            break;
        }
        x = (x - (b * x + q * x * x - o) / d).clamp(0.0, 1.0);
    }
    x as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::linear::responses;
    use crate::refine::model::{bsdf, Fixed, Observation, Params};
    use glam::{Quat, Vec3};

    /// An orthographic photo of a unit sphere of `truth` around its
    /// highlight under a distant light: one sample per pixel, each in its
    /// own normal's frame.
    fn sphere(truth: Params) -> Vec<Sample> {
        let b = bsdf(&truth.to_x(), &Fixed::default());
        let view = Vec3::Z;
        let light = Vec3::new(0.35, 0.1, 1.0).normalize();
        let h = (view + light).normalize();
        let step = 0.004;
        let mut out = Vec::new();
        for iy in -75..=75 {
            for ix in -75..=75 {
                let (x, y) = (h.x + ix as f32 * step, h.y + iy as f32 * step);
                let z2 = 1.0 - x * x - y * y;
                if z2 <= 0.0 {
                    continue;
                }
                let n = Vec3::new(x, y, z2.sqrt());
                let to_local = Quat::from_rotation_arc(n, Vec3::Z);
                let o = Observation::rendered(&b, to_local * view, to_local * light, [2.0; 3]);
                out.push(Sample::exact(o));
            }
        }
        out
    }

    fn metal(basecolor: [f32; 3], roughness: f32) -> Params {
        Params {
            basecolor,
            roughness,
            metallic: 1.0,
        }
    }

    fn pooled(samples: &[Sample], roughness: f32) -> HighlightColour {
        let r = responses(samples, roughness, 1.0, &Fixed::default());
        colour(
            samples.iter().zip(&r),
            &Noise::default(),
            &HighlightOptions::default(),
        )
    }

    #[test]
    fn the_pooled_colour_is_the_metals_own_when_the_fitted_lobe_is_a_third_too_narrow_or_wide() {
        let truth = [0.9, 0.6, 0.3];
        let photo = sphere(metal(truth, 0.15));
        for roughness in [0.1, 0.15, 0.2] {
            let measured = pooled(&photo, roughness);
            let Some(c) = measured.colour() else {
                panic!("blind at roughness {roughness}: {measured:?}");
            };
            for (got, want) in c.iter().zip(truth) {
                assert!(
                    (got - want).abs() < 0.03 * want,
                    "roughness {roughness}: {c:?} against {truth:?}"
                );
            }
        }
    }

    #[test]
    fn a_black_metal_reads_black_and_a_metal_without_a_highlight_is_blind() {
        let black = pooled(&sphere(metal([0.0; 3], 0.2)), 0.2);
        let c = black.colour().expect("measured");
        assert!(c.iter().all(|v| (0.0..1e-6).contains(v)), "{c:?}");
        // The light behind the surface: no view sees a lobe.
        let b = bsdf(&metal([0.8; 3], 0.2).to_x(), &Fixed::default());
        let dark: Vec<Sample> = (0..50)
            .map(|k| {
                let wo = Vec3::new(0.3, 0.01 * k as f32, 0.9).normalize();
                let wi = Vec3::new(-0.3, 0.2, -0.5).normalize();
                Sample::exact(Observation::rendered(&b, wo, wi, [2.0; 3]))
            })
            .collect();
        match pooled(&dark, 0.2) {
            HighlightColour::Blind { reason } => {
                assert!(reason.contains("no highlight"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
        match pooled(&[], 0.2) {
            HighlightColour::Blind { reason } => {
                assert!(reason.contains("no highlight"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_one_pixel_metal_seen_from_one_view_reads_its_colour_from_that_view() {
        let truth = [0.7, 0.5, 0.2];
        let b = bsdf(&metal(truth, 0.3).to_x(), &Fixed::default());
        let wo = Vec3::new(0.3, 0.0, 0.95).normalize();
        let wi = Vec3::new(-0.25, 0.05, 0.97).normalize();
        let one = [Sample::exact(Observation::rendered(&b, wo, wi, [2.0; 3]))];
        let c = pooled(&one, 0.3).colour().expect("measured");
        for (got, want) in c.iter().zip(truth) {
            assert!((got - want).abs() < 1e-3, "{c:?} against {truth:?}");
        }
        // The same view with no trust left is no highlight at all.
        let mut untrusted = one;
        untrusted[0].observation.weight = 0.0;
        assert!(pooled(&untrusted, 0.3).colour().is_none());
    }

    #[test]
    fn saturated_highlights_make_the_colour_blind_not_dark() {
        let mut photo = sphere(metal([0.9, 0.6, 0.3], 0.15));
        let top = photo
            .iter()
            .map(|s| s.observation.observed[0])
            .fold(0.0f32, f32::max);
        for s in photo.iter_mut() {
            for c in 0..3 {
                if s.observation.observed[c] >= 0.2 * top {
                    s.observation.observed[c] = 0.2 * top;
                    s.clipped[c] = true;
                }
            }
        }
        match pooled(&photo, 0.15) {
            HighlightColour::Blind { reason } => assert!(reason.contains("clipped"), "{reason}"),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn non_finite_observations_give_a_finite_colour() {
        let mut photo = sphere(metal([0.5; 3], 0.3));
        for s in photo.iter_mut().step_by(7) {
            s.observation.observed = [f32::NAN, f32::INFINITY, -1.0];
        }
        let c = pooled(&photo, 0.3).colour().expect("measured");
        assert!(
            c.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)),
            "{c:?}"
        );
    }

    #[test]
    fn a_pooled_colour_the_pixels_disagree_with_is_reported_as_a_doubtful_lobe() {
        let measured = |colour| HighlightColour::Measured {
            colour,
            observations: 100,
            clipped: 0.0,
        };
        let options = HighlightOptions::default();
        let agree = checked(measured([0.46, 0.23, 1.0]), [0.39, 0.22, 0.84], &options);
        assert_eq!(agree.colour(), Some([0.46, 0.23, 1.0]));
        let dark = checked(measured([0.01, 0.0, 0.02]), [0.0, 0.01, 0.0], &options);
        assert!(dark.colour().is_some());
        match checked(measured([0.72, 1.0, 0.78]), [0.13, 0.11, 0.13], &options) {
            HighlightColour::Blind { reason } => assert!(reason.contains("lobe width"), "{reason}"),
            other => panic!("{other:?}"),
        }
        let blind = HighlightColour::Blind {
            reason: "no highlight".into(),
        };
        assert_eq!(checked(blind.clone(), [0.5; 3], &options), blind);
    }

    /// A deterministic stand-in for noise: a hash of `i` in [-1, 1].
    fn jitter(i: u64, seed: u64) -> f64 {
        let mut x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed;
        x ^= x >> 31;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 29;
        (x % 20001) as f64 / 10000.0 - 1.0
    }

    #[test]
    fn readings_that_share_a_texture_keep_it_and_independent_errors_are_dropped() {
        let mut readings = TextureReadings::default();
        for i in 0..4000u64 {
            // Red: a texture of amplitude 0.3 both readings see, each
            // with an error a tenth of it. Green: no texture, errors of
            // 0.2 each, independent. Blue: the same texture and no error.
            let texture = 0.3 * jitter(i, 1);
            readings.add(
                0,
                texture + 0.03 * jitter(i, 2),
                texture + 0.03 * jitter(i, 3),
            );
            readings.add(1, 0.2 * jitter(i, 4), 0.2 * jitter(i, 5));
            readings.add(2, texture, texture);
        }
        let kept = readings.kept();
        assert!(kept[0] > 0.97 && kept[0] < 1.0, "{kept:?}");
        assert!(kept[1] < 0.05, "{kept:?}");
        assert_eq!(kept[2], 1.0);
    }

    #[test]
    fn readings_that_disagree_or_show_nothing_keep_no_texture() {
        let mut opposed = TextureReadings::default();
        let mut flat = TextureReadings::default();
        for i in 0..100u64 {
            let d = 0.2 * jitter(i, 7);
            opposed.add(0, d, -d);
            flat.add(0, 0.0, 0.0);
            opposed.add(1, f64::NAN, d);
            flat.add(1, f64::INFINITY, 0.0);
        }
        assert_eq!(opposed.kept(), [0.0; 3]);
        assert_eq!(flat.kept(), [0.0; 3]);
    }
}
