//! Analysis-by-synthesis refinement after the networks: per reference
//! pixel, basecolor, roughness and metallic are fitted so that the
//! simulator's principled BSDF under the calibrated lights reproduces the
//! lit-minus-ambient photos of every view, starting from (and pulled
//! toward) the networks' answer.
//!
//! - [`model`]: the forward model and the solver's parameter space.
//! - [`loss`]: noise scale, Huber loss, per-view trust, the prior.
//! - [`solver`]: projected Levenberg–Marquardt for one pixel.
//! - [`confidence`]: per-parameter confidence from the fit's curvature.
//! - [`observe`]: a scan's views as per-pixel observations and lights.
//!
//! Transmission and subsurface are not fitted: the point-light photos the
//! model explains say little about them (the backlight panel has no pose
//! to model, and subsurface transport is not local), so the networks'
//! values are kept, transmission enters the model as a fixed input, and
//! `result.toml` says so. Pixels with a large subsurface estimate trust
//! the data less (the model renders them as Burley diffuse).
//!
//! Crate choices: `rayon` for the per-pixel parallelism (already in the
//! workspace, used by `calib` and `sim`); `matscan-sim` for the BSDF, so
//! the refinement and the simulated truth share one implementation. Small
//! fixed-size linear algebra (5x5 Cholesky) is written out in `solver`
//! rather than pulling a matrix crate.
//!
//! Boundaries: no file I/O and no networks; the pipeline hands in the
//! networks' maps and writes what comes back.

pub mod confidence;
pub mod error;
pub mod loss;
pub mod model;
pub mod observe;
pub mod solver;

pub use confidence::Confidence;
pub use observe::IlluminationSource;
pub use solver::{Settings, StopReason};

use crate::pipeline::inputs::SceneInputs;
pub use error::RefineError;
use loss::Prior;
use matscan_calib::ScanCalibration;
use matscan_scan::Bundle;
use model::{Fixed, Observation, Params, N};
use observe::{calibrated_lighting, clip_level, network_lighting, observations, ViewLighting};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Instant;

/// How the refinement runs; `iterations == 0` turns it off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineOptions {
    /// Solver iterations per pixel (0 = no refinement). Run time grows
    /// linearly with it.
    pub iterations: u32,
    /// Where the light per pixel comes from.
    pub illumination: IlluminationSource,
    /// Prior standard deviations in solver units (basecolor and metallic:
    /// their own units; roughness: natural log), i.e. how far the data may
    /// pull each parameter from the network's answer at equal cost.
    pub prior_sigma: PriorSigma,
    /// A channel counts as clipped at or above this fraction of the level
    /// its photo shows it clipped at (see
    /// [`matscan_calib::photos::clip_levels`]); a photo that shows no
    /// pile-up clips nowhere.
    pub saturation: f32,
    /// Noise model and Huber threshold.
    pub noise_abs: f64,
    pub noise_rel: f64,
    pub huber_k: f64,
}

/// Prior standard deviations per fitted parameter (see [`RefineOptions`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PriorSigma {
    pub basecolor: f64,
    pub ln_roughness: f64,
    pub metallic: f64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        let s = Settings::default();
        RefineOptions {
            iterations: 0,
            illumination: IlluminationSource::Calibration,
            // Basecolor 0.1, not looser: the model has no interreflections
            // or environment light, so where they add to a photo the data
            // pull basecolor up. On the 36 held-out scenes (refine_eval,
            // 10 iterations, second-training weights) 0.1 lowered the
            // mean MAD of all three fitted parameters (metallic 0.312 to
            // 0.302, roughness 0.235 to 0.232, basecolor 0.143 to 0.140);
            // 0.3 raised basecolor's to 0.158, 0.03 left the fit no room.
            prior_sigma: PriorSigma {
                basecolor: 0.1,
                ln_roughness: 0.3,
                metallic: 0.15,
            },
            saturation: 0.99,
            noise_abs: s.noise_abs,
            noise_rel: s.noise_rel,
            huber_k: s.huber_k,
        }
    }
}

impl RefineOptions {
    /// Whether the refinement runs at all.
    pub fn enabled(&self) -> bool {
        self.iterations > 0
    }

    fn settings(&self) -> Settings {
        Settings {
            max_iterations: self.iterations,
            huber_k: self.huber_k,
            noise_abs: self.noise_abs,
            noise_rel: self.noise_rel,
            ..Settings::default()
        }
    }

    /// The prior centred on `x0`; held parameters get a prior so strong
    /// that the data cannot move them.
    pub fn prior(&self, x0: [f64; N], hold: &Hold) -> Prior {
        let s = self.prior_sigma;
        let held = |h: bool, v: f64| if h { HELD_SIGMA } else { v };
        let sig = [
            held(hold.basecolor, s.basecolor),
            held(hold.basecolor, s.basecolor),
            held(hold.basecolor, s.basecolor),
            held(hold.roughness, s.ln_roughness),
            held(hold.metallic, s.metallic),
        ];
        Prior {
            mean: x0,
            precision: sig.map(|v| 1.0 / (v * v).max(1e-12)),
        }
    }
}

/// Prior standard deviation of a held parameter: 1e-6 solver units.
const HELD_SIGMA: f64 = 1e-6;

/// Fitted parameters to keep at their start (given by the user, or
/// skipped): the fit treats them as known.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Hold {
    pub basecolor: bool,
    pub roughness: bool,
    pub metallic: bool,
}

/// What `result.toml` records of a refinement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RefineSummary {
    /// Solver iterations per pixel at most.
    pub iterations: u32,
    /// Where the light per pixel came from.
    pub illumination: IlluminationSource,
    /// Parameters the fit changed.
    pub fitted: Vec<String>,
    /// Parameters kept as the networks (or the user) gave them, and why.
    pub kept: BTreeMap<String, String>,
    /// Pixels per stop reason, over every position with maps.
    pub stops: BTreeMap<String, u64>,
    /// Views lit from the network or left out, and similar notes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// Why transmission and subsurface are never fitted.
pub const NOT_FITTED: [(&str, &str); 2] = [
    (
        "transmission",
        "the point-light photos barely depend on it and the backlight panel has no pose to \
         model: the network's value is kept (and enters the model as a fixed input)",
    ),
    (
        "subsurface",
        "subsurface transport is not local, the per-pixel model cannot reproduce it: the \
         network's value is kept",
    ),
];

/// The networks' answer per reference pixel, each in [0, 1].
#[derive(Clone, Copy, Debug)]
pub struct Start<'a> {
    pub basecolor: &'a [[f32; 3]],
    pub roughness: &'a [f32],
    pub metallic: &'a [f32],
    pub transmission: &'a [f32],
    pub subsurface: &'a [f32],
    /// Pixels to refine (the reference's object mask).
    pub mask: &'a [bool],
    /// Parameters not to change.
    pub hold: Hold,
}

impl Start<'_> {
    fn check(&self, n: usize) -> Result<(), RefineError> {
        let sizes = [
            ("basecolor", self.basecolor.len()),
            ("roughness", self.roughness.len()),
            ("metallic", self.metallic.len()),
            ("transmission", self.transmission.len()),
            ("subsurface", self.subsurface.len()),
            ("mask", self.mask.len()),
        ];
        for (what, found) in sizes {
            if found != n {
                return Err(RefineError::Size {
                    what,
                    found,
                    expected: n,
                });
            }
        }
        Ok(())
    }
}

/// Refined maps, their confidences and how each pixel's fit ended.
#[derive(Clone, Debug, PartialEq)]
pub struct Refined {
    pub basecolor: Vec<[f32; 3]>,
    pub roughness: Vec<f32>,
    pub metallic: Vec<f32>,
    /// Per pixel; 0 outside the mask.
    pub confidence: Vec<Confidence>,
    /// Pixels per stop reason (every reason listed, zeros included).
    pub stops: BTreeMap<StopReason, u64>,
    /// Wall time of the refinement, lighting included.
    pub seconds: f64,
    /// Views whose light came from the network because calibration could
    /// not provide it, and views left out entirely.
    pub notes: Vec<String>,
}

/// Refines `start` with the views of `inputs`. `illumination` is the
/// roughness network's per-view illumination in [0, 1] (indexed like
/// `inputs.views`), when it ran.
pub fn refine_scene(
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    start: &Start<'_>,
    illumination: Option<&[Vec<f32>]>,
    options: &RefineOptions,
) -> Result<Refined, RefineError> {
    let t = Instant::now();
    start.check(inputs.pixels())?;
    let mut notes = Vec::new();
    let mut lighting: Vec<Option<ViewLighting>> = Vec::with_capacity(inputs.views.len());
    for (index, planes) in inputs.views.iter().enumerate() {
        let view = &planes.view;
        let network = || {
            illumination
                .and_then(|all| all.get(index))
                .map(|e| network_lighting(planes, e, clip_level(planes, options.saturation)))
        };
        let chosen = match options.illumination {
            IlluminationSource::Calibration => {
                match calibrated_lighting(
                    bundle,
                    calibration,
                    &inputs.reference,
                    planes,
                    options.saturation,
                )? {
                    Some(l) => Some(l),
                    None => {
                        let fallback = network();
                        notes.push(format!(
                            "view {view}: the manifest gives no light intensity or a \
                             patterned light; {}",
                            if fallback.is_some() {
                                "its light is the roughness network's illumination"
                            } else {
                                "left out of the refinement"
                            }
                        ));
                        fallback
                    }
                }
            }
            IlluminationSource::Network => {
                let l = network();
                if l.is_none() {
                    notes.push(format!(
                        "view {view}: no network illumination; left out of the refinement"
                    ));
                }
                l
            }
        };
        lighting.push(chosen);
    }
    let mut refined = refine_pixels(start, |i| observations(inputs, &lighting, i), options);
    refined.notes = notes;
    refined.seconds = t.elapsed().as_secs_f64();
    Ok(refined)
}

/// Refines every masked pixel of `start` with the observations
/// `observe(pixel)` returns, in parallel over pixels.
pub fn refine_pixels<F>(start: &Start<'_>, observe: F, options: &RefineOptions) -> Refined
where
    F: Fn(usize) -> Vec<Observation> + Sync,
{
    let t = Instant::now();
    let settings = options.settings();
    let n = start.mask.len();
    let fits: Vec<Option<(Params, Confidence, StopReason)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            if !start.mask.get(i).copied().unwrap_or(false) {
                return None;
            }
            let at = |v: &[f32]| v.get(i).copied().unwrap_or(0.0);
            let x0 = Params {
                basecolor: start.basecolor.get(i).copied().unwrap_or([0.5; 3]),
                roughness: at(start.roughness),
                metallic: at(start.metallic),
            }
            .to_x();
            let prior = options.prior(x0, &start.hold);
            let mut obs = observe(i);
            // The model renders subsurface as Burley diffuse: the more
            // subsurface, the less its photos are evidence.
            let trust = (1.0 - at(start.subsurface)).clamp(0.0, 1.0);
            for o in &mut obs {
                o.weight *= trust;
            }
            let problem = solver::Problem {
                start: x0,
                prior,
                fixed: Fixed {
                    transmission: at(start.transmission),
                },
                observations: &obs,
            };
            let fit = solver::solve(&problem, &settings);
            let confidence = Confidence::of(&fit.posterior_variance, &prior);
            Some((Params::from_x(&fit.x), confidence, fit.stop))
        })
        .collect();
    let mut stops: BTreeMap<StopReason, u64> = StopReason::ALL.iter().map(|&s| (s, 0)).collect();
    let mut out = Refined {
        basecolor: vec![[0.0; 3]; n],
        roughness: vec![0.0; n],
        metallic: vec![0.0; n],
        confidence: vec![Confidence::default(); n],
        stops: BTreeMap::new(),
        seconds: 0.0,
        notes: Vec::new(),
    };
    for (i, fit) in fits.into_iter().enumerate() {
        if let Some((p, c, stop)) = fit {
            out.basecolor[i] = p.basecolor;
            out.roughness[i] = p.roughness;
            out.metallic[i] = p.metallic;
            out.confidence[i] = c;
            *stops.entry(stop).or_insert(0) += 1;
        }
    }
    out.stops = stops;
    out.seconds = t.elapsed().as_secs_f64();
    out
}
