//! The physical fit: basecolor, roughness and metallic measured from the
//! photos under the calibrated lights, without learning.
//!
//! 1. Every observation of a reference pixel in one place
//!    ([`crate::refine::observe`]): from every position and every lit
//!    capture with a calibrated light (the flashes and the projector's
//!    uniform field), lit minus ambient at the ambient exposure, the light
//!    per pixel `exposure · I · colour · level / (π d²)`, the local view
//!    and light directions, and a trust that drops shadowed, saturated and
//!    grazing views.
//! 2. A cost volume ([`linear`]): for each (roughness, metallic) of a grid
//!    the BSDF is affine in basecolor, so basecolor is solved in closed
//!    form per pixel and channel, and the pixel's robust residual is
//!    stored.
//! 3. Materials ([`materials`]): pixels are split by their own best
//!    answer's colour and the backlight's share seen through them (the
//!    nearest measured pixel's where unmeasured); each material's roughness and
//!    metallic is the grid point with the least summed cost over all its
//!    pixels (one pixel rarely sees a highlight, a material does), refined
//!    between grid points by a parabola in ln roughness. A material that
//!    scatters light inside takes its roughness from the views that look
//!    into its highlights ([`lobe`]).
//! 4. Basecolor per pixel in closed form at its material's roughness and
//!    metallic.
//!
//! The backlit photo ([`backlight`]) says per material whether any light
//! passes through it: one that passes light is fitted as a dielectric,
//! one that passes none without transmission, and one that passes light
//! and scatters none inside with the transmission the light through it
//! measures.
//!
//! What the photos cannot pin is reported, not invented: a material's
//! roughness is pinned when its cost curve over roughness has a clear
//! minimum (at the grid's roughest lobe only for a dielectric whose
//! direct light shows nothing but its surface: see
//! [`SURFACE_ONLY_SHARE`]), metallic when one choice explains the photos clearly better,
//! a pixel's basecolor when at least one observation counted. Where a
//! [`Fallback`] is given (the networks' answer), unpinned values come
//! from it: a material's roughness as its median over the material,
//! metallic pixel by pixel (metal and dielectric may alternate within one
//! colour) wherever the pixel's neighbourhood does not call it clearly
//! ([`neighbourhood`]).
//!
//! Transmission enters as a fixed input (the caller's map, 0 where the
//! backlight shows no light passing); subsurface is rendered as Burley
//! diffuse by the model, as in the refinement. After the fit, the
//! materials that scatter light inside get their subsurface measured by
//! rendering the scan's object under the flashes ([`scattering`]).
//!
//! Boundaries: no networks, and no file I/O beyond the bundle's manifest,
//! global-light photos and mesh; the pipeline hands in the scan's inputs
//! and writes what comes back.

pub mod backlight;
pub mod highlight;
pub mod linear;
pub mod lobe;
pub mod materials;
pub mod neighbourhood;
pub mod scattering;
pub mod separation;

use crate::pipeline::inputs::{SceneInputs, ViewPlanes};
use crate::refine::model::{directions, Fixed};
use crate::refine::observe::{
    calibrated_lighting, light_exposure, point_light, seen, ViewLighting,
};
use crate::refine::RefineError;
use backlight::{measure_backlight, Backlight, BacklightOptions, MaterialBacklight, Passage};
use highlight::{HighlightColour, HighlightOptions, TextureReadings};
use linear::{
    footprint_alpha2, responses, solve, solve_pulled, LinearFit, Noise, Pull, Response, Sample,
};
use lobe::LobeOptions;
use materials::{feature, split, Feature, Split, SplitOptions};
use matscan_calib::photos::quantile;
use matscan_calib::ScanCalibration;
use matscan_scan::{Bundle, Param};
use neighbourhood::NeighbourhoodOptions;
use rayon::prelude::*;
use scattering::{FlashPhotos, ScatteringOptions, SubsurfaceFit};
use serde::{Deserialize, Serialize};
use std::collections::hash_map::{Entry, HashMap};
use std::time::Instant;

/// The roughness grid: log-spaced from 0.02 (just above the delta
/// threshold, see `refine::model::ROUGHNESS_MIN`) to 1.
pub fn roughness_grid() -> Vec<f32> {
    const STEPS: usize = 16;
    let (lo, hi) = (0.02f64.ln(), 0.0f64);
    (0..STEPS)
        .map(|k| (lo + (hi - lo) * k as f64 / (STEPS - 1) as f64).exp() as f32)
        .collect()
}

/// Metallic is decided, not blended: real materials are metal or not (and
/// every scene kind's truth is 0 or 1).
pub const METALLIC_GRID: [f32; 2] = [0.0, 1.0];

/// How the fit runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    pub noise: Noise,
    pub split: SplitOptions,
    /// A channel counts as clipped at or above this fraction of the level
    /// its photo shows it clipped at (see
    /// [`matscan_calib::photos::clip_levels`]); a photo that shows no
    /// pile-up clips nowhere.
    pub saturation: f32,
    /// A material's roughness counts as pinned when the cost at the grid's
    /// worst roughness exceeds the best by at least this fraction.
    pub roughness_contrast: f64,
    /// Metallic counts as pinned when the other choice costs at least this
    /// fraction more.
    pub metallic_contrast: f64,
    /// Islands of another material up to about this radius in pixels
    /// join the material around them (see [`mode_filter`]).
    pub island_radius: usize,
    /// Strength of the pull of a pixel's basecolor toward its material's
    /// (see [`linear::Pull`]).
    pub basecolor_pull: f64,
    /// Which light the surface is fitted to.
    pub light: FitLight,
    /// Whether light passes through each material, read from the backlit
    /// photo ([`backlight`]); `None` leaves it unread.
    pub backlight: Option<BacklightOptions>,
    /// How a metal's highlights are pooled into its colour.
    pub highlight: HighlightOptions,
    /// How a scattering material's roughness is read from its highlights
    /// ([`lobe`]); `None` leaves such a material to its total light's fit.
    pub lobe: Option<LobeOptions>,
    /// How a pixel of a material whose photos pin no metallic takes its
    /// metallic from its neighbourhood ([`neighbourhood`]); `None` leaves
    /// every such pixel to the fallback.
    pub neighbourhood: Option<NeighbourhoodOptions>,
    /// How a scattering material's subsurface is measured by rendering the
    /// scan's object ([`scattering`]); `None` leaves it to the networks.
    pub scattering: Option<ScatteringOptions>,
}

/// Which part of the photos' light the surface BSDF is fitted to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FitLight {
    /// Lit minus ambient as it is: direct light and global light
    /// (interreflections, light scattered inside) together.
    Total,
    /// The direct light: the global light measured with the projector's
    /// checker ([`separation`]) subtracted from every view. A scan without
    /// a checker capture is fitted to its total light, with a note. On
    /// `tune` it lowers metallic's MAD against the total light (0.140 to
    /// 0.130) and roughness's (0.184 to 0.174) for 0.002 of basecolor's.
    Direct,
    /// The direct light, except for a material whose measured global light
    /// is at least [`SCATTERING_SHARE`] of its total light: light that
    /// scatters inside before it leaves is part of what such a material
    /// reflects, so it is fitted to its total light, which also decides its
    /// metallic (a large share is also what a concave metal reflects onto
    /// itself, so it does not rule a metal out). The default: on `tune`,
    /// under `fit-dielectric`, it lowers basecolor's MAD against the direct
    /// light by a third, and metallic's from 0.130 to 0.122
    /// (docs/results.md).
    #[default]
    Material,
}

/// Records in each material that passes light and scatters none inside
/// its transmission, measured from the light seen through it and its
/// diffuse albedo's luma (`albedo(pixel, material)`): the median over its
/// pixels of [`backlight::transmission_from`] (per pixel, or with the
/// pixels that show no light through set to 0, measured worse on `tune`).
fn clear_transmission<A>(
    materials: &mut [MaterialFit],
    labels: &[Option<usize>],
    backlight: &Backlight,
    options: &BacklightOptions,
    albedo: A,
) where
    A: Fn(usize, &MaterialFit) -> Option<f32> + Sync,
{
    for (j, m) in materials.iter_mut().enumerate() {
        if !(m.passes_light() && m.scatters_none() && !m.scattering) {
            continue;
        }
        let seen: Vec<(usize, f32)> = (0..labels.len())
            .into_par_iter()
            .filter(|&i| labels[i] == Some(j))
            .filter_map(|i| Some((i, albedo(i, m)?)))
            .collect();
        m.transmission = backlight.transmission(&seen, options);
    }
}

/// The share of a material's lit-minus-ambient light that is global at
/// which [`FitLight::Material`] fits it to its total light. On a convex
/// opaque object the global light is interreflection, a few per cent of
/// what a point reflects; light scattered under the surface is a large
/// share of it (the checker's blur).
pub const SCATTERING_SHARE: f64 = 0.3;

/// A material's global share below which its global light is no more
/// than a surface reflects onto itself. On `tune` most opaque dielectrics
/// show under 0.02 (one in a concave blob 0.06), glossy glass, which
/// refracts the checker, 0.07, and subsurface scattering 0.1 and up: a
/// material above it is not trusted to be a rough surface when its
/// roughest lobe wins.
pub const SURFACE_ONLY_SHARE: f64 = 0.03;

impl FitLight {
    pub const ALL: [FitLight; 3] = [FitLight::Total, FitLight::Direct, FitLight::Material];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            FitLight::Total => "total",
            FitLight::Direct => "direct",
            FitLight::Material => "material",
        }
    }
}

impl std::fmt::Display for FitLight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A `--fit-light` value that is not one.
#[derive(Debug, thiserror::Error)]
#[error("unknown fit light {0:?}: expected total, direct or material")]
pub struct UnknownFitLight(pub String);

impl std::str::FromStr for FitLight {
    type Err = UnknownFitLight;

    fn from_str(s: &str) -> Result<FitLight, UnknownFitLight> {
        FitLight::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| UnknownFitLight(s.to_string()))
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            noise: Noise::default(),
            split: SplitOptions::default(),
            saturation: 0.99,
            roughness_contrast: 0.05,
            metallic_contrast: 0.05,
            island_radius: 2,
            basecolor_pull: 2.0,
            light: FitLight::default(),
            backlight: Some(BacklightOptions::default()),
            highlight: HighlightOptions::default(),
            lobe: Some(LobeOptions::default()),
            neighbourhood: Some(NeighbourhoodOptions::default()),
            scattering: Some(ScatteringOptions::default()),
        }
    }
}

/// The values to use where the photos pin nothing (the networks' answer),
/// per reference pixel.
#[derive(Clone, Copy, Debug)]
pub struct Fallback<'a> {
    pub basecolor: &'a [[f32; 3]],
    pub roughness: &'a [f32],
    pub metallic: &'a [f32],
}

/// What the fit is told rather than finds. Values it must not change
/// (given by the user, or skipped), per reference pixel: a material takes
/// their median, and basecolor is solved under it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Known<'a> {
    pub roughness: Option<&'a [f32]>,
    pub metallic: Option<&'a [f32]>,
    /// The materials, per reference pixel, in place of the fit's own split
    /// (the error budget's segmentation oracle).
    pub labels: Option<&'a [Option<usize>]>,
    /// The backlight's measurement of the reference image: a material
    /// that passes light is fitted as a dielectric, one that passes none
    /// is fitted without transmission.
    pub backlight: Option<&'a Backlight>,
    /// The subsurface the scan's scattering materials measured at another
    /// position ([`scattering::measure`]): a material property, so the
    /// renders (the fit's costliest step) run once per scan and every
    /// other position's scattering materials take it.
    pub subsurface: Option<&'a SubsurfaceFit>,
}

/// What the fit found of one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialFit {
    /// Pixels of the reference image in the material.
    pub pixels: usize,
    /// Mean fitted basecolor.
    pub basecolor: [f32; 3],
    pub roughness: f32,
    pub metallic: f32,
    /// Whether the photos pinned roughness (else it is the fallback's
    /// median, or the fit's flat best guess without a fallback).
    pub roughness_pinned: bool,
    pub metallic_pinned: bool,
    /// Fitted to its total light, not its direct light: the direct light
    /// pinned it as metal and the total light did not, the signature of a
    /// material that scatters light inside or through it; or, under
    /// [`FitLight::Material`], its measured global share was at least
    /// [`SCATTERING_SHARE`].
    #[serde(default)]
    pub scattering: bool,
    /// What the backlight showed of it; `None` where unread (no backlit
    /// photo, too few facing pixels).
    #[serde(default)]
    pub backlight: Option<MaterialBacklight>,
    /// The share of its lit-minus-ambient light that is global, where the
    /// checker separated it (under [`FitLight::Material`]).
    #[serde(default)]
    pub global_share: Option<f32>,
    /// Its transmission, measured through it with the backlight, where it
    /// passes light and scatters none inside
    /// ([`backlight::transmission_from`]).
    #[serde(default)]
    pub transmission: Option<f32>,
    /// A pinned metal's colour from its pooled highlights
    /// ([`highlight::colour`]), or why they cannot say.
    #[serde(default)]
    pub highlight: Option<HighlightColour>,
    /// A material whose basecolor mean is its highlights' colour or the
    /// networks': per channel, the share of its pixels' texture kept, where
    /// the fit's own and the networks' readings agree
    /// ([`Fitted::basecolor_texture_into`]).
    #[serde(default)]
    pub texture_kept: Option<[f32; 3]>,
    /// A material that scatters light inside or passes the backlight,
    /// whose roughness its views near the mirror direction pinned
    /// ([`lobe`]): how many of its pixels had such a view.
    #[serde(default)]
    pub lobe_pixels: Option<usize>,
    /// A material whose photos pinned no metallic, or a mixed one
    /// (`metallic_mixed`): how many of its pixels took metallic from their
    /// neighbourhood's photos ([`neighbourhood`]).
    #[serde(default)]
    pub neighbourhood_pixels: Option<usize>,
    /// A material whose photos pinned its metallic, the backlight did not:
    /// the share of its pixels' clear neighbourhood calls (over its own
    /// pixels) that contradict that call ([`neighbourhood::member_calls`]).
    #[serde(default)]
    pub contrary_calls: Option<f32>,
    /// That share reached [`NeighbourhoodOptions::mixed_share`]: the
    /// material holds metal and dielectric alike, and its metallic is per
    /// pixel as an open material's (the neighbourhood's call, else the
    /// networks').
    #[serde(default)]
    pub metallic_mixed: bool,
    /// A dielectric that scatters light inside: its subsurface as the
    /// renders of the scan's object under the flashes measured it
    /// ([`scattering`]), or why they could not.
    #[serde(default)]
    pub subsurface: Option<SubsurfaceFit>,
}

impl MaterialFit {
    /// Whether the backlight showed light passing through it.
    pub fn passes_light(&self) -> bool {
        self.backlight.is_some_and(|b| b.passage == Passage::Passes)
    }

    /// Whether the backlight showed no light passing through it.
    pub fn blocks_light(&self) -> bool {
        self.backlight
            .is_some_and(|b| b.passage == Passage::Blocked)
    }

    /// Whether its global share was measured and is below
    /// [`SCATTERING_SHARE`]: it scatters no light inside.
    pub fn scatters_none(&self) -> bool {
        self.global_share
            .is_some_and(|s| f64::from(s) < SCATTERING_SHARE)
    }

    /// Whether the fit's own basecolor answers it: a dielectric that is
    /// opaque (no light scattered inside, none seen through) or transmits
    /// what the backlight measured, whose basecolor is its diffuse albedo.
    pub fn basecolor_fitted(&self) -> bool {
        self.metallic < 0.5
            && !self.scattering
            && (!self.passes_light() || self.transmission.is_some())
    }

    /// Whether the photos show the material has no `kind` (transmission
    /// or subsurface): a dielectric the backlight shows passing no light
    /// has neither transmission nor light scattered through it; one that
    /// scatters none inside has no subsurface. A metal hides both (their
    /// weights are zero in it).
    pub fn lacks(&self, kind: Param) -> bool {
        self.metallic < 0.5
            && match kind {
                Param::Transmission => self.blocks_light(),
                Param::Subsurface => self.blocks_light() || self.scatters_none(),
                _ => false,
            }
    }
}

/// Per parameter, the share of the object's pixels whose value the photos
/// pinned (for basecolor: measured, or shaped its texture; see
/// [`Fitted::basecolor_texture_into`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Constrained {
    pub basecolor: f32,
    pub roughness: f32,
    pub metallic: f32,
    /// Transmission and subsurface: the share the photos measured (0 where
    /// they show the material lacks them, or a measured transmission; see
    /// [`Fitted::measured_into`]).
    #[serde(default)]
    pub transmission: f32,
    #[serde(default)]
    pub subsurface: f32,
}

/// The fit of one reference image.
#[derive(Clone, Debug, PartialEq)]
pub struct Fitted {
    pub basecolor: Vec<[f32; 3]>,
    pub roughness: Vec<f32>,
    pub metallic: Vec<f32>,
    /// Material index per pixel (`None` outside the mask or unfitted).
    pub labels: Vec<Option<usize>>,
    pub materials: Vec<MaterialFit>,
    pub constrained: Constrained,
    /// Views left out, and similar.
    pub notes: Vec<String>,
    /// The whole fit, the measurements included.
    pub seconds: f64,
    pub measured: MeasureSeconds,
}

/// Seconds of the fit's two measurements of light beyond the surface lobe
/// (0 for one that did not run): what they add to a scan's fit (reading
/// the backlit photo is part of assembling the inputs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeasureSeconds {
    /// The backlight's transmission ([`measure_backlight`]).
    pub backlight: f64,
    /// The checkers' scattering: the mesh read, the flash photos averaged
    /// into cells and the subsurface renders ([`scattering::measure`]).
    pub scattering: f64,
}

impl std::ops::AddAssign for MeasureSeconds {
    fn add_assign(&mut self, other: Self) {
        self.backlight += other.backlight;
        self.scattering += other.scattering;
    }
}

impl Fitted {
    /// Writes the fitted roughness into `roughness` at the pixels whose
    /// material pinned it, leaving every other pixel as it was.
    pub fn pinned_roughness_into(&self, roughness: &mut [f32]) {
        for ((r, label), fit) in roughness.iter_mut().zip(&self.labels).zip(&self.roughness) {
            let pinned = label
                .and_then(|j| self.materials.get(j))
                .is_some_and(|m| m.roughness_pinned);
            if pinned && fit.is_finite() {
                *r = *fit;
            }
        }
    }
}

impl Fitted {
    /// Writes into `map` of `kind` (transmission or subsurface) what the
    /// photos measured: 0 at the pixels of the materials they show lack it
    /// ([`MaterialFit::lacks`]), a material's measured transmission or
    /// subsurface,
    /// leaving every other pixel as it was; returns the share of the
    /// fitted pixels written.
    pub fn measured_into(&self, kind: Param, map: &mut [f32]) -> f32 {
        let (mut written, mut fitted) = (0usize, 0usize);
        for (v, label) in map.iter_mut().zip(&self.labels) {
            let Some(m) = label.and_then(|j| self.materials.get(j)) else {
                continue;
            };
            fitted += 1;
            let subsurface = m.subsurface.as_ref().and_then(SubsurfaceFit::value);
            let measured = match (kind, m.transmission, subsurface) {
                (Param::Transmission, Some(t), _) => Some(t),
                (Param::Subsurface, _, Some(s)) => Some(s),
                _ => m.lacks(kind).then_some(0.0),
            };
            if let Some(value) = measured {
                *v = value;
                written += 1;
            }
        }
        if fitted == 0 {
            0.0
        } else {
            written as f32 / fitted as f32
        }
    }

    /// Writes the fitted basecolor into `basecolor` at the pixels of the
    /// materials the fit reads as opaque dielectrics (dielectric, no light
    /// scattered inside, none seen through), leaving every other pixel as
    /// it was;
    /// returns the share of the fitted pixels written.
    pub fn dielectric_basecolor_into(&self, basecolor: &mut [[f32; 3]]) -> f32 {
        let (mut written, mut fitted) = (0usize, 0usize);
        for ((b, label), fit) in basecolor.iter_mut().zip(&self.labels).zip(&self.basecolor) {
            let Some(m) = label.and_then(|j| self.materials.get(j)) else {
                continue;
            };
            fitted += 1;
            if m.basecolor_fitted() && fit.iter().all(|v| v.is_finite()) {
                *b = fit.map(|v| v.clamp(0.0, 1.0));
                written += 1;
            }
        }
        if fitted == 0 {
            0.0
        } else {
            written as f32 / fitted as f32
        }
    }
}

impl Fitted {
    /// Gives every material whose basecolor the fit does not answer itself
    /// ([`MaterialFit::basecolor_fitted`]) the texture its photos support:
    /// a metal whose highlights measured its colour
    /// ([`MaterialFit::highlight`]) takes that colour as its mean, any
    /// other material whose metallic the photos pinned keeps the mean of
    /// `basecolor` (the networks' answer, which this overwrites); within
    /// it, the share of the texture its two readings agree on
    /// ([`TextureReadings`]): the fit's own per-pixel answers and the
    /// networks', each relative to its mean over the material. A material
    /// whose metallic is open (a per-pixel map) keeps the networks' answer
    /// as it is (reading it too lost on multimat, docs/results.md), and so
    /// does a material whose networks' mean is about black (at most 1e-3)
    /// in a channel: there is no texture to compare. A mixed material
    /// (`metallic_mixed`) counts as pinned: its mean and readings are
    /// taken over the pixels of both metallics. The share kept, per
    /// channel, goes into the material's `texture_kept`.
    /// Returns the share of the fitted pixels written: the photos measured
    /// their mean (a metal's highlights) or shaped their texture.
    pub fn basecolor_texture_into(&mut self, basecolor: &mut [[f32; 3]]) -> f32 {
        debug_assert_eq!(basecolor.len(), self.labels.len());
        let count = self.materials.len();
        let networks = channel_means(basecolor, &self.labels, count);
        let own = channel_means(&self.basecolor, &self.labels, count);
        // Per material, the mean it takes (`None`: left as the networks
        // answered).
        let means: Vec<Option<[f32; 3]>> = self
            .materials
            .iter()
            .zip(&networks)
            .map(
                |(m, n)| match m.highlight.as_ref().and_then(|h| h.colour()) {
                    Some(colour) => Some(colour),
                    None if m.metallic_pinned && !m.basecolor_fitted() => {
                        let [Some(r), Some(g), Some(b)] = *n else {
                            return None;
                        };
                        Some([r as f32, g as f32, b as f32])
                    }
                    None => None,
                },
            )
            .collect();
        // A pixel's material and the mean it takes, where it takes one.
        let material = |label: &Option<usize>| {
            let j = label.filter(|&j| j < count)?;
            Some((j, means[j]?))
        };
        // A pixel's two deviations in channel `c`, where both readings
        // have one (a channel read black has no texture to read).
        let deviations = |j: usize, own_value: &[f32; 3], networks_value: &[f32; 3], c: usize| {
            let deviation = |v: f32, mean: Option<f64>| {
                mean.filter(|_| v.is_finite())
                    .map(|m| f64::from(v) / m - 1.0)
            };
            Some((
                deviation(own_value[c], own[j][c])?,
                deviation(networks_value[c], networks[j][c])?,
            ))
        };
        let mut readings = vec![TextureReadings::default(); count];
        for ((b, f), label) in basecolor.iter().zip(&self.basecolor).zip(&self.labels) {
            if let Some((j, _)) = material(label) {
                for c in 0..3 {
                    if let Some((x, y)) = deviations(j, f, b, c) {
                        readings[j].add(c, x, y);
                    }
                }
            }
        }
        let kept: Vec<[f32; 3]> = readings.iter().map(TextureReadings::kept).collect();
        let fitted = self
            .labels
            .iter()
            .filter(|l| l.is_some_and(|j| j < count))
            .count();
        let mut written = 0usize;
        for ((b, f), label) in basecolor.iter_mut().zip(&self.basecolor).zip(&self.labels) {
            let Some((j, colour)) = material(label) else {
                continue;
            };
            for c in 0..3 {
                let texture = deviations(j, f, &*b, c).map_or(0.0, |(x, y)| 0.5 * (x + y));
                let v = f64::from(colour[c]) * (1.0 + f64::from(kept[j][c]) * texture);
                b[c] = if v.is_finite() {
                    (v as f32).clamp(0.0, 1.0)
                } else {
                    0.0
                };
            }
            written += 1;
        }
        for ((m, k), mean) in self.materials.iter_mut().zip(kept).zip(&means) {
            if mean.is_some() {
                m.texture_kept = Some(k);
            }
        }
        if fitted == 0 {
            0.0
        } else {
            written as f32 / fitted as f32
        }
    }
}

/// Per material and channel, the mean of `values` over its pixels, where
/// it is above 1e-3 (a reading of about black has no texture to compare).
fn channel_means(
    values: &[[f32; 3]],
    labels: &[Option<usize>],
    count: usize,
) -> Vec<[Option<f64>; 3]> {
    let mut sums = vec![([0.0f64; 3], 0usize); count];
    for (v, label) in values.iter().zip(labels) {
        if let Some(j) = *label {
            if j < count && v.iter().all(|x| x.is_finite()) {
                for (s, x) in sums[j].0.iter_mut().zip(v) {
                    *s += f64::from(*x);
                }
                sums[j].1 += 1;
            }
        }
    }
    sums.iter()
        .map(|(sum, n)| {
            std::array::from_fn(|c| {
                let mean = sum[c] / (*n).max(1) as f64;
                (*n > 0 && mean > 1e-3).then_some(mean)
            })
        })
        .collect()
}

/// One pixel's cost and basecolor at each grid point (metallic-major),
/// from its own photos alone.
struct Volume {
    cost: Vec<f64>,
    basecolor: Vec<[f32; 3]>,
}

/// Fits the reference image of `inputs`. `transmission` is the fixed
/// transmission per pixel (the networks' or the user's).
pub fn fit_scene(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    transmission: &[f32],
    known: Known<'_>,
    fallback: Option<Fallback<'_>>,
    options: &FitOptions,
) -> Result<Fitted, RefineError> {
    let t = Instant::now();
    let mut notes = Vec::new();
    let mut lighting: Vec<Option<ViewLighting>> = Vec::with_capacity(inputs.views.len());
    for planes in &inputs.views {
        let l = calibrated_lighting(
            bundle,
            calibration,
            &inputs.reference,
            planes,
            options.saturation,
        )?;
        if l.is_none() {
            notes.push(format!(
                "view {}: the manifest gives no light intensity or a patterned light; left \
                 out of the fit",
                planes.view
            ));
        }
        lighting.push(l);
    }
    if options.light != FitLight::Total {
        subtract_global(bundle, calibration, inputs, &mut lighting, &mut notes)?;
    }
    let t_backlight = Instant::now();
    let backlight = match (&options.backlight, known.backlight) {
        (Some(o), None) => match measure_backlight(inputs, o) {
            Ok(b) => Some(b),
            Err(why) => {
                notes.push(format!(
                    "{why}: whether light passes through the materials is not read"
                ));
                None
            }
        },
        _ => None,
    };
    let backlight_s = t_backlight.elapsed().as_secs_f64();
    let known = Known {
        backlight: known.backlight.or(backlight.as_ref()),
        ..known
    };
    let mask = &inputs.mask.data;
    let mut fitted = fit_pixels(
        mask,
        inputs.width,
        |i| samples(inputs, &lighting, i),
        transmission,
        known,
        fallback,
        options,
    );
    let t_scattering = Instant::now();
    measure_subsurface(
        bundle,
        inputs,
        &mut fitted,
        transmission,
        fallback,
        known.subsurface,
        options,
    )?;
    notes.append(&mut fitted.notes);
    fitted.notes = notes;
    fitted.measured = MeasureSeconds {
        backlight: backlight_s,
        scattering: t_scattering.elapsed().as_secs_f64(),
    };
    fitted.seconds = t.elapsed().as_secs_f64();
    Ok(fitted)
}

/// The median transmission from which a material counts as clear for
/// [`measure_subsurface`].
pub const CLEAR_TRANSMISSION: f32 = 0.5;

/// Whether [`scattering`] measures the material: a dielectric whose
/// measured global share says it scatters light inside, with no
/// transmission measured through it (a clear material's global light is
/// the checker refracted, not scattered).
fn scatters_inside(m: &MaterialFit) -> bool {
    m.metallic < 0.5
        && !m.lacks(Param::Subsurface)
        && m.transmission.is_none()
        && m.global_share
            .is_some_and(|s| f64::from(s) >= SCATTERING_SHARE)
}

/// Measures the subsurface of the materials that scatter light inside
/// ([`scatters_inside`]) and that `transmission` does not call clear,
/// together, from the reference position's flash
/// photos, with the basecolor the fallback gives them (its median over
/// them; the fit's own where there is none, though a scattering material's
/// surface fit reads dark) and their median fitted roughness; or gives
/// them what another position `measured`.
fn measure_subsurface(
    bundle: &Bundle,
    inputs: &SceneInputs,
    fitted: &mut Fitted,
    transmission: &[f32],
    fallback: Option<Fallback<'_>>,
    measured: Option<&SubsurfaceFit>,
    options: &FitOptions,
) -> Result<(), RefineError> {
    let Some(scattering) = &options.scattering else {
        return Ok(());
    };
    // A material the transmission map (the networks' or the user's) calls
    // clear shows the checker refracted, not scattered: its global share
    // says nothing of how far light travels under its surface.
    let clear = |j: usize| {
        let mut t: Vec<f32> = (0..fitted.labels.len())
            .filter(|&i| fitted.labels[i] == Some(j))
            .filter_map(|i| transmission.get(i).copied())
            .collect();
        quantile(&mut t, 0.5).is_some_and(|t| t >= CLEAR_TRANSMISSION)
    };
    let chosen: Vec<usize> = (0..fitted.materials.len())
        .filter(|&j| scatters_inside(&fitted.materials[j]) && !clear(j))
        .collect();
    if chosen.is_empty() {
        return Ok(());
    }
    if let Some(fit) = measured {
        for j in chosen {
            fitted.materials[j].subsurface = Some(fit.clone());
        }
        return Ok(());
    }
    let photos = match FlashPhotos::new(bundle, inputs, scattering, options.saturation)? {
        Ok(p) => p,
        Err(reason) => {
            for &j in &chosen {
                fitted.materials[j].subsurface = Some(SubsurfaceFit::Blind {
                    reason: reason.clone(),
                });
            }
            return Ok(());
        }
    };
    // The scattering materials are measured together: the fit's split
    // cuts one scattering material into several by the texture its light
    // shows, each often too small for a cell, and the render gives the
    // whole object one material anyway.
    let labels = &fitted.labels;
    let member = |i: usize| labels[i].is_some_and(|j| chosen.contains(&j));
    let cells = photos.cells_of(inputs.width, member);
    let members: Vec<usize> = (0..labels.len()).filter(|&i| member(i)).collect();
    let median = |value: &dyn Fn(usize, usize) -> f32| {
        glam::Vec3::from_array(std::array::from_fn(|c| {
            let mut v: Vec<f32> = members.iter().map(|&i| value(i, c)).collect();
            quantile(&mut v, 0.5).unwrap_or(0.5)
        }))
    };
    let basecolor = match fallback {
        Some(f) => median(&|i, c| f.basecolor[i][c]),
        None => median(&|i, c| fitted.basecolor[i][c]),
    };
    let roughness = median(&|i, _| fitted.roughness[i]).x;
    let fit = scattering::measure(
        &bundle.read_mesh()?,
        &photos,
        &cells,
        basecolor,
        roughness,
        scattering,
    );
    for j in chosen {
        fitted.materials[j].subsurface = Some(fit.clone());
    }
    Ok(())
}

/// Gives every calibrated view the global light its light puts on each
/// reference pixel: its position's global light at full projector white
/// ([`separation::global_light`], warped into the reference once) scaled
/// by the ratio of the view's calibrated light to the projector's.
fn subtract_global(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    lighting: &mut [Option<ViewLighting>],
    notes: &mut Vec<String>,
) -> Result<(), RefineError> {
    let mut by_position: HashMap<&str, Option<ReferenceGlobal>> = HashMap::new();
    for (planes, lighting) in inputs.views.iter().zip(lighting.iter_mut()) {
        let Some(lighting) = lighting.as_mut() else {
            continue;
        };
        let position = planes.view.position.as_str();
        let global = match by_position.entry(position) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => e.insert(reference_global(
                bundle,
                calibration,
                inputs,
                planes,
                notes,
            )?),
        };
        if let Some(global) = global {
            lighting.global = Some(global.under(&lighting.light));
        }
    }
    Ok(())
}

/// One position's global light at full projector white and the
/// projector's calibrated light, both per reference pixel.
struct ReferenceGlobal {
    /// NaN where unmeasured.
    rgb: Vec<[f32; 3]>,
    projector: Vec<[f32; 3]>,
}

impl ReferenceGlobal {
    /// The global light that a view whose calibrated light is `light`
    /// puts on each pixel (NaN where unmeasured).
    fn under(&self, light: &[[f32; 3]]) -> Vec<[f32; 3]> {
        self.rgb
            .iter()
            .zip(&self.projector)
            .zip(light)
            .map(|((g, p), l)| {
                std::array::from_fn(|c| {
                    if p[c] > 0.0 && p[c].is_finite() {
                        g[c] * l[c] / p[c]
                    } else {
                        f32::NAN
                    }
                })
            })
            .collect()
    }
}

/// The global light of `planes`' position in the reference, or `None`
/// with a note saying why the fit takes that position's light as direct.
fn reference_global(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    planes: &ViewPlanes,
    notes: &mut Vec<String>,
) -> Result<Option<ReferenceGlobal>, RefineError> {
    let position = planes.view.position.as_str();
    let global = match separation::global_light(bundle, calibration, position)? {
        Ok(g) => g,
        Err(why) => {
            notes.push(format!("{why}: the fit takes the photos' light as direct"));
            return Ok(None);
        }
    };
    let Some(projector) = point_light(
        bundle,
        calibration,
        &inputs.reference,
        position,
        &global.projector,
        light_exposure(planes),
    )?
    else {
        notes.push(format!(
            "position {position}: no intensity of `{}`: the fit takes the photos' light as direct",
            global.projector
        ));
        return Ok(None);
    };
    let rgb = if position == inputs.reference {
        global.rgb.data
    } else {
        calibration
            .correspondence(&inputs.reference, position)
            .ok_or_else(|| RefineError::MissingMaps(position.to_string()))?
            .warp_rgb(&global.rgb, "global light")?
            .data
    };
    notes.push(format!(
        "position {position}: global light separated with the checker of `{}`, \
         measured on {:.0} % of the object",
        global.projector,
        100.0 * global.measured
    ));
    Ok(Some(ReferenceGlobal {
        rgb,
        projector: projector.light,
    }))
}

/// [`fit_scene`] for any source of observations: `observe(pixel)` returns
/// the pixel's usable observations.
pub fn fit_pixels<F>(
    mask: &[bool],
    width: usize,
    observe: F,
    transmission: &[f32],
    known: Known<'_>,
    fallback: Option<Fallback<'_>>,
    options: &FitOptions,
) -> Fitted
where
    F: Fn(usize) -> Vec<Sample> + Sync,
{
    let t = Instant::now();
    let n = mask.len();
    let grid = roughness_grid();
    // `opaque`: the pixel's material passes no light (the backlight), so
    // it has no transmission whatever the caller's map says.
    let fixed_at = |i: usize, opaque: bool| Fixed {
        transmission: if opaque {
            0.0
        } else {
            transmission.get(i).copied().unwrap_or(0.0)
        },
    };
    let transmits = |i: usize| transmission.get(i).is_some_and(|&t| t > 0.0);
    let total_light: Vec<Vec<Sample>> = (0..n)
        .into_par_iter()
        .map(|i| if mask[i] { observe(i) } else { Vec::new() })
        .collect();
    // The surface is fitted to the direct light; where global light was
    // measured, the total light is fitted too, for materials that scatter
    // light inside (see `scattering`).
    let separated = total_light
        .iter()
        .flatten()
        .any(|s| s.global.iter().any(|&g| g > 0.0));
    let direct: Option<Vec<Vec<Sample>>> = separated.then(|| {
        total_light
            .par_iter()
            .map(|obs| obs.iter().map(Sample::direct).collect())
            .collect()
    });
    let direct_at =
        |i: usize| -> &[Sample] { direct.as_ref().unwrap_or(&total_light)[i].as_slice() };
    let volume_of = |i: usize, obs: &[Sample], opaque: bool| -> Option<Volume> {
        if !mask[i] || obs.is_empty() {
            return None;
        }
        let fixed = fixed_at(i, opaque);
        let points = grid.len() * METALLIC_GRID.len();
        let mut cost = Vec::with_capacity(points);
        let mut basecolor = Vec::with_capacity(points);
        let mut weight = 0.0;
        for &m in &METALLIC_GRID {
            for &r in &grid {
                let fit = solve(obs, &responses(obs, r, m, &fixed), &options.noise);
                cost.push(fit.cost);
                basecolor.push(fit.basecolor);
                weight = fit.weight;
            }
        }
        (weight > 0.0).then_some(Volume { cost, basecolor })
    };
    let volumes: Vec<Option<Volume>> = (0..n)
        .into_par_iter()
        .map(|i| volume_of(i, direct_at(i), false))
        .collect();

    // Each pixel's apparent albedo (as a rough dielectric) places it among
    // the materials: it needs no choice of roughness or metallic, which
    // one pixel's few views cannot make.
    let reference = grid
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - 0.5).abs().total_cmp(&(b.1 - 0.5).abs()))
        .map_or(0, |(k, _)| k);
    let seen_through = known
        .backlight
        .map_or_else(|| vec![0.0; n], |b| b.filled(mask, width));
    let features: Vec<Option<Feature>> = volumes
        .iter()
        .zip(&seen_through)
        .map(|(v, &t)| Some(feature(v.as_ref()?.basecolor[reference], t)))
        .collect();
    let parts = match known.labels {
        // Given materials keep only the pixels the fit can place.
        Some(labels) => Split {
            labels: (0..n)
                .map(|i| features[i].and(labels.get(i).copied().flatten()))
                .collect(),
            count: labels.iter().flatten().max().map_or(0, |m| m + 1),
        },
        None => {
            let mut parts = split(&features, &options.split);
            // A highlight is a few bright pixels inside its material: its
            // own answer places it elsewhere, but it is the one place the
            // material shows its roughness. A mode filter gives such
            // islands back to the material around them.
            parts.labels = mode_filter(&parts.labels, width, options.island_radius);
            parts
        }
    };
    let mut parts = parts;
    // Materials the filter emptied are dropped, the rest renumbered.
    let mut renumber = vec![None; parts.count];
    let mut next = 0;
    for l in parts.labels.iter().flatten() {
        if renumber[*l].is_none() {
            renumber[*l] = Some(next);
            next += 1;
        }
    }
    for l in parts.labels.iter_mut() {
        *l = l.and_then(|v| renumber[v]);
    }
    parts.count = next;

    // A material's roughness and metallic: the grid point with the least
    // cost summed over its pixels, each with its own best basecolor.
    let points = grid.len() * METALLIC_GRID.len();
    let mut materials = Vec::with_capacity(parts.count);
    // Every blocked material's volumes without the caller's transmission,
    // which its pixels' neighbourhoods read too.
    let mut recosted_all: HashMap<usize, Volume> = HashMap::new();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); parts.count];
    for (i, label) in parts.labels.iter().enumerate() {
        if let Some(j) = label {
            members[*j].push(i);
        }
    }
    for list in members.iter() {
        let reading = known
            .backlight
            .zip(options.backlight.as_ref())
            .and_then(|(b, o)| b.material(list, o));
        let opaque = reading.is_some_and(|r| r.passage == Passage::Blocked);
        // A material that passes no light is costed without the
        // transmission the caller's map gave its pixels.
        let recosted: HashMap<usize, Volume> = if opaque {
            list.par_iter()
                .filter(|&&i| transmits(i))
                .filter_map(|&i| Some((i, volume_of(i, direct_at(i), true)?)))
                .collect()
        } else {
            HashMap::new()
        };
        let mut by_direct = vec![0.0f64; points];
        for &i in list {
            if let Some(v) = recosted.get(&i).or(volumes[i].as_ref()) {
                by_direct.iter_mut().zip(&v.cost).for_each(|(t, c)| *t += c);
            }
        }
        // Light through a material rules out a metal, which transmits
        // nothing and scatters nothing inside.
        let dielectric = reading.is_some_and(|r| r.passage == Passage::Passes);
        let measured_share = separated.then(|| global_share(list, &total_light));
        let mut material = choose(
            &by_direct,
            &grid,
            list,
            known,
            Evidence {
                dielectric,
                surface_only: !dielectric && measured_share.is_some_and(|s| s < SURFACE_ONLY_SHARE),
            },
            fallback,
            options,
        );
        let share = measured_share.filter(|_| options.light == FitLight::Material);
        let scatters = share.is_some_and(|s| s >= SCATTERING_SHARE);
        // A material whose direct light pins it as metal but whose total
        // light does not scatters light inside or through it: its direct
        // light is its specular lobe alone (a metal's signature), its
        // total light the light it scatters back. Metals scatter nothing
        // inside, so such a material is fitted to its total light.
        let pinned_metal = |m: &MaterialFit| m.metallic_pinned && m.metallic >= 0.5;
        if scatters || (separated && known.metallic.is_none() && pinned_metal(&material)) {
            let by_total = list
                .par_iter()
                .filter_map(|&i| volume_of(i, &total_light[i], opaque))
                .map(|v| v.cost)
                .reduce(
                    || vec![0.0f64; points],
                    |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect(),
                );
            // A large global share is light scattered inside or, on a
            // concave metal, light it reflects onto itself: the total
            // light's own fit decides metallic.
            let in_total = choose(
                &by_total,
                &grid,
                list,
                known,
                Evidence {
                    dielectric,
                    surface_only: false,
                },
                fallback,
                options,
            );
            if scatters || !pinned_metal(&in_total) {
                material = MaterialFit {
                    scattering: true,
                    ..in_total
                };
            }
        }
        // The total light rarely pins a scattering dielectric's roughness:
        // its highlights can. A material the backlight shows light through
        // has light refracted through the object in its direct light (a
        // checker seen through clear material keeps its sharp edges),
        // which no surface model renders and which a broad lobe soaks up
        // when every view counts: its highlights decide its roughness
        // wherever they pin one.
        let passes = reading.is_some_and(|b| b.passage == Passage::Passes);
        // The lobe's costs take the caller's transmission map: the
        // backlight measures the material's own after this loop, at the
        // roughness read here.
        let from_highlights = ((material.scattering && !material.roughness_pinned) || passes)
            && material.metallic < 0.5
            && known.roughness.is_none();
        if let (true, Some(direct), Some(lobe)) = (from_highlights, direct.as_ref(), options.lobe) {
            // Each pixel with a view into the lobe adds its row and counts.
            let (summed, seen) = list
                .par_iter()
                .filter_map(|&i| {
                    let (volume, opaque) = match recosted.get(&i) {
                        Some(v) => (v, true),
                        None => (volumes[i].as_ref()?, false),
                    };
                    lobe::highlight_costs(
                        &direct[i],
                        &volume.basecolor[..grid.len()],
                        &grid,
                        &fixed_at(i, opaque),
                        &options.noise,
                        lobe.cone_cos,
                    )
                })
                .map(|row| (row, 1usize))
                .reduce(
                    || (vec![0.0f64; grid.len()], 0),
                    |(a, n), (b, m)| (a.iter().zip(&b).map(|(x, y)| x + y).collect(), n + m),
                );
            if seen >= lobe.min_pixels {
                if let Some(r) = lobe::pinned(&summed, &grid, options.roughness_contrast) {
                    material.roughness = r;
                    material.roughness_pinned = true;
                    material.lobe_pixels = Some(seen);
                }
            }
        }
        material.backlight = reading;
        material.global_share = share.map(|s| s as f32);
        materials.push(material);
        recosted_all.extend(recosted);
    }
    if let (Some(b), Some(o)) = (known.backlight, options.backlight.as_ref()) {
        clear_transmission(&mut materials, &parts.labels, b, o, |i, m| {
            // The diffuse albedo, which the direct light shows at
            // transmission 0.
            let obs = direct_at(i);
            let fit = solve(
                obs,
                &responses(obs, m.roughness, 0.0, &fixed_at(i, true)),
                &options.noise,
            );
            (fit.weight > 0.0).then(|| matscan_calib::photos::luma(fit.basecolor))
        });
    }
    let fixed_of = |i: usize, m: &MaterialFit| match m.transmission {
        Some(t) => Fixed { transmission: t },
        None => fixed_at(i, m.blocks_light()),
    };

    // Where a material's photos pin no metallic, a pixel's neighbourhood
    // may.
    let any_open = materials.iter().any(|m| !m.metallic_pinned);
    let local_metallic: Vec<Option<f32>> = match options.neighbourhood {
        // The window's sums cost a pass over every pixel's volume: none
        // where every material's metallic is pinned (most scans).
        Some(o) if known.metallic.is_none() && any_open => {
            let open = |i: usize| parts.labels[i].is_some_and(|j| !materials[j].metallic_pinned);
            let rows: Vec<Option<&[f64]>> = (0..n)
                .map(|i| {
                    volumes[i]
                        .as_ref()
                        .filter(|_| open(i))
                        .map(|v| v.cost.as_slice())
                })
                .collect();
            let sums = neighbourhood::window_sums(&rows, width, points, o.radius);
            (0..n)
                .map(|i| {
                    let summed = sums[i].as_deref().filter(|_| open(i))?;
                    neighbourhood::call(summed, grid.len(), o.contrast)
                })
                .collect()
        }
        _ => vec![None; n],
    };
    let mut local_metallic = local_metallic;
    // A pinned material whose own pixels' neighbourhoods contradict its
    // call in a large share of their clear calls holds metal and
    // dielectric alike (multimat): its metallic stays per pixel. Light
    // seen through a material rules a metal out, so the backlight's call
    // stands. Each pinned material's window sums run over its bounding box.
    if let (Some(o), None) = (options.neighbourhood, known.metallic) {
        let calls: Vec<Vec<(usize, f32)>> = materials
            .par_iter()
            .zip(&members)
            .map(|(m, list)| {
                if !m.metallic_pinned || m.passes_light() {
                    return Vec::new();
                }
                let row_of = |i: usize| {
                    recosted_all
                        .get(&i)
                        .or(volumes[i].as_ref())
                        .map(|v| v.cost.as_slice())
                };
                neighbourhood::member_calls(list, row_of, width, grid.len(), &o)
            })
            .collect();
        for (m, calls) in materials.iter_mut().zip(calls) {
            m.contrary_calls = neighbourhood::contrary_share(&calls, m.metallic).map(|s| s as f32);
            if m.contrary_calls
                .is_some_and(|s| f64::from(s) >= o.mixed_share)
            {
                m.metallic_mixed = true;
                for (i, v) in calls {
                    local_metallic[i] = Some(v);
                }
            }
        }
    }
    let observed = |i: usize, j: usize| -> &[Sample] {
        if materials[j].scattering {
            &total_light[i]
        } else {
            direct_at(i)
        }
    };
    // Each pixel's metallic: a neighbourhood's call, else, where its
    // material's one call does not hold for all of it, the networks'.
    let per_pixel = |m: &MaterialFit| !m.metallic_pinned || m.metallic_mixed;
    let metallic_at = |i: usize, j: usize| -> f32 {
        let m = &materials[j];
        match (local_metallic[i], fallback) {
            (Some(v), _) => v,
            (None, Some(f)) if per_pixel(m) => f
                .metallic
                .get(i)
                .copied()
                .filter(|v| v.is_finite())
                .unwrap_or(m.metallic),
            _ => m.metallic,
        }
    };
    // The metallic a pixel's basecolor is read at: its window's call, else
    // its material's metallic (a pinned material's call; an open
    // material's is the networks' majority, rounded). The networks'
    // fractional metallic is no surface the photos showed (a surface is a
    // metal or not), and reading a dielectric at it darkens its basecolor.
    let read_at = |i: usize, j: usize| local_metallic[i].unwrap_or(materials[j].metallic);
    // Basecolor per pixel at its material's roughness and that metallic,
    // first from its own photos alone; then pulled toward its material's
    // information-weighted mean, which decides only where the photos say
    // little of it (a glossy metal away from its highlights).
    let own: Vec<Option<(Vec<Response>, LinearFit)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let j = parts.labels[i]?;
            let m = &materials[j];
            let obs = observed(i, j);
            let r = responses(obs, m.roughness, read_at(i, j), &fixed_of(i, m));
            let fit = solve(obs, &r, &options.noise);
            Some((r, fit))
        })
        .collect();
    // A pinned metal's colour from its highlights, pooled over its metal
    // pixels.
    let highlights: Vec<Option<HighlightColour>> = materials
        .iter()
        .enumerate()
        .map(|(j, m)| {
            if m.metallic < 0.5 || !m.metallic_pinned || !m.roughness_pinned {
                return None;
            }
            let pooled: Vec<(&Sample, &Response)> = members[j]
                .iter()
                .filter(|&&i| metallic_at(i, j) >= 0.5)
                .filter_map(|&i| Some((observed(i, j), &own[i].as_ref()?.0)))
                .flat_map(|(obs, r)| obs.iter().zip(r))
                .collect();
            Some(highlight::colour(
                pooled.iter().copied(),
                &options.noise,
                &options.highlight,
            ))
        })
        .collect();
    let mut means = vec![([0.0f64; 3], [0.0f64; 3]); materials.len()];
    for (own, label) in own.iter().zip(&parts.labels) {
        if let (Some((_, f)), Some(j)) = (own, label) {
            for c in 0..3 {
                means[*j].0[c] += f.information[c] * f64::from(f.basecolor[c]);
                means[*j].1[c] += f.information[c];
            }
        }
    }
    let means: Vec<[f32; 3]> = means
        .iter()
        .map(|(s, w)| {
            std::array::from_fn(|c| {
                if w[c] > 0.0 {
                    (s[c] / w[c]) as f32
                } else {
                    0.5
                }
            })
        })
        .collect();
    let results: Vec<Option<([f32; 3], f32, f32)>> = own
        .par_iter()
        .enumerate()
        .map(|(i, own)| {
            let (r, _) = own.as_ref()?;
            let j = parts.labels[i]?;
            let m = &materials[j];
            let fit: LinearFit = solve_pulled(
                observed(i, j),
                r,
                &options.noise,
                Some(Pull {
                    mean: means[j],
                    strength: options.basecolor_pull,
                }),
            );
            Some((fit.basecolor, m.roughness, metallic_at(i, j)))
        })
        .collect();

    let mut out = Fitted {
        basecolor: vec![[0.0; 3]; n],
        roughness: vec![0.0; n],
        metallic: vec![0.0; n],
        labels: parts.labels.clone(),
        materials: Vec::new(),
        constrained: Constrained::default(),
        notes: Vec::new(),
        seconds: 0.0,
        measured: MeasureSeconds::default(),
    };
    let object = mask.iter().filter(|&&m| m).count().max(1) as f32;
    let (mut bc, mut rough, mut metal) = (0usize, 0usize, 0usize);
    let mut sums = vec![([0.0f64; 3], 0usize); materials.len()];
    for i in 0..n {
        if !mask[i] {
            continue;
        }
        match (results[i], parts.labels[i]) {
            (Some((b, r, m)), Some(j)) => {
                out.basecolor[i] = b;
                out.roughness[i] = r;
                // Where the material's photos pin no metallic, or its
                // pixels' neighbourhoods contradict the one they pin, the
                // answer stays per pixel: metal and dielectric can
                // alternate within one colour, which one call would throw
                // away (multimat).
                out.metallic[i] = m;
                bc += 1;
                rough += usize::from(materials[j].roughness_pinned);
                let held = materials[j].metallic_pinned && !materials[j].metallic_mixed;
                metal += usize::from(held || local_metallic[i].is_some());
                for (sum, v) in sums[j].0.iter_mut().zip(b) {
                    *sum += f64::from(v);
                }
                sums[j].1 += 1;
            }
            _ => {
                let (b, r, m) = match fallback {
                    Some(f) => (
                        f.basecolor.get(i).copied().unwrap_or([0.5; 3]),
                        f.roughness.get(i).copied().unwrap_or(0.5),
                        f.metallic.get(i).copied().unwrap_or(0.0),
                    ),
                    None => ([0.5; 3], 0.5, 0.0),
                };
                out.basecolor[i] = b;
                out.roughness[i] = r;
                out.metallic[i] = m;
            }
        }
    }
    for ((m, h), (s, count)) in materials.iter_mut().zip(highlights).zip(&sums) {
        if *count > 0 {
            m.basecolor = s.map(|v| (v / *count as f64) as f32);
        }
        m.highlight = h.map(|h| highlight::checked(h, m.basecolor, &options.highlight));
    }
    out.constrained = Constrained {
        basecolor: bc as f32 / object,
        roughness: rough as f32 / object,
        metallic: metal as f32 / object,
        transmission: 0.0,
        subsurface: 0.0,
    };
    let unfitted = mask.iter().filter(|&&m| m).count() - bc;
    if unfitted > 0 {
        out.notes.push(format!(
            "{unfitted} object pixels had no usable observation (shadowed, saturated or \
             grazing in every view): {}",
            if fallback.is_some() {
                "the networks' values are kept there"
            } else {
                "basecolor 0.5, roughness 0.5, dielectric there"
            }
        ));
    }
    for (call, label) in local_metallic.iter().zip(&parts.labels) {
        if let (Some(_), Some(j)) = (call, label) {
            *materials[*j].neighbourhood_pixels.get_or_insert(0) += 1;
        }
    }
    out.materials = materials;
    out.seconds = t.elapsed().as_secs_f64();
    out
}

/// The share of the light the pixels `members` show that is global
/// (summed over channels and usable views); 0 where nothing was measured.
fn global_share(members: &[usize], observations: &[Vec<Sample>]) -> f64 {
    let (mut global, mut total) = (0.0f64, 0.0f64);
    for s in members.iter().flat_map(|&i| &observations[i]) {
        for c in 0..3 {
            global += f64::from(s.global[c].max(0.0));
            total += f64::from(s.observation.observed[c].max(0.0));
        }
    }
    if total > 0.0 && global.is_finite() {
        (global / total).min(1.0)
    } else {
        0.0
    }
}

/// Every usable view of reference pixel `i` (views whose lighting is
/// `None` are left out), clipped channels kept as bounds at their floor.
pub fn samples(inputs: &SceneInputs, lighting: &[Option<ViewLighting>], i: usize) -> Vec<Sample> {
    inputs
        .views
        .iter()
        .zip(lighting)
        .filter_map(|(planes, lighting)| {
            let s = seen(planes, lighting.as_ref()?, i);
            let mut observation = s.observation;
            if observation.weight.is_nan() || observation.weight <= 0.0 {
                return None;
            }
            for c in 0..3 {
                let value = if s.clipped[c] {
                    s.floor[c]
                } else {
                    observation.observed[c]
                };
                observation.observed[c] = value.max(0.0);
            }
            Some(Sample {
                observation,
                clipped: s.clipped,
                footprint: footprint_alpha2(half_angle_step(planes, inputs.width, i)),
                global: s.global.map(|g| g.max(0.0)),
            })
        })
        .collect()
}

/// Each labelled pixel takes the most frequent label in the
/// `(2 radius + 1)²` window around it (its own on a tie), twice: islands
/// smaller than the window vanish, straight boundaries stay.
pub fn mode_filter(labels: &[Option<usize>], width: usize, radius: usize) -> Vec<Option<usize>> {
    if radius == 0 || width == 0 {
        return labels.to_vec();
    }
    let height = labels.len() / width;
    let count = labels.iter().flatten().max().map_or(0, |m| m + 1);
    let mut current = labels.to_vec();
    for _ in 0..2 {
        let next: Vec<Option<usize>> = (0..current.len())
            .into_par_iter()
            .map(|i| {
                let own = current[i]?;
                let (x, y) = (i % width, i / width);
                let mut votes = vec![0u32; count];
                for yy in y.saturating_sub(radius)..(y + radius + 1).min(height) {
                    for xx in x.saturating_sub(radius)..(x + radius + 1).min(width) {
                        if let Some(l) = current[yy * width + xx] {
                            votes[l] += 1;
                        }
                    }
                }
                let best = (0..count)
                    .max_by_key(|&l| (votes[l], l == own))
                    .unwrap_or(own);
                Some(best)
            })
            .collect();
        current = next;
    }
    current
}

/// The angle of the half-vector to the normal at pixel `i` of `planes`.
fn half_angle(planes: &ViewPlanes, i: usize) -> Option<f32> {
    if planes.mask[i].is_nan() || planes.mask[i] <= 0.5 {
        return None;
    }
    let (wo, wi) = directions(planes.cos_nv()[i], planes.cos_nl()[i], planes.cos_vl()[i]);
    let h = wo + wi;
    let len = h.length();
    (len > 1e-6).then(|| (h.z / len).clamp(-1.0, 1.0).acos())
}

/// How much the half-vector's angle changes from pixel `i` to its
/// neighbours (the largest step to a neighbour the view sees; 0 alone).
fn half_angle_step(planes: &ViewPlanes, width: usize, i: usize) -> f32 {
    let Some(here) = half_angle(planes, i) else {
        return 0.0;
    };
    let n = planes.mask.len();
    let (x, y) = (i % width.max(1), i / width.max(1));
    let mut step = 0.0f32;
    let mut visit = |j: usize| {
        if let Some(a) = half_angle(planes, j) {
            step = step.max((a - here).abs());
        }
    };
    if x > 0 {
        visit(i - 1);
    }
    if x + 1 < width {
        visit(i + 1);
    }
    if y > 0 {
        visit(i - width);
    }
    if i + width < n {
        visit(i + width);
    }
    // Half the step to either side: the footprint spans one pixel.
    step
}

/// Whether the cost `worse` exceeds `best` by at least the fraction
/// `contrast`: how the fit decides that the photos pinned a choice.
fn clearly_worse(worse: f64, best: f64, contrast: f64) -> bool {
    worse > best * (1.0 + contrast) + 1e-9
}

/// The index of the smallest finite value.
fn argmin(v: &[f64]) -> Option<usize> {
    v.iter()
        .enumerate()
        .filter(|(_, c)| c.is_finite())
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map(|(i, _)| i)
}

/// What the photos say of a material before its cost volume is read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Evidence {
    /// Light passes through it (the backlight): it is no metal.
    dielectric: bool,
    /// The volume is its measured direct light, and its global light is
    /// below [`SURFACE_ONLY_SHARE`] with none seen through it: nothing
    /// but its surface lobe can be what the costs favour.
    surface_only: bool,
}

/// A material's roughness and metallic from its summed cost volume.
fn choose(
    total: &[f64],
    grid: &[f32],
    members: &[usize],
    known: Known<'_>,
    evidence: Evidence,
    fallback: Option<Fallback<'_>>,
    options: &FitOptions,
) -> MaterialFit {
    let dielectric = evidence.dielectric;
    let median = |v: &[f32]| -> Option<f32> {
        let mut s: Vec<f32> = members.iter().filter_map(|&i| v.get(i).copied()).collect();
        quantile(&mut s, 0.5)
    };
    let r = grid.len();
    let known_metallic = known
        .metallic
        .and_then(median)
        .map(|m| usize::from(m >= 0.5))
        .or(dielectric.then_some(0));
    let known_roughness = known.roughness.and_then(median);
    let row_of = |m: usize| &total[m * r..(m + 1) * r];
    let best_of = |m: usize| -> (usize, f64) {
        let row = row_of(m);
        let k = argmin(row).unwrap_or(r / 2);
        (k, row[k])
    };
    let (dielectric, metal) = (best_of(0), best_of(1));
    let m = known_metallic.unwrap_or(usize::from(metal.1 < dielectric.1));
    let (k, best) = if m == 1 { metal } else { dielectric };
    let other = if m == 1 { dielectric.1 } else { metal.1 };
    // The roughest lobe on the grid winning means no surface lobe explains
    // the photos (light scattered inside or through the material, or a
    // truly rough surface), and a metal call there is the degenerate one
    // (a broad metal lobe imitating diffuse light), so only a dielectric
    // call is kept. For a material that shows nothing but its surface, a
    // dielectric's roughest lobe winning is a truly rough surface.
    let at_edge = k + 1 >= r;
    let explained = !at_edge || (m == 0 && evidence.surface_only);
    let metallic_pinned = known_metallic.is_some()
        || ((!at_edge || m == 0) && clearly_worse(other, best, options.metallic_contrast));
    let row = row_of(m);
    let worst = row.iter().copied().fold(0.0f64, f64::max);
    let roughness_pinned = known_roughness.is_some()
        || (explained && clearly_worse(worst, best, options.roughness_contrast));
    let roughness = known_roughness.unwrap_or_else(|| {
        if at_edge {
            edge_minimum(row, grid)
        } else {
            parabola_minimum(row, grid, k)
        }
    });
    let roughness = match (roughness_pinned, fallback) {
        (false, Some(f)) => median(f.roughness).unwrap_or(roughness),
        _ => roughness,
    };
    let metallic = match (metallic_pinned, fallback) {
        (false, Some(f)) => {
            if median(f.metallic).unwrap_or(0.0) >= 0.5 {
                1.0
            } else {
                0.0
            }
        }
        _ => METALLIC_GRID[m],
    };
    MaterialFit {
        pixels: members.len(),
        basecolor: [0.0; 3],
        roughness,
        metallic,
        roughness_pinned,
        metallic_pinned,
        scattering: false,
        backlight: None,
        global_share: None,
        transmission: None,
        highlight: None,
        texture_kept: None,
        lobe_pixels: None,
        neighbourhood_pixels: None,
        contrary_calls: None,
        metallic_mixed: false,
        subsurface: None,
    }
}

/// The minimum of the parabola through the grid costs around `k`, in ln
/// roughness; the grid value itself at the ends or where the three points
/// do not bend upward.
fn parabola_minimum(row: &[f64], grid: &[f32], k: usize) -> f32 {
    if k == 0 || k + 1 >= row.len() {
        return grid[k.min(grid.len() - 1)];
    }
    let x = [k - 1, k, k + 1].map(|i| f64::from(grid[i]).ln());
    let y = [k - 1, k, k + 1].map(|i| row[i]);
    parabola_vertex(x, y).map_or(grid[k], |xm| (xm.exp() as f32).clamp(grid[0], 1.0))
}

/// The vertex of the parabola through three points (x ascending), kept
/// between the outer two; `None` where they do not bend upward.
pub(crate) fn parabola_vertex(x: [f64; 3], y: [f64; 3]) -> Option<f64> {
    let ([x0, x1, x2], [y0, y1, y2]) = (x, y);
    let d = (x0 - x1) * (x0 - x2) * (x1 - x2);
    let a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / d;
    let b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / d;
    if a.is_nan() || a <= 0.0 || !b.is_finite() {
        return None;
    }
    Some((-b / (2.0 * a)).clamp(x0, x2))
}

/// Where the costs still fall at the grid's roughest lobe: the minimum
/// of the parabola through the last three costs, between the last two
/// grid points, or the roughest lobe where the parabola does not bend
/// upward.
fn edge_minimum(row: &[f64], grid: &[f32]) -> f32 {
    let r = row.len().min(grid.len());
    if r < 3 {
        return grid[r.saturating_sub(1)];
    }
    let k = r - 2;
    let x = |i: usize| f64::from(grid[i]).ln();
    let slope = |a: usize, b: usize| (row[b] - row[a]) / (x(b) - x(a));
    if slope(k, k + 1) > slope(k - 1, k) {
        parabola_minimum(&row[..r], &grid[..r], k).clamp(grid[k], grid[r - 1])
    } else {
        grid[r - 1]
    }
}

#[cfg(test)]
mod tests;
