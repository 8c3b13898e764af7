//! How far light travels under a material's surface (its subsurface),
//! measured by rendering the scan's own object under the reference
//! position's flashes.
//!
//! Why rendering, not a table: with the Principled radius of one scene
//! unit, a subsurface of 0.2 already gives the random walk a mean free path
//! of a third of an object (`matscan_bsdf::subsurface`), so light that
//! enters on the lit side spreads through the whole object. Every measure
//! that sums over the object (the checker's global share, the glow on the
//! unlit side, the lit albedo) is then a property of the shape as much as
//! of the material (docs/results.md, "how far light travels under the
//! surface"). The shape is known, so it is put into the model: `sim`'s
//! path tracer with its random walk renders the scan's mesh from the
//! reference camera under each calibrated flash of the reference position,
//! once per subsurface of [`GRID`], with the material's basecolor and
//! fitted roughness over the whole object.
//!
//! What is compared is each flash's share of a cell's light,
//! `p_v / Σ_u p_u`, photo against render. The share cancels the basecolor's
//! texture and the light's overall scale (both multiply every flash alike),
//! and it is what scattering changes: without it each flash lights its own
//! side (the share follows N·L); with it light from either flash leaves
//! everywhere and the shares flatten towards the flashes' ratio. The
//! subsurface whose renders leave the least root-mean-square share
//! difference, refined by a parabola through its grid neighbours, is the
//! measurement. All candidates are rendered with the same random numbers,
//! so that their differences are the material's and not the noise's; the
//! residual then falls smoothly to one minimum, so the grid is searched
//! downhill from 0.3 (with 0, the Burley diffuse, always rendered) rather
//! than rendered whole ([`descend`]), first at [`SEARCH_SAMPLES`] per cell
//! and then at the full count around the coarse search's least point only
//! ([`search`]), and only the cells compared are traced.
//!
//! What limits it: the renders take the basecolor as given (the caller's:
//! the networks' median), and a brighter basecolor carries light as far as
//! a larger subsurface does (on `tune`, a basecolor 0.3 off moves the
//! answer by about 0.1); the whole object is rendered with one material,
//! so the fit measures every scattering material of a scan together and
//! the materials around them are rendered as if they were them.
//!
//! Blind, with the reason recorded: fewer than two flash views with a
//! calibrated intensity at the reference position, fewer than
//! [`ScatteringOptions::min_cells`] unclipped cells wholly of the
//! material, or a black basecolor (every subsurface renders alike).

use crate::pipeline::inputs::SceneInputs;
use crate::refine::observe::clip_level;
use glam::Vec3;
use matscan_bsdf::material::{Material, DEFAULT_SUBSURFACE_RADIUS};
use matscan_bsdf::CLOSURE_WEIGHT_CUTOFF;
use matscan_scan::camera::PinholeCamera;
use matscan_scan::mesh::Mesh;
use matscan_scan::Bundle;
use matscan_sim::render::environment::Environment;
use matscan_sim::render::integrator::{
    MaterialMode, Pass, PassImages, PassKey, DEFAULT_CLAMP_INDIRECT,
};
use matscan_sim::render::lights::{Flash, Panel};
use matscan_sim::render::world::{ObjectGeometry, World};
use matscan_sim::scene::model::{MaterialField, PointLight};
use serde::{Deserialize, Serialize};

/// The subsurface values the renders may take.
pub const GRID: [f32; 8] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0];

/// The grid point the search starts from ([`descend`]): 0.3.
pub const START: usize = 3;

/// How many times the least coarse residual the first point's must be for
/// the fine search to leave it out ([`search`]).
pub const FIRST_POINT_FAR: f64 = 2.0;

/// The coarse search's samples per cell ([`ScatteringOptions::search_samples`]).
pub const SEARCH_SAMPLES: u32 = 64;

/// How the measurement renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScatteringOptions {
    /// Cells across the reference image; the photos are averaged over
    /// each cell and the renders made at this size.
    pub cells: usize,
    /// Path-tracing samples per cell of the renders the answer rests on.
    pub samples: u32,
    /// Path-tracing samples per cell of the first, coarse search
    /// ([`search`]); `samples` or more renders the search once, at
    /// `samples`.
    pub search_samples: u32,
    /// Fewest cells wholly of the material (and unclipped) to measure it.
    pub min_cells: usize,
    /// Seed of the renders' random numbers.
    pub seed: u64,
}

impl Default for ScatteringOptions {
    fn default() -> Self {
        ScatteringOptions {
            cells: 32,
            samples: 512,
            search_samples: SEARCH_SAMPLES,
            min_cells: 16,
            seed: 7,
        }
    }
}

/// What the renders said of one material's subsurface.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum SubsurfaceFit {
    Measured {
        value: f32,
        /// Root-mean-square difference of the flashes' shares at `value`'s
        /// grid point.
        residual: f64,
        /// The same at no subsurface: how much better scattering explains
        /// the photos (at the coarse search's samples where the fine search
        /// did not render subsurface 0, [`search`]).
        residual_without: f64,
        /// Every subsurface rendered at the full samples and its residual,
        /// in grid order: how sharply the photos single out `value`.
        curve: Vec<[f64; 2]>,
        cells: usize,
        /// Time the renders took, s.
        seconds: f64,
    },
    Blind {
        reason: String,
    },
}

impl SubsurfaceFit {
    /// The measured subsurface, if any.
    pub fn value(&self) -> Option<f32> {
        match self {
            SubsurfaceFit::Measured { value, .. } => Some(*value),
            SubsurfaceFit::Blind { .. } => None,
        }
    }
}

/// The reference position's flashes and their photos, averaged over cells.
pub struct FlashPhotos {
    /// Cells across and down.
    pub size: (usize, usize),
    /// Reference pixels per cell side.
    pub factor: usize,
    pub flashes: Vec<PointLight>,
    /// Per flash, lit minus ambient per cell, summed over the channels
    /// (NaN where a pixel clipped).
    pub light: Vec<Vec<f64>>,
    pub camera: PinholeCamera,
}

impl FlashPhotos {
    /// The flash views of `inputs`' reference position, or why there are
    /// not enough of them.
    pub fn new(
        bundle: &Bundle,
        inputs: &SceneInputs,
        options: &ScatteringOptions,
        saturation: f32,
    ) -> Result<Result<FlashPhotos, String>, matscan_scan::ScanError> {
        let position = bundle.position(&inputs.reference)?;
        let factor = (inputs.width / options.cells.max(1)).max(1);
        let size = (inputs.width / factor, inputs.height / factor);
        let (mut flashes, mut per_flash) = (Vec::new(), Vec::new());
        for planes in inputs
            .views
            .iter()
            .filter(|p| p.view.position == inputs.reference)
        {
            let Some(flash) = position
                .light(&planes.view.light)
                .and_then(PointLight::from_manifest)
                .filter(|f| f.intensity > 0.0)
            else {
                continue;
            };
            let clip = clip_level(planes, saturation);
            let (lit, ambient) = (planes.lit(), planes.ambient());
            let cells = (0..size.0 * size.1)
                .map(|k| {
                    let mut sum = 0.0f64;
                    for i in cell_pixels(size.0, factor, inputs.width, k) {
                        // NaN counts as clipped.
                        if (0..3).any(|c| lit[i][c].is_nan() || lit[i][c] >= clip[c]) {
                            return f64::NAN;
                        }
                        sum += (0..3)
                            .map(|c| f64::from(lit[i][c] - ambient[i][c]))
                            .sum::<f64>();
                    }
                    sum / (factor * factor) as f64
                })
                .collect();
            per_flash.push(cells);
            flashes.push(flash);
        }
        if flashes.len() < 2 {
            return Ok(Err(format!(
                "{} flash view(s) with a calibrated intensity at {}: how far light travels \
                 under the surface needs two",
                flashes.len(),
                inputs.reference
            )));
        }
        let reference = bundle.camera(&inputs.reference)?;
        let camera = PinholeCamera::new(
            reference.intrinsics.scaled_to(size.0 as u32, size.1 as u32),
            reference.camera_to_world,
        );
        Ok(Ok(FlashPhotos {
            size,
            factor,
            flashes,
            light: per_flash,
            camera,
        }))
    }

    /// The cells wholly inside `member` (per reference pixel) and
    /// unclipped in every flash.
    pub fn cells_of(&self, width: usize, member: impl Fn(usize) -> bool) -> Vec<usize> {
        (0..self.size.0 * self.size.1)
            .filter(|&k| {
                self.light.iter().all(|l| l[k].is_finite())
                    && cell_pixels(self.size.0, self.factor, width, k).all(&member)
            })
            .collect()
    }
}

/// The reference pixels (of an image `width` wide) of cell `k` in a grid
/// `across` cells wide, each `factor` pixels on a side.
fn cell_pixels(
    across: usize,
    factor: usize,
    width: usize,
    k: usize,
) -> impl Iterator<Item = usize> {
    let (x0, y0) = ((k % across) * factor, (k / across) * factor);
    (0..factor * factor).map(move |j| (y0 + j / factor) * width + x0 + j % factor)
}

/// The subsurface of a material covering `cells`, with `basecolor` and
/// `roughness`, rendered on `mesh`.
pub fn measure(
    mesh: &Mesh,
    photos: &FlashPhotos,
    cells: &[usize],
    basecolor: Vec3,
    roughness: f32,
    options: &ScatteringOptions,
) -> SubsurfaceFit {
    if cells.len() < options.min_cells.max(1) {
        return SubsurfaceFit::Blind {
            reason: format!(
                "{} cell(s) of {}x{} reference pixels wholly of the material and unclipped \
                 (at least {} needed)",
                cells.len(),
                photos.factor,
                photos.factor,
                options.min_cells
            ),
        };
    }
    if photos.flashes.len() < 2 {
        return SubsurfaceFit::Blind {
            reason: format!(
                "{} flash(es): each flash's share of the light needs two",
                photos.flashes.len()
            ),
        };
    }
    let t = std::time::Instant::now();
    let object = ObjectGeometry::new(mesh);
    let render = FlashRender {
        object: &object,
        panel: None,
        camera: photos.camera,
        flashes: &photos.flashes,
        cells: Some(cells),
        samples: options.samples,
        seed: options.seed,
    };
    let basecolor = if basecolor.is_finite() {
        basecolor.clamp(Vec3::ZERO, Vec3::ONE)
    } else {
        Vec3::splat(0.5)
    };
    let roughness = if roughness.is_finite() {
        roughness.clamp(0.0, 1.0)
    } else {
        0.5
    };
    // So dark a basecolor drops the diffuse and subsurface lobes
    // (`CLOSURE_WEIGHT_CUTOFF`): every subsurface would render alike.
    if basecolor.element_sum() / 3.0 <= CLOSURE_WEIGHT_CUTOFF {
        return SubsurfaceFit::Blind {
            reason: format!(
                "a black basecolor ({:.2}, {:.2}, {:.2}) carries no light under the surface: \
                 every subsurface renders alike",
                basecolor.x, basecolor.y, basecolor.z
            ),
        };
    }
    let residual = |samples: u32, g: usize| {
        let material = Material {
            basecolor,
            roughness,
            metallic: 0.0,
            transmission: 0.0,
            subsurface: GRID[g],
            subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
        };
        let render = FlashRender { samples, ..render };
        share_residual(&photos.light, &render.light(&material), cells)
    };
    // Subsurface 0's coarse residual, which stands in where the fine
    // search did not render 0.
    let (residuals, coarse_without) = if options.search_samples < options.samples {
        let s = search(
            GRID.len(),
            START,
            |g| residual(options.search_samples, g),
            |g| residual(options.samples, g),
        );
        (s.fine, s.coarse[0])
    } else {
        let r = descend(GRID.len(), START, |g| residual(options.samples, g));
        (r, None)
    };
    let Some(best) = least(&residuals) else {
        return SubsurfaceFit::Blind {
            reason: "neither the photos nor the renders show flash light on the material"
                .to_string(),
        };
    };
    // Both neighbours of the least point are rendered (or off the grid),
    // which is all the parabola reads.
    let filled: Vec<f64> = residuals.iter().map(|r| r.unwrap_or(f64::NAN)).collect();
    SubsurfaceFit::Measured {
        value: refined(&GRID, &filled, best),
        residual: filled[best],
        residual_without: residuals[0].or(coarse_without).unwrap_or(f64::NAN),
        curve: GRID
            .iter()
            .zip(&residuals)
            .filter_map(|(&g, r)| Some([f64::from(g), (*r)?]))
            .collect(),
        cells: cells.len(),
        seconds: t.elapsed().as_secs_f64(),
    }
}

/// The object under the flashes, as the measurement renders it: each
/// flash alone, from one camera, with one material over the whole object.
pub struct FlashRender<'a> {
    pub object: &'a ObjectGeometry<'a>,
    /// The backlight panel behind the object, which reflects the flashes'
    /// light back onto it, where its place is known: the simulator's, for
    /// the probe. The contract gives a rig's panel no pose, so the
    /// measurement renders without it.
    pub panel: Option<&'a Panel>,
    pub camera: PinholeCamera,
    pub flashes: &'a [PointLight],
    /// The pixels (cells, row-major) rendered; `None` for all. The
    /// measurement compares only the cells wholly of its materials, so the
    /// rest of the object is left black rather than rendered.
    pub cells: Option<&'a [usize]>,
    /// Path-tracing samples per pixel.
    pub samples: u32,
    pub seed: u64,
}

impl FlashRender<'_> {
    /// Per flash, the radiance of the object with `material`: one pass
    /// with one slot per flash, so the flashes share their paths.
    pub fn images(&self, material: &Material) -> PassImages {
        let env = Environment::off();
        let field = MaterialField::uniform(material);
        let pass = Pass {
            world: World::new(self.object, self.panel),
            camera: self.camera,
            env: &env,
            env_slot: None,
            flashes: self
                .flashes
                .iter()
                .enumerate()
                .map(|(slot, light)| (Flash::new(light), slot))
                .collect(),
            projector: None,
            backlight_slot: None,
            materials: MaterialMode::Authored(&field),
            slots: self.flashes.len(),
            max_depth: 8,
            clamp_indirect: DEFAULT_CLAMP_INDIRECT,
        };
        let key = PassKey {
            seed: self.seed,
            position: 0,
            pass: 0,
        };
        match self.cells {
            None => pass.render(self.samples, key),
            Some(cells) => {
                let (w, h) = (self.camera.intrinsics.width, self.camera.intrinsics.height);
                let mut keep = vec![false; w as usize * h as usize];
                for &k in cells {
                    if let Some(v) = keep.get_mut(k) {
                        *v = true;
                    }
                }
                pass.render_where(self.samples, key, |i| keep[i])
            }
        }
    }

    /// Per flash, [`Self::images`] summed over the channels, as
    /// [`FlashPhotos::light`] holds the photos.
    pub fn light(&self, material: &Material) -> Vec<Vec<f64>> {
        self.images(material)
            .slots
            .iter()
            .map(|s| {
                s.data
                    .iter()
                    .map(|v| v.iter().map(|&x| f64::from(x)).sum())
                    .collect()
            })
            .collect()
    }
}

/// The residuals of a grid of `len` points, `residual(g)` evaluated only
/// where the search needs it (`None` elsewhere): the first point, `start`
/// and its neighbours, then the unrendered neighbour of the least rendered
/// residual, until the least has both neighbours rendered (or is at the
/// grid's end). On a curve with one minimum past the first point that is
/// the whole grid's least point. The first point is always rendered
/// because it is another model (subsurface 0 is the Burley diffuse, any
/// more the random walk), so the curve may step between it and the rest;
/// it is also the reference "without". Where the first renders give no
/// finite residual, every point is rendered.
pub fn descend(len: usize, start: usize, residual: impl FnMut(usize) -> f64) -> Vec<Option<f64>> {
    walk(len, start, true, residual)
}

/// [`descend`], the first point rendered up front only where `with_first`
/// (else only when the walk reaches it, or when the first renders give no
/// finite residual and every point is rendered).
fn walk(
    len: usize,
    start: usize,
    with_first: bool,
    mut residual: impl FnMut(usize) -> f64,
) -> Vec<Option<f64>> {
    let mut r: Vec<Option<f64>> = vec![None; len];
    let start = start.min(len.saturating_sub(1));
    let first = start.saturating_sub(1)..(start + 2).min(len);
    for (g, v) in r.iter_mut().enumerate() {
        if (with_first && g == 0) || first.contains(&g) {
            *v = Some(residual(g));
        }
    }
    if least(&r).is_none() {
        for (g, v) in r.iter_mut().enumerate() {
            if v.is_none() {
                *v = Some(residual(g));
            }
        }
        return r;
    }
    while let Some(best) = least(&r) {
        let next = [best.checked_sub(1), Some(best + 1)]
            .into_iter()
            .flatten()
            .find(|&g| g < len && r[g].is_none());
        match next {
            Some(g) => r[g] = Some(residual(g)),
            None => break,
        }
    }
    r
}

/// [`descend`] twice: with the cheap `coarse` residual from `start`, then
/// with the `fine` one from the coarse search's least point, so the fine
/// renders are that point and its neighbours (and any step further
/// downhill where the coarse search landed beside the fine minimum), and
/// the first point unless the coarse search set it apart (below). The
/// candidates share their random numbers at either count of
/// samples, so the coarse curve has the fine one's shape and its noise
/// moves the least point by a grid step at most; the fine search walks that
/// step. The first point is left to the walk (rendered only if it reaches
/// it) where its coarse residual is more than [`FIRST_POINT_FAR`] times the
/// least: another model's step that large is not noise.
pub fn search(
    len: usize,
    start: usize,
    coarse: impl FnMut(usize) -> f64,
    fine: impl FnMut(usize) -> f64,
) -> Searched {
    let coarse = descend(len, start, coarse);
    let first = least(&coarse).unwrap_or(start);
    // A least point at or beside the first point renders it anyway (the
    // walk's first window), so the ratio alone decides.
    let far = matches!((coarse[0], coarse[first]), (Some(a), Some(b)) if a > FIRST_POINT_FAR * b);
    Searched {
        fine: walk(len, first, !far, fine),
        coarse,
    }
}

/// What [`search`] rendered: the residuals at its coarse and its fine
/// samples.
pub struct Searched {
    pub coarse: Vec<Option<f64>>,
    pub fine: Vec<Option<f64>>,
}

/// The grid point with the least finite residual among those rendered.
fn least(residuals: &[Option<f64>]) -> Option<usize> {
    residuals
        .iter()
        .enumerate()
        .filter_map(|(g, r)| Some((g, (*r).filter(|r| r.is_finite())?)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(g, _)| g)
}

/// Root-mean-square difference, over `cells` and flashes, of each flash's
/// share of a cell's light in `photo` and in `render`; NaN where no cell
/// has light in both.
pub fn share_residual(photo: &[Vec<f64>], render: &[Vec<f64>], cells: &[usize]) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for &k in cells {
        let p: f64 = photo.iter().map(|l| l[k]).sum();
        let r: f64 = render.iter().map(|l| l[k]).sum();
        if !(p > 0.0 && r > 0.0 && p.is_finite() && r.is_finite()) {
            continue;
        }
        for (pv, rv) in photo.iter().zip(render) {
            sum += (pv[k] / p - rv[k] / r).powi(2);
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (sum / n as f64).sqrt()
    }
}

/// The vertex of the parabola through `best` and its grid neighbours,
/// kept between them ([`super::parabola_vertex`]); the grid point itself
/// at the grid's ends or where the three do not bend upwards.
pub fn refined(grid: &[f32], residuals: &[f64], best: usize) -> f32 {
    if best == 0 || best + 1 >= grid.len().min(residuals.len()) {
        return grid[best];
    }
    let x = [best - 1, best, best + 1].map(|i| f64::from(grid[i]));
    let y = [best - 1, best, best + 1].map(|i| residuals[i]);
    super::parabola_vertex(x, y).map_or(grid[best], |v| v as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parabola_finds_a_minimum_between_grid_points() {
        let grid = [0.0, 0.1, 0.2, 0.3];
        // (s - 0.17)^2 sampled on the grid.
        let r: Vec<f64> = grid
            .iter()
            .map(|&s: &f32| (f64::from(s) - 0.17).powi(2))
            .collect();
        assert!((refined(&grid, &r, 2) - 0.17).abs() < 1e-4);
        // At the grid's end the grid point stands.
        assert_eq!(refined(&grid, &[0.1, 0.2, 0.3, 0.4], 0), 0.0);
        // A flat triple keeps the grid point.
        assert_eq!(refined(&grid, &[0.2, 0.2, 0.2, 0.3], 1), 0.1);
    }

    #[test]
    fn the_downhill_search_finds_the_grids_least_point_without_rendering_it_all() {
        for minimum in 0..8usize {
            let curve = |g: usize| (g as f64 - minimum as f64).powi(2) + 1.0;
            let mut calls = 0;
            let r = descend(8, START, |g| {
                calls += 1;
                curve(g)
            });
            assert_eq!(least(&r), Some(minimum));
            // Each point at most once, the neighbours of the least rendered.
            assert_eq!(calls, r.iter().flatten().count());
            assert!(minimum == 0 || r[minimum - 1].is_some());
            assert!(minimum == 7 || r[minimum + 1].is_some());
            assert!(r[0].is_some(), "the first point is always rendered");
            // 0 and 0.2 to 0.4 first, then one per step downhill and the far
            // neighbour of the least (at 0.1 the tie with 0 walks through 0).
            let expected = [5, 5, 5, 4, 5, 6, 7, 7];
            assert_eq!(calls, expected[minimum], "minimum {minimum}");
        }
    }

    #[test]
    fn the_search_renders_every_point_where_its_start_shows_nothing_and_survives_tiny_grids() {
        let r = descend(8, START, |g| if g < 5 { f64::NAN } else { g as f64 });
        // A step at the first point (another model) is found, not walked past.
        let step = descend(8, START, |g| {
            if g == 0 {
                0.5
            } else {
                (g as f64 - 3.0).abs() + 1.0
            }
        });
        assert_eq!(least(&step), Some(0));
        assert!(r.iter().all(Option::is_some));
        assert_eq!(least(&r), Some(5));
        assert!(descend(0, START, |_| 1.0).is_empty());
        assert_eq!(descend(1, START, |_| 2.0), vec![Some(2.0)]);
        let all_nan = descend(8, START, |_| f64::NAN);
        assert_eq!(least(&all_nan), None);
    }

    #[test]
    fn the_fine_search_renders_only_around_the_coarse_searchs_least_point() {
        for minimum in 0..8usize {
            let curve = |g: usize| (g as f64 - minimum as f64).powi(2) + 1.0;
            // The coarse curve's noise puts its least point a step off.
            let off = (minimum + 1).min(7);
            let coarse = |g: usize| (g as f64 - off as f64).powi(2) + 1.0;
            let mut fine_calls = Vec::new();
            let searched = search(8, START, coarse, |g| {
                fine_calls.push(g);
                curve(g)
            });
            let r = searched.fine;
            assert_eq!(least(&r), Some(minimum), "minimum {minimum}");
            assert!(searched.coarse[0].is_some(), "always rendered coarse");
            // The coarse curve puts the first point at off^2 + 1 against
            // its least 1: left out from two steps off, unless the walk
            // comes down to its neighbour.
            assert_eq!(r[0].is_some(), minimum <= 1, "minimum {minimum}");
            // The coarse least point and its neighbours (the first point
            // where it is near), then the one step downhill to the fine
            // least point and its far neighbour.
            let first = (off < 2).then_some(0);
            let mut expected: Vec<usize> = [off.saturating_sub(1), off, off + 1]
                .into_iter()
                .chain(first)
                .chain((minimum != off).then(|| minimum.saturating_sub(1)))
                .filter(|&g| g < 8)
                .collect();
            expected.sort_unstable();
            expected.dedup();
            let mut calls = fine_calls.clone();
            calls.sort_unstable();
            assert_eq!(calls, expected, "minimum {minimum}");
        }
        // A coarse search that sees nothing leaves the fine one its start.
        let r = search(8, START, |_| f64::NAN, |g| (g as f64 - 5.0).abs());
        assert_eq!(least(&r.fine), Some(5));
        // A first point near the least coarse residual is rendered fine
        // too, however far from it.
        let near = |g: usize| {
            if g == 0 {
                1.5
            } else {
                0.2 * (g as f64 - 5.0).abs() + 1.0
            }
        };
        let r = search(8, START, near, near);
        assert_eq!(least(&r.fine), Some(5));
        assert!(r.fine[0].is_some());
        // Left out up front, the first point is still rendered where the
        // first renders show nothing.
        let r = walk(8, 5, false, |_| f64::NAN);
        assert!(r.iter().all(Option::is_some), "{r:?}");
    }

    #[test]
    fn the_share_residual_ignores_the_texture_and_scale_that_multiply_every_flash() {
        let render = vec![vec![1.0, 2.0, 3.0], vec![3.0, 2.0, 1.0]];
        // The photo: the render times a texture per cell and a scale.
        let texture = [0.2, 0.9, 0.5];
        let photo: Vec<Vec<f64>> = render
            .iter()
            .map(|l| l.iter().zip(texture).map(|(v, t)| 7.0 * v * t).collect())
            .collect();
        assert!(share_residual(&photo, &render, &[0, 1, 2]) < 1e-12);
        // Swapping the flashes on one cell is seen.
        let mut swapped = photo.clone();
        swapped[0][0] = photo[1][0];
        swapped[1][0] = photo[0][0];
        let r = share_residual(&swapped, &render, &[0, 1, 2]);
        // Cell 0's shares go from (1/4, 3/4) to (3/4, 1/4): two differences
        // of 1/2 among six.
        assert!((r - (2.0 * 0.25f64 / 6.0).sqrt()).abs() < 1e-12, "{r}");
    }

    /// The product's options at this test's 24 cells across.
    const TEST_OPTIONS: ScatteringOptions = ScatteringOptions {
        cells: 24,
        samples: 128,
        search_samples: 32,
        min_cells: 16,
        seed: 7,
    };

    /// A sweep-subsurface sphere's object, reference camera at `cells`
    /// pixels across and flashes.
    fn sphere() -> (Mesh, PinholeCamera, Vec<PointLight>) {
        use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
        let scene = generate(&SceneOptions {
            seed: 5,
            kind: SceneKind::SweepSubsurface,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: 24,
            height: 24,
            positions: 1,
            map_size: 8,
        });
        let position = &scene.rig.positions[0];
        let camera = PinholeCamera::new(scene.rig.intrinsics, position.camera_to_world);
        (scene.mesh.clone(), camera, position.flashes.clone())
    }

    /// Photos of the sphere rendered at `subsurface` with other random
    /// numbers than the measurement's, and every cell that shows it.
    fn photos_at(subsurface: f32) -> (Mesh, FlashPhotos, Vec<usize>) {
        photos_with(Vec3::splat(0.5), subsurface)
    }

    /// The same with `basecolor`.
    fn photos_with(basecolor: Vec3, subsurface: f32) -> (Mesh, FlashPhotos, Vec<usize>) {
        let (mesh, camera, flashes) = sphere();
        let object = ObjectGeometry::new(&mesh);
        let material = Material {
            basecolor,
            roughness: 0.5,
            metallic: 0.0,
            transmission: 0.0,
            subsurface,
            subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
        };
        let light = FlashRender {
            object: &object,
            panel: None,
            camera,
            flashes: &flashes,
            cells: None,
            samples: 512,
            seed: 1234,
        }
        .light(&material);
        // The object's cells away from its silhouette, as the product's
        // cells wholly of a material are.
        let lit = |x: usize, y: usize| light.iter().all(|l| l[y * 24 + x] > 0.0);
        let cells = (0..24 * 24)
            .filter(|&k| {
                let (x, y) = (k % 24, k / 24);
                (1..23).contains(&x)
                    && (1..23).contains(&y)
                    && (0..9).all(|j| lit(x + j % 3 - 1, y + j / 3 - 1))
            })
            .collect();
        let photos = FlashPhotos {
            size: (24, 24),
            factor: 1,
            flashes,
            light,
            camera,
        };
        (mesh, photos, cells)
    }

    #[test]
    fn subsurface_on_a_black_basecolor_is_blind_with_the_reason() {
        // A black scattering material shows its specular lobe alone.
        let (mesh, photos, cells) = photos_with(Vec3::ZERO, 0.5);
        assert!(
            cells.len() >= TEST_OPTIONS.min_cells,
            "{} cells",
            cells.len()
        );
        let fit = measure(&mesh, &photos, &cells, Vec3::ZERO, 0.5, &TEST_OPTIONS);
        assert!(
            matches!(&fit, SubsurfaceFit::Blind { reason } if reason.contains("every subsurface")),
            "{fit:?}"
        );
        // A grey basecolor on the same photos is measured, finitely.
        let grey = measure(&mesh, &photos, &cells, Vec3::splat(0.5), 0.5, &TEST_OPTIONS);
        assert!(
            grey.value().is_some_and(|v| (0.0..=1.0).contains(&v)),
            "{grey:?}"
        );
    }

    #[test]
    fn rendering_only_the_measured_cells_gives_them_the_whole_renders_values() {
        let (mesh, camera, flashes) = sphere();
        let object = ObjectGeometry::new(&mesh);
        let material = Material {
            basecolor: Vec3::splat(0.5),
            subsurface: 0.3,
            ..Material::WHITE_DIFFUSE
        };
        let render = |cells| {
            FlashRender {
                object: &object,
                panel: None,
                camera,
                flashes: &flashes,
                cells,
                samples: 16,
                seed: 3,
            }
            .light(&material)
        };
        let whole = render(None);
        let cells: Vec<usize> = (0..24 * 24).filter(|k| k % 7 == 0).collect();
        let some = render(Some(&cells));
        for (w, s) in whole.iter().zip(&some) {
            for k in 0..24 * 24 {
                let expected = if k % 7 == 0 { w[k] } else { 0.0 };
                assert_eq!(s[k], expected, "cell {k}");
            }
        }
        // The sphere fills the middle: a kept cell there (301 = 7 x 43,
        // row 12, column 13) carries the flashes' light.
        assert!(some.iter().map(|l| l[301]).sum::<f64>() > 0.0);
    }

    #[test]
    fn a_scattering_sphere_is_measured_near_the_subsurface_it_was_rendered_with() {
        let (mesh, photos, cells) = photos_at(0.3);
        assert!(cells.len() > 60, "{} cells", cells.len());
        let fit = measure(&mesh, &photos, &cells, Vec3::splat(0.5), 0.5, &TEST_OPTIONS);
        let SubsurfaceFit::Measured {
            value,
            residual,
            residual_without,
            ..
        } = fit
        else {
            panic!("blind: {fit:?}");
        };
        assert!((value - 0.3).abs() <= 0.08, "measured {value}");
        assert!(
            residual_without > 2.0 * residual,
            "{residual_without} vs {residual}"
        );
    }

    #[test]
    fn an_opaque_sphere_is_measured_without_scattering() {
        let (mesh, photos, cells) = photos_at(0.0);
        let fit = measure(&mesh, &photos, &cells, Vec3::splat(0.5), 0.5, &TEST_OPTIONS);
        let value = fit.value().expect("measured");
        assert!(value <= 0.05, "measured {value}");
    }

    #[test]
    fn one_flash_too_few_cells_or_black_photos_are_blind_with_a_reason() {
        let (mesh, mut photos, cells) = photos_at(0.3);
        let options = ScatteringOptions::default();
        let few = measure(&mesh, &photos, &cells[..3], Vec3::splat(0.5), 0.5, &options);
        assert!(
            matches!(&few, SubsurfaceFit::Blind { reason } if reason.contains("3 cell(s)")),
            "{few:?}"
        );
        let mut black = photos.light.clone();
        for l in &mut photos.light {
            l.iter_mut().for_each(|v| *v = 0.0);
        }
        let dark = measure(&mesh, &photos, &cells, Vec3::splat(0.5), 0.5, &options);
        assert!(
            matches!(&dark, SubsurfaceFit::Blind { reason } if reason.contains("flash light")),
            "{dark:?}"
        );
        black.truncate(1);
        photos.light = black;
        photos.flashes.truncate(1);
        let one = measure(&mesh, &photos, &cells, Vec3::splat(0.5), 0.5, &options);
        assert!(
            matches!(&one, SubsurfaceFit::Blind { reason } if reason.contains("needs two")),
            "{one:?}"
        );
        // A NaN basecolor or roughness renders a mid grey rather than NaN.
        let (mesh, photos, cells) = photos_at(0.3);
        let fit = measure(&mesh, &photos, &cells, Vec3::NAN, f32::NAN, &options);
        assert!(fit.value().is_some_and(f32::is_finite), "{fit:?}");
    }

    #[test]
    fn dark_clipped_or_missing_cells_give_no_residual_rather_than_nan_arithmetic() {
        let dark = vec![vec![0.0, f64::NAN], vec![0.0, 1.0]];
        let render = vec![vec![1.0, 1.0], vec![1.0, 1.0]];
        assert!(share_residual(&dark, &render, &[0, 1]).is_nan());
        assert!(share_residual(&render, &render, &[]).is_nan());
    }
}
