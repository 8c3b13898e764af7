//! The surface lobe of a material that scatters light inside, or that the
//! backlight shows light through, read where it shows: at the views that
//! look into its highlight.
//!
//! A material whose global share is large is fitted to its total light
//! (see [`super::FitLight::Material`]), and the Burley diffuse that stands
//! in there for the light scattered inside misfits every view by a few
//! percent. Summed over all of a material's views, that misfit drowns the
//! dielectric's faint specular lobe (F0 of 0.04): on `tune` the total
//! light's cost over roughness is least at the roughest lobe, and the
//! direct light's is flat to 2 or 3 % or has a second minimum there (a
//! broad lobe soaks up the part of the scattered light the checker counts
//! as direct). At a view whose half-vector lies within a few degrees of
//! the normal, the lobe is what the direct light shows most. Each pixel's
//! basecolor still comes from all of its direct views, at each roughness;
//! only the cost is summed over the views near the mirror direction, where
//! a wrong lobe width misses most.
//!
//! A material that passes light has the same trouble in its direct light:
//! light refracted through the object keeps the checker's sharp edges, so
//! the separation counts it as direct, and no surface model renders it.
//! Summed over every view, a broad lobe soaks it up; near the mirror
//! direction the surface's own lobe still outshines it.
//!
//! Boundaries: costs of the samples it is given; which materials it reads
//! and what their answer becomes is the fit's ([`super::fit_pixels`]).

use super::linear::{cost_at, responses, Noise, Sample};
use crate::refine::model::Fixed;

/// Which views count as looking into the lobe, and how many pixels must
/// have one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeOptions {
    /// A view counts where the cosine between its half-vector and the
    /// normal is at least this (0.97: within about 14 degrees).
    pub cone_cos: f32,
    /// The material's roughness is read only where at least this many of
    /// its pixels have such a view: a handful of pixels is one speck of
    /// noise or a rim, not a highlight.
    pub min_pixels: usize,
}

impl Default for LobeOptions {
    fn default() -> Self {
        LobeOptions {
            cone_cos: 0.97,
            min_pixels: 50,
        }
    }
}

/// Whether `sample` looks into the surface lobe: a trusted view whose
/// half-vector of view and light lies within the cone around the normal.
fn looks_into_lobe(sample: &Sample, cone_cos: f32) -> bool {
    let o = &sample.observation;
    let h = (o.wo + o.wi).normalize_or_zero();
    h.z.is_finite() && h.z >= cone_cos && o.weight > 0.0
}

/// One pixel's cost at each roughness of `grid` as a dielectric, counted
/// over its views near the mirror direction only, each at the basecolor
/// all its views solved at that roughness (`basecolor[k]` for `grid[k]`).
/// `None` where no view looks into the lobe.
pub fn highlight_costs(
    samples: &[Sample],
    basecolor: &[[f32; 3]],
    grid: &[f32],
    fixed: &Fixed,
    noise: &Noise,
    cone_cos: f32,
) -> Option<Vec<f64>> {
    // Only the near views' responses are needed: the basecolor is given.
    let near: Vec<Sample> = samples
        .iter()
        .filter(|s| looks_into_lobe(s, cone_cos))
        .copied()
        .collect();
    if near.is_empty() || basecolor.len() < grid.len() {
        return None;
    }
    Some(
        grid.iter()
            .zip(basecolor)
            .map(|(&r, &x)| cost_at(&near, &responses(&near, r, 0.0, fixed), x, noise))
            .collect(),
    )
}

/// The roughness a summed highlight cost row pins: its least cost lies
/// inside the grid (at the roughest lobe, the scattered light itself may
/// be what wins) and the worst costs at least `1 + contrast` times it.
pub fn pinned(row: &[f64], grid: &[f32], contrast: f64) -> Option<f32> {
    let k = super::argmin(row)?;
    if k == 0 || k + 1 >= row.len().min(grid.len()) {
        return None;
    }
    let worst = row
        .iter()
        .copied()
        .filter(|c| c.is_finite())
        .fold(0.0f64, f64::max);
    super::clearly_worse(worst, row[k], contrast).then(|| super::parabola_minimum(row, grid, k))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::linear::solve;
    use crate::fit::roughness_grid;
    use crate::refine::model::{bsdf, Observation, Params};
    use glam::Vec3;

    /// A dielectric of roughness `r` seen by a ring of views around a
    /// highlight, plus `scattered` of extra flat light (the part of the
    /// light scattered inside that no surface model renders).
    fn photos(r: f32, scattered: f32) -> Vec<Sample> {
        let truth = Params {
            basecolor: [0.4, 0.5, 0.3],
            roughness: r,
            metallic: 0.0,
        };
        let b_sdf = bsdf(&truth.to_x(), &Fixed::default());
        let mut out = Vec::new();
        for a in [20.0f32, 35.0] {
            let a = a.to_radians();
            let wi = Vec3::new(a.sin(), 0.0, a.cos());
            for k in 0..24 {
                // From 25 degrees before the mirror direction to 45 after.
                let off = (-25.0 + 70.0 * k as f32 / 23.0).to_radians();
                let b = (a + off).clamp(-1.3, 1.3);
                let wo = Vec3::new(-b.sin(), 0.05, b.cos()).normalize();
                let mut o = Observation::rendered(&b_sdf, wo, wi, [3.0; 3]);
                for c in 0..3 {
                    o.observed[c] += scattered * wi.z * (1.0 + 0.3 * off.abs());
                }
                out.push(Sample::exact(o));
            }
        }
        out
    }

    fn row(samples: &[Sample], cone: f32) -> Option<Vec<f64>> {
        let grid = roughness_grid();
        let noise = Noise::default();
        let fixed = Fixed::default();
        let basecolor: Vec<[f32; 3]> = grid
            .iter()
            .map(|&r| solve(samples, &responses(samples, r, 0.0, &fixed), &noise).basecolor)
            .collect();
        highlight_costs(samples, &basecolor, &grid, &fixed, &noise, cone)
    }

    #[test]
    fn the_views_near_the_mirror_pin_a_dielectrics_lobe_under_light_no_surface_model_renders() {
        let grid = roughness_grid();
        for truth in [0.3f32, 0.5] {
            let s = photos(truth, 0.25);
            let hl = row(&s, 0.97).expect("views near the mirror direction");
            let r = pinned(&hl, &grid, 0.05).expect("a pinned roughness");
            assert!(
                (r - truth).abs() < 0.12,
                "truth {truth}: read {r} from {hl:?}"
            );
        }
    }

    #[test]
    fn a_pixel_with_no_view_near_the_mirror_has_no_highlight_cost() {
        let s: Vec<Sample> = photos(0.4, 0.2)
            .into_iter()
            .filter(|s| (s.observation.wo + s.observation.wi).normalize().z < 0.96)
            .collect();
        assert!(!s.is_empty());
        assert_eq!(row(&s, 0.97), None);
        assert_eq!(row(&[], 0.97), None);
    }

    #[test]
    fn a_row_that_falls_to_the_roughest_lobe_or_stays_flat_pins_nothing() {
        let grid = roughness_grid();
        let falling: Vec<f64> = (0..grid.len()).map(|k| 10.0 - k as f64).collect();
        assert_eq!(pinned(&falling, &grid, 0.05), None);
        let flat = vec![1.0; grid.len()];
        assert_eq!(pinned(&flat, &grid, 0.05), None);
        let mut dip = vec![2.0; grid.len()];
        dip[7] = 1.0;
        let r = pinned(&dip, &grid, 0.05).expect("an inner minimum");
        assert!((r - grid[7]).abs() < 1e-6 || (grid[6]..=grid[8]).contains(&r));
        let nan = vec![f64::NAN; grid.len()];
        assert_eq!(pinned(&nan, &grid, 0.05), None);
    }

    #[test]
    fn non_finite_views_give_finite_costs() {
        let mut s = photos(0.4, 0.1);
        s[0].observation.observed = [f32::NAN, f32::INFINITY, 1.0];
        s[1].observation.wo = Vec3::new(f32::NAN, 0.0, 1.0);
        if let Some(hl) = row(&s, 0.97) {
            assert!(hl.iter().all(|c| c.is_finite()), "{hl:?}");
        }
    }
}
