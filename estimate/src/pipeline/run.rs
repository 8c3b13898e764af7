//! One estimate of a scan: calibrate, select views, plan, run the networks
//! stage by stage (figure 3.14; the networks of one stage concurrently, on
//! scoped threads), compare with the truth where the scan has it, and write
//! `estimate/`.
//!
//! What each network reads: the earlier parameters in [0, 1] — metallic;
//! the effective transmission `T (1 - M)` (eq. 3.5); the effective
//! subsurface `S (1 - M) (1 - T)` (eq. 3.6); roughness — and the roughness
//! network's per-view illumination. Network outputs are read back with
//! `inputs::uncentre` (basecolor as YCbCr, then converted to RGB), and are
//! 0 outside the reference's object mask.
//!
//! Which views each network fuses: transmission only views whose position
//! has a backlit capture, subsurface only views whose position has a
//! checker capture, the others every view.
//!
//! Refinement (optional, `EstimateOptions::refine`): after the networks of
//! each position, `refine` fits basecolor, roughness and metallic per pixel
//! to the photos, starting from the networks' maps (given or skipped
//! parameters are held), and its confidence maps are written beside them.
//!
//! Out of scope: the networks (see `network`), channel assembly (see
//! `inputs`), the plan (see `plan`), file layout (see `output`), the fit
//! (see `refine`).

use crate::fit::scattering::SubsurfaceFit;
use crate::fit::{fit_scene, Constrained, Fallback, FitOptions, Fitted, Known, MeasureSeconds};
use crate::net::models::{ModelSource, Models, ModelsError};
use crate::net::network::InputError;
use crate::pipeline::inputs::{
    rgb_of_ycbcr, uncentre, Dependencies, InputsError, Photos, SceneInputs,
};
use crate::pipeline::method::Method;
use crate::pipeline::metrics::error_metrics;
use crate::pipeline::oracle::{OracleError, Oracles};
use crate::pipeline::output::{
    write_estimate, FitSummary, OutputError, ParamResult, ResultFile, Status, Timings,
    RESULT_FORMAT,
};
use crate::pipeline::plan::{Availability, Decision, Given, Plan, PlanError};
use crate::pipeline::views::{select_views, ViewError, ViewFilter};
use crate::refine::{
    refine_scene, Hold, RefineError, RefineOptions, RefineSummary, Start, StopReason, NOT_FITTED,
};
use burn::tensor::Device;
use matscan_calib::{calibrate_bundle, CalibError, CalibOptions, ScanCalibration};
use matscan_scan::estimate_maps::{MapError, ParamMap, PositionMaps};
use matscan_scan::image_io::{read_rgb_exr, read_scalar_exr};
use matscan_scan::raster::{RgbRaster, ScalarRaster};
use matscan_scan::{Bundle, Param, ScanError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to estimate and how.
#[derive(Clone, Debug, Default)]
pub struct EstimateOptions {
    /// Output folder; `<scan>/estimate` when `None`.
    pub out: Option<PathBuf>,
    /// User-given parameters.
    pub given: Vec<(Param, Given)>,
    /// Only these parameters (and what they need); all when `None`.
    pub only: Option<Vec<Param>>,
    /// `--positions` and `--views`.
    pub filter: ViewFilter,
    /// Calibration settings.
    pub calib: CalibOptions,
    /// Which positions get maps.
    pub references: References,
    /// The per-pixel refinement after the networks (off by default).
    pub refine: RefineOptions,
    /// Who answers basecolor, roughness and metallic.
    pub method: Method,
    /// The physical fit's settings (for every method but `Networks`).
    pub fit: FitOptions,
    /// Truth fed in place of measurement (the error budget of `matscan
    /// eval --oracle`); empty for every estimate a user gets.
    pub oracle: Oracles,
}

/// Which positions' camera images get maps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum References {
    /// Only the reference position (the first usable one).
    #[default]
    First,
    /// Every usable position, each in turn as reference with the same views:
    /// what texture baking needs to cover the whole object. Costs one pass
    /// of the networks per position.
    Every,
}

/// An estimate that could not be made.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// Reading the scan failed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// Calibration failed.
    #[error("calibration: {0}")]
    Calib(#[from] CalibError),
    /// No usable views.
    #[error(transparent)]
    Views(#[from] ViewError),
    /// An invalid request.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A network is unavailable.
    #[error(transparent)]
    Models(#[from] ModelsError),
    /// Assembling inputs failed.
    #[error(transparent)]
    Inputs(#[from] InputsError),
    /// A map broke its parameter's rules (a bug, reported rather than
    /// written).
    #[error("estimate map: {0}")]
    Map(#[from] MapError),
    /// A network refused its inputs.
    #[error("the {kind} network: {source}")]
    Network {
        /// The network.
        kind: Param,
        /// Why.
        #[source]
        source: InputError,
    },
    /// A network's output could not be read back.
    #[error("the {kind} network's output could not be read: {message}")]
    Readback {
        /// The network.
        kind: Param,
        /// The backend's message.
        message: String,
    },
    /// An oracle's truth could not be read.
    #[error("oracle: {0}")]
    Oracle(#[from] OracleError),
    /// A given map does not fit the reference image.
    #[error("--given {param}={path}: {reason}")]
    GivenMap {
        /// The parameter.
        param: Param,
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// Writing the result failed.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The refinement could not run.
    #[error(transparent)]
    Refine(#[from] RefineError),
}

/// What a finished estimate wrote.
#[derive(Clone, Debug)]
pub struct EstimateReport {
    /// The folder written.
    pub out: PathBuf,
    /// The contents of its `result.toml`.
    pub result: ResultFile,
}

/// One network's result.
struct NetRun {
    kind: Param,
    /// Channel-major `[channels][pixels]`, network units.
    fused: Vec<f32>,
    /// Per view, the first per-view channel (illumination), network units.
    per_view: Vec<Vec<f32>>,
    views: usize,
    seconds: f64,
}

/// Parameter values in [0, 1] per reference pixel.
#[derive(Default)]
struct Values {
    scalar: BTreeMap<Param, Vec<f32>>,
    basecolor: Option<Vec<[f32; 3]>>,
    illumination: Option<Vec<Vec<f32>>>,
    /// Seconds spent reading given maps.
    given_s: f64,
}

/// A scan opened and calibrated once, for every stage that needs it (the
/// daemon checks the calibration, then estimates, from the same one).
pub struct PreparedScan {
    pub bundle: Bundle,
    pub calibration: ScanCalibration,
    /// Seconds spent opening the bundle.
    pub load_s: f64,
    /// Seconds spent calibrating it.
    pub calibration_s: f64,
}

impl PreparedScan {
    /// Opens the scan at `scan` and calibrates it with `calib`.
    pub fn open(scan: &Path, calib: &CalibOptions) -> Result<PreparedScan, EstimateError> {
        Self::open_adjusted(scan, calib, &|_| Ok(()))
    }

    /// [`PreparedScan::open`] with the manifest changed by `adjust` before
    /// calibration (an evaluation's deliberately wrong or recalibrated
    /// rig); its error is the scan's.
    pub fn open_adjusted(
        scan: &Path,
        calib: &CalibOptions,
        adjust: &dyn Fn(&mut matscan_scan::Manifest) -> Result<(), ScanError>,
    ) -> Result<PreparedScan, EstimateError> {
        let t = Instant::now();
        let mut bundle = Bundle::open(scan)?;
        adjust(&mut bundle.manifest)?;
        let load_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let calibration = calibrate_bundle(&bundle, calib)?;
        Ok(PreparedScan {
            bundle,
            calibration,
            load_s,
            calibration_s: t.elapsed().as_secs_f64(),
        })
    }
}

/// Estimates the scan at `scan` and writes the result.
pub fn estimate(
    scan: &Path,
    models: ModelSource,
    options: &EstimateOptions,
    device: &Device,
) -> Result<EstimateReport, EstimateError> {
    let prepared = PreparedScan::open(scan, &options.calib)?;
    estimate_prepared(&prepared, models, options, device)
}

/// [`estimate`] of a scan already opened and calibrated (with
/// `options.calib`). Its total time counts the opening and calibration
/// once, as [`estimate`]'s does, however often the prepared scan is
/// estimated (eval runs several view configurations on one).
pub fn estimate_prepared(
    prepared: &PreparedScan,
    models: ModelSource,
    options: &EstimateOptions,
    device: &Device,
) -> Result<EstimateReport, EstimateError> {
    let start = Instant::now();
    let PreparedScan {
        bundle,
        calibration,
        ..
    } = prepared;
    let scan = bundle.root.as_path();
    let mut timings = Timings {
        load_s: prepared.load_s,
        ..Timings::default()
    };

    let t = Instant::now();
    let set = select_views(&bundle.manifest, calibration, &options.filter)?;
    timings.calibration_s = prepared.calibration_s + t.elapsed().as_secs_f64();

    let t = Instant::now();
    // Every position sees the same photos: read each once (kept only when
    // more positions follow).
    let mut photos = Photos::default();
    let inputs = SceneInputs::assemble_with(bundle, calibration, &set, &mut photos)?;
    timings.inputs_s = t.elapsed().as_secs_f64();
    if options.references == References::First {
        photos = Photos::default();
    }

    let available = Availability {
        backlit: inputs.views.iter().any(|v| v.has_backlit()),
        checker: inputs.views.iter().any(|v| v.has_checker()),
    };
    let mut given = options.given.clone();
    given.extend(options.oracle.given(bundle, &set.reference)?);
    let plan = Plan::new(options.only.as_deref(), &given, available)?;

    let t = Instant::now();
    let kinds: Vec<Param> = plan.networks().collect();
    let models = models.resolve(&kinds, device)?;
    timings.weights_s = t.elapsed().as_secs_f64();

    let mut tally = RefineTally::default();
    let mut fits = FitTally::default();
    let pass = Pass {
        plan: &plan,
        models: &models,
        bundle,
        calibration,
        refine: &options.refine,
        method: options.method,
        fit: &options.fit,
        oracle: &options.oracle,
        device,
    };
    let (first, mut runs, given_s) = pass.run(&inputs, &mut tally, &mut fits)?;
    timings.load_s += given_s;
    let t = Instant::now();
    let metrics = metrics(bundle, &set.reference, &first.maps, &inputs)?;
    timings.metrics_s = t.elapsed().as_secs_f64();
    let mut warnings = inputs.warnings.clone();
    let mut positions = vec![first];
    if options.references == References::Every {
        let given_map = given.iter().find(|(_, g)| matches!(g, Given::Map(_)));
        for name in set.usable.iter().filter(|p| **p != set.reference) {
            if let Some((kind, _)) = given_map {
                warnings.push(format!(
                    "position {name} has no maps: the given {kind} map is in the camera \
                     image of {}",
                    set.reference
                ));
                continue;
            }
            let Some(other) = set.with_reference(name) else {
                continue;
            };
            let t = Instant::now();
            let inputs = SceneInputs::assemble_with(bundle, calibration, &other, &mut photos)?;
            timings.inputs_s += t.elapsed().as_secs_f64();
            for w in &inputs.warnings {
                if !warnings.contains(w) {
                    warnings.push(w.clone());
                }
            }
            let (maps, more, given_s) = pass.run(&inputs, &mut tally, &mut fits)?;
            timings.load_s += given_s;
            for (kind, (_, seconds)) in more {
                runs.entry(kind).or_insert((0, 0.0)).1 += seconds;
            }
            positions.push(maps);
        }
    }
    timings.networks = runs
        .iter()
        .map(|(k, (_, s))| (k.name().to_string(), *s))
        .collect();
    timings.refine_s = tally.seconds;
    timings.fit_s = fits.seconds;
    timings.backlight_s = fits.measured.backlight;
    timings.scattering_s = fits.measured.scattering;
    timings.total_s = prepared.load_s + prepared.calibration_s + start.elapsed().as_secs_f64();

    let mut params = BTreeMap::new();
    for kind in crate::net::spec::PIPELINE_ORDER {
        let model = models.get(kind).map(|m| m.id.clone());
        let entry = match plan.decision(kind) {
            Decision::Estimate => {
                let (method, constrained) = fits.answered(kind, options.method);
                let network_s = runs.get(&kind).map(|(_, s)| *s);
                let fit_s = (method != Method::Networks).then_some(fits.seconds);
                let seconds = match (network_s, fit_s) {
                    (None, None) => None,
                    (n, f) => Some(n.unwrap_or(0.0) + f.unwrap_or(0.0)),
                };
                ParamResult {
                    status: Status::Estimated,
                    reason: None,
                    source: None,
                    default: None,
                    model: if method == Method::Fit { None } else { model },
                    views: runs.get(&kind).map(|(v, _)| *v),
                    method: Some(method.to_string()),
                    constrained,
                    seconds,
                }
            }
            Decision::Given(given) => ParamResult {
                status: Status::Given,
                reason: None,
                source: Some(given.to_string()),
                default: None,
                model: None,
                views: None,
                method: None,
                constrained: None,
                seconds: None,
            },
            Decision::Skip { reason } => ParamResult {
                status: Status::Skipped,
                reason: Some(reason.clone()),
                source: None,
                default: Some(kind.default_value()),
                model: None,
                views: None,
                method: None,
                constrained: None,
                seconds: None,
            },
        };
        params.insert(kind.name().to_string(), entry);
    }
    let result = ResultFile {
        format: RESULT_FORMAT.to_string(),
        scan: scan.display().to_string(),
        reference_position: set.reference.clone(),
        positions: positions.iter().map(|p| p.position.clone()).collect(),
        views: set.views.iter().map(|v| v.to_string()).collect(),
        left_out: set.left_out.clone(),
        warnings,
        params,
        // The networks that ran: under `fit` the fitted parameters' are
        // loaded but not used.
        models: kinds
            .iter()
            .filter(|k| runs.contains_key(*k))
            .filter_map(|k| models.get(*k).map(|m| (k.name().to_string(), m.id.clone())))
            .collect(),
        timings,
        metrics,
        refine: tally.summary(&options.refine, &plan),
        fit: fits.summary,
    };
    let out = options
        .out
        .clone()
        .unwrap_or_else(|| scan.join(crate::pipeline::output::ESTIMATE_DIR));
    write_estimate(&out, &positions, &result)?;
    Ok(EstimateReport { out, result })
}

/// Per network that ran: the views it fused and its seconds.
type NetRuns = BTreeMap<Param, (usize, f64)>;

/// Values with every given and skipped parameter set, nothing estimated.
fn held_values(plan: &Plan, inputs: &SceneInputs) -> Result<Values, EstimateError> {
    let t = Instant::now();
    let mut values = Values::default();
    for kind in crate::net::spec::PIPELINE_ORDER {
        match plan.decision(kind) {
            Decision::Given(g) => set_given(&mut values, kind, g, inputs)?,
            Decision::Skip { .. } => set_constant(&mut values, kind, kind.default_value(), inputs),
            Decision::Estimate => {}
        }
    }
    values.given_s = t.elapsed().as_secs_f64();
    Ok(values)
}

/// Runs `stages` of networks in order, storing each answer in `values`.
fn run_stages(
    plan: &Plan,
    stages: &[Vec<Param>],
    models: &Models,
    inputs: &SceneInputs,
    values: &mut Values,
    device: &Device,
    runs: &mut NetRuns,
) -> Result<(), EstimateError> {
    for stage in stages {
        if stage.is_empty() {
            continue;
        }
        let results = run_stage(stage, models, inputs, values, device)?;
        for run in results {
            runs.insert(run.kind, (run.views, run.seconds));
            store(values, plan, run, inputs);
        }
    }
    Ok(())
}

/// The plan's networks among `kinds`, stage by stage.
fn stages_of(plan: &Plan, kinds: &[Param]) -> Vec<Vec<Param>> {
    plan.stages()
        .iter()
        .map(|s| s.iter().copied().filter(|k| kinds.contains(k)).collect())
        .collect()
}

/// What every reference position's maps are made with.
struct Pass<'a> {
    plan: &'a Plan,
    models: &'a Models,
    bundle: &'a Bundle,
    calibration: &'a ScanCalibration,
    refine: &'a RefineOptions,
    method: Method,
    fit: &'a FitOptions,
    /// Truth fed in place of measurement: with the segmentation among its
    /// pieces, the fit takes the truth's materials in each reference image.
    oracle: &'a Oracles,
    device: &'a Device,
}

impl Pass<'_> {
    /// The networks and the refinement in the image of `inputs.reference`:
    /// its maps, the networks' runs and the seconds spent reading given maps.
    fn run(
        &self,
        inputs: &SceneInputs,
        tally: &mut RefineTally,
        fits: &mut FitTally,
    ) -> Result<(PositionMaps, NetRuns, f64), EstimateError> {
        let (before, after) = self.method.networks_around_fit();
        let mut values = held_values(self.plan, inputs)?;
        let mut runs = BTreeMap::new();
        self.run_networks(before, inputs, &mut values, &mut runs)?;
        let mut fitted = if self.method.fits() {
            Some(fit_values(
                self,
                &mut values,
                inputs,
                fits.subsurface.as_ref(),
            )?)
        } else {
            None
        };
        // The networks that follow the fit read what the photos measured
        // of transmission and subsurface; one of those two among them is
        // overruled again where the photos measured it.
        let measure = |values: &mut Values, f: &mut Fitted| {
            f.constrained.transmission = measured_over(values, self.plan, f, Param::Transmission);
            f.constrained.subsurface = measured_over(values, self.plan, f, Param::Subsurface);
        };
        if let Some(f) = fitted.as_mut() {
            measure(&mut values, f);
        }
        self.run_networks(after, inputs, &mut values, &mut runs)?;
        let measured_after = after
            .iter()
            .any(|k| matches!(k, Param::Transmission | Param::Subsurface));
        if let Some(mut f) = fitted {
            if measured_after {
                measure(&mut values, &mut f);
            }
            if self.method.fit_roughness_last() {
                pinned_roughness_over(&mut values, self.plan, &f);
            }
            if self.method.fit_basecolor_last() {
                f.constrained.basecolor = measured_basecolor_over(&mut values, self.plan, &mut f);
            }
            fits.add(self.method, &f, self.bundle, inputs);
        }
        let confidence = refine_values(
            &mut values,
            self.plan,
            self.bundle,
            self.calibration,
            inputs,
            self.refine,
            tally,
        )?;
        let maps = PositionMaps {
            position: inputs.reference.clone(),
            maps: written_maps(self.plan, &values, inputs, confidence)?,
        };
        Ok((maps, runs, values.given_s))
    }
}

impl Pass<'_> {
    /// The plan's networks among `kinds`, stage by stage, into `values`.
    fn run_networks(
        &self,
        kinds: &[Param],
        inputs: &SceneInputs,
        values: &mut Values,
        runs: &mut NetRuns,
    ) -> Result<(), EstimateError> {
        run_stages(
            self.plan,
            &stages_of(self.plan, kinds),
            self.models,
            inputs,
            values,
            self.device,
            runs,
        )
    }
}

/// What the fits of all positions did: the reference position's summary
/// and shares, every position's seconds.
#[derive(Default)]
struct FitTally {
    seconds: f64,
    measured: MeasureSeconds,
    constrained: Option<Constrained>,
    summary: Option<FitSummary>,
    /// The first subsurface a position measured, which the later positions
    /// take ([`Known::subsurface`]).
    subsurface: Option<SubsurfaceFit>,
}

impl FitTally {
    fn add(&mut self, method: Method, fitted: &Fitted, bundle: &Bundle, inputs: &SceneInputs) {
        self.seconds += fitted.seconds;
        self.measured += fitted.measured;
        if self.subsurface.is_none() {
            self.subsurface = fitted
                .materials
                .iter()
                .filter_map(|m| m.subsurface.as_ref())
                .find(|s| s.value().is_some())
                .cloned();
        }
        if self.summary.is_some() {
            return;
        }
        let position = bundle.position(&inputs.reference).ok();
        // The numbers themselves: a rig recalibrated later changes them,
        // and the result must say which it was measured against.
        let intensities: Vec<String> = position
            .map(|p| {
                p.lights
                    .iter()
                    .filter_map(|l| Some(format!("{} {:.6}", l.name, l.intensity?)))
                    .collect()
            })
            .unwrap_or_default();
        self.constrained = Some(fitted.constrained);
        self.summary = Some(FitSummary {
            method,
            scale: if intensities.is_empty() {
                "none: the manifest gives no light intensity, the fit could not run".to_string()
            } else {
                format!(
                    "the manifest's light intensities at {}: {}",
                    inputs.reference,
                    intensities.join(", ")
                )
            },
            materials: fitted.materials.clone(),
            notes: fitted.notes.clone(),
        });
    }

    /// The method that answered `kind` under `method`, and the share the
    /// photos pinned.
    fn answered(&self, kind: Param, method: Method) -> (Method, Option<f32>) {
        let share = self.constrained.map(|c| match kind {
            Param::Basecolor => c.basecolor,
            Param::Roughness => c.roughness,
            Param::Metallic => c.metallic,
            Param::Transmission => c.transmission,
            Param::Subsurface => c.subsurface,
        });
        // Under a method that falls back to the networks where the photos
        // pin nothing, a parameter pinned nowhere was the networks' answer
        // throughout; the share still says the fit looked. Under `fit` the
        // fit answers everywhere.
        match (share, method.answering(kind)) {
            (Some(s), answering) if answering != Method::Networks => {
                let fell_back = s <= 0.0 && answering != Method::Fit;
                (
                    if fell_back {
                        Method::Networks
                    } else {
                        answering
                    },
                    Some(s),
                )
            }
            _ => (Method::Networks, None),
        }
    }
}

/// Replaces the estimated basecolor, roughness and metallic of `values`
/// with the physical fit's (given and skipped values are held, and the
/// fit solves basecolor under them).
fn fit_values(
    pass: &Pass<'_>,
    values: &mut Values,
    inputs: &SceneInputs,
    subsurface: Option<&SubsurfaceFit>,
) -> Result<Fitted, EstimateError> {
    let Pass {
        plan,
        bundle,
        calibration,
        method,
        fit: options,
        oracle,
        ..
    } = *pass;
    let labels = oracle.labels(bundle, &inputs.reference)?;
    let n = inputs.pixels();
    let estimated = |k: Param| *plan.decision(k) == Decision::Estimate;
    let zeros = vec![0.0f32; n];
    let transmission = values
        .scalar
        .get(&Param::Transmission)
        .map_or(zeros.as_slice(), Vec::as_slice);
    let known = Known {
        roughness: (!estimated(Param::Roughness))
            .then(|| values.scalar.get(&Param::Roughness).map(Vec::as_slice))
            .flatten(),
        metallic: (!estimated(Param::Metallic))
            .then(|| values.scalar.get(&Param::Metallic).map(Vec::as_slice))
            .flatten(),
        labels: labels.as_deref(),
        backlight: None,
        subsurface,
    };
    let grey = vec![[0.5f32; 3]; n];
    let half = vec![0.5f32; n];
    let fallback = method.falls_back().then(|| Fallback {
        basecolor: values.basecolor.as_deref().unwrap_or(&grey),
        roughness: values
            .scalar
            .get(&Param::Roughness)
            .map_or(half.as_slice(), Vec::as_slice),
        metallic: values
            .scalar
            .get(&Param::Metallic)
            .map_or(zeros.as_slice(), Vec::as_slice),
    });
    let fitted = fit_scene(
        bundle,
        calibration,
        inputs,
        transmission,
        known,
        fallback,
        options,
    )?;
    if estimated(Param::Basecolor) {
        values.basecolor = Some(fitted.basecolor.clone());
    }
    if estimated(Param::Roughness) {
        values
            .scalar
            .insert(Param::Roughness, fitted.roughness.clone());
    }
    if estimated(Param::Metallic) {
        values
            .scalar
            .insert(Param::Metallic, fitted.metallic.clone());
    }
    Ok(fitted)
}

/// Puts the fit's roughness into `values` at the pixels whose material
/// pinned it (an estimated roughness only).
fn pinned_roughness_over(values: &mut Values, plan: &Plan, fitted: &Fitted) {
    if *plan.decision(Param::Roughness) != Decision::Estimate {
        return;
    }
    if let Some(roughness) = values.scalar.get_mut(&Param::Roughness) {
        fitted.pinned_roughness_into(roughness);
    }
}

/// Puts what the photos measured of `kind` (transmission or subsurface,
/// estimated only) into `values`: 0 on the materials they show lack it, a
/// material's measured transmission; returns the share of the object it
/// answered.
fn measured_over(values: &mut Values, plan: &Plan, fitted: &Fitted, kind: Param) -> f32 {
    if *plan.decision(kind) != Decision::Estimate {
        return 0.0;
    }
    match values.scalar.get_mut(&kind) {
        Some(map) => fitted.measured_into(kind, map),
        None => 0.0,
    }
}

/// Puts what the fit measured of basecolor into `values` (an estimated
/// basecolor only): its own on the materials it reads as opaque
/// dielectrics; on the metals whose highlights gave a colour that colour,
/// and on every other material whose metallic it pinned the networks'
/// mean, each with the share of the texture the fit's and the networks'
/// readings agree on; returns the share of the object it wrote.
fn measured_basecolor_over(values: &mut Values, plan: &Plan, fitted: &mut Fitted) -> f32 {
    if *plan.decision(Param::Basecolor) != Decision::Estimate {
        return 0.0;
    }
    match values.basecolor.as_mut() {
        Some(basecolor) => {
            fitted.dielectric_basecolor_into(basecolor) + fitted.basecolor_texture_into(basecolor)
        }
        None => 0.0,
    }
}

/// What the refinements of all positions did, together.
#[derive(Default)]
struct RefineTally {
    ran: bool,
    stops: BTreeMap<StopReason, u64>,
    notes: Vec<String>,
    seconds: f64,
}

impl RefineTally {
    fn summary(&self, options: &RefineOptions, plan: &Plan) -> Option<RefineSummary> {
        if !options.enabled() {
            return None;
        }
        let mut fitted = Vec::new();
        let mut kept: BTreeMap<String, String> = NOT_FITTED
            .iter()
            .map(|(k, why)| (k.to_string(), why.to_string()))
            .collect();
        for kind in [Param::Basecolor, Param::Roughness, Param::Metallic] {
            if *plan.decision(kind) == Decision::Estimate {
                fitted.push(kind.name().to_string());
            } else {
                kept.insert(
                    kind.name().to_string(),
                    "given or skipped: held at that value".to_string(),
                );
            }
        }
        Some(RefineSummary {
            iterations: options.iterations,
            illumination: options.illumination,
            fitted: if self.ran { fitted } else { Vec::new() },
            kept,
            stops: StopReason::ALL
                .iter()
                .map(|s| {
                    (
                        s.name().to_string(),
                        self.stops.get(s).copied().unwrap_or(0),
                    )
                })
                .collect(),
            notes: self.notes.clone(),
        })
    }
}

/// Refines basecolor, roughness and metallic of `values` in place when the
/// options ask for it; the confidence maps of the fitted parameters by file
/// stem (`<param>_confidence`), empty when it did not run.
fn refine_values(
    values: &mut Values,
    plan: &Plan,
    bundle: &Bundle,
    calibration: &ScanCalibration,
    inputs: &SceneInputs,
    options: &RefineOptions,
    tally: &mut RefineTally,
) -> Result<BTreeMap<Param, ScalarRaster>, EstimateError> {
    let mut extra = BTreeMap::new();
    if !options.enabled() {
        return Ok(extra);
    }
    let scalar = |k: Param| values.scalar.get(&k);
    let (Some(basecolor), Some(roughness), Some(metallic), Some(transmission), Some(subsurface)) = (
        values.basecolor.as_ref(),
        scalar(Param::Roughness),
        scalar(Param::Metallic),
        scalar(Param::Transmission),
        scalar(Param::Subsurface),
    ) else {
        let note = "refinement skipped: it needs all five parameters (run without --only)";
        if !tally.notes.iter().any(|n| n == note) {
            tally.notes.push(note.to_string());
        }
        return Ok(extra);
    };
    let held = |k: Param| *plan.decision(k) != Decision::Estimate;
    let hold = Hold {
        basecolor: held(Param::Basecolor),
        roughness: held(Param::Roughness),
        metallic: held(Param::Metallic),
    };
    let start = Start {
        basecolor,
        roughness,
        metallic,
        transmission,
        subsurface,
        mask: &inputs.mask.data,
        hold,
    };
    let illumination: Option<Vec<Vec<f32>>> = values.illumination.as_ref().map(|views| {
        views
            .iter()
            .map(|v| v.iter().map(|&c| uncentre(c)).collect())
            .collect()
    });
    let refined = refine_scene(
        bundle,
        calibration,
        inputs,
        &start,
        illumination.as_deref(),
        options,
    )?;
    tally.ran = true;
    tally.seconds += refined.seconds;
    for (stop, count) in &refined.stops {
        *tally.stops.entry(*stop).or_insert(0) += count;
    }
    for note in refined.notes {
        if !tally.notes.contains(&note) {
            tally.notes.push(note);
        }
    }
    let (w, h) = (inputs.width as u32, inputs.height as u32);
    let mut put = |kind: Param, data: Vec<f32>| {
        if let Some(map) = ScalarRaster::from_vec(w, h, data) {
            extra.insert(kind, map);
        }
    };
    if !hold.basecolor {
        put(
            Param::Basecolor,
            refined.confidence.iter().map(|c| c.basecolor).collect(),
        );
        values.basecolor = Some(refined.basecolor);
    }
    if !hold.roughness {
        put(
            Param::Roughness,
            refined.confidence.iter().map(|c| c.roughness).collect(),
        );
        values.scalar.insert(Param::Roughness, refined.roughness);
    }
    if !hold.metallic {
        put(
            Param::Metallic,
            refined.confidence.iter().map(|c| c.metallic).collect(),
        );
        values.scalar.insert(Param::Metallic, refined.metallic);
    }
    Ok(extra)
}

/// The views `kind`'s network fuses.
fn views_for(kind: Param, inputs: &SceneInputs) -> Vec<usize> {
    (0..inputs.views.len())
        .filter(|&i| inputs.views[i].serves(kind))
        .collect()
}

/// Runs the networks of one stage concurrently.
fn run_stage(
    stage: &[Param],
    models: &Models,
    inputs: &SceneInputs,
    values: &Values,
    device: &Device,
) -> Result<Vec<NetRun>, EstimateError> {
    let metallic = values.scalar.get(&Param::Metallic);
    let transmission = values.scalar.get(&Param::Transmission);
    let subsurface = values.scalar.get(&Param::Subsurface);
    let transmission_final: Option<Vec<f32>> = match (transmission, metallic) {
        (Some(t), Some(m)) => Some(t.iter().zip(m).map(|(t, m)| t * (1.0 - m)).collect()),
        _ => None,
    };
    let subsurface_final: Option<Vec<f32>> = match (subsurface, &transmission_final, metallic) {
        (Some(s), Some(_), Some(m)) => transmission.map(|t| {
            s.iter()
                .zip(m)
                .zip(t)
                .map(|((s, m), t)| s * (1.0 - m) * (1.0 - t))
                .collect()
        }),
        _ => None,
    };
    let deps = Dependencies {
        metallic: metallic.map(Vec::as_slice),
        transmission_final: transmission_final.as_deref(),
        subsurface_final: subsurface_final.as_deref(),
        roughness: values.scalar.get(&Param::Roughness).map(Vec::as_slice),
        illumination: values.illumination.as_deref(),
    };
    let run_one = |kind: Param| -> Result<NetRun, EstimateError> {
        let t = Instant::now();
        let model = models.get(kind).ok_or(ModelsError::NotProvided(kind))?;
        let which = views_for(kind, inputs);
        let tensors = inputs.tensors(kind, &which, &deps, device)?;
        let out = model
            .net
            .forward(&tensors)
            .map_err(|source| EstimateError::Network { kind, source })?;
        let read = |t: burn::tensor::Tensor<4>| {
            t.into_data()
                .try_to_vec::<f32>()
                .map_err(|e| EstimateError::Readback {
                    kind,
                    message: format!("{e:?}"),
                })
        };
        let fused = read(out.fused)?;
        let n = inputs.pixels();
        let mut per_view = Vec::with_capacity(out.per_view.len());
        for t in out.per_view {
            let mut v = read(t)?;
            v.truncate(n);
            per_view.push(v);
        }
        Ok(NetRun {
            kind,
            fused,
            per_view,
            views: which.len(),
            seconds: t.elapsed().as_secs_f64(),
        })
    };
    let results: Vec<Result<NetRun, EstimateError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = stage
            .iter()
            .map(|&kind| scope.spawn(move || run_one(kind)))
            .collect();
        handles
            .into_iter()
            .map(|h| match h.join() {
                Ok(result) => result,
                Err(panic) => std::panic::resume_unwind(panic),
            })
            .collect()
    });
    results.into_iter().collect()
}

/// Keeps a network's result as the parameter's value (unless given) and
/// roughness's illumination.
fn store(values: &mut Values, plan: &Plan, run: NetRun, inputs: &SceneInputs) {
    let n = inputs.pixels();
    let mask = &inputs.mask.data;
    if run.kind == Param::Roughness {
        values.illumination = Some(run.per_view);
    }
    if plan.decision(run.kind) != &Decision::Estimate {
        return;
    }
    if run.kind == Param::Basecolor {
        let rgb = (0..n)
            .map(|i| {
                if !mask[i] {
                    return [0.0; 3];
                }
                rgb_of_ycbcr([0, 1, 2].map(|c| uncentre(run.fused[c * n + i])))
            })
            .collect();
        values.basecolor = Some(rgb);
    } else {
        let map = (0..n)
            .map(|i| if mask[i] { uncentre(run.fused[i]) } else { 0.0 })
            .collect();
        values.scalar.insert(run.kind, map);
    }
}

fn set_constant(values: &mut Values, kind: Param, v: f32, inputs: &SceneInputs) {
    let n = inputs.pixels();
    if kind == Param::Basecolor {
        values.basecolor = Some(vec![[v; 3]; n]);
    } else {
        values.scalar.insert(kind, vec![v; n]);
    }
}

fn set_given(
    values: &mut Values,
    kind: Param,
    given: &Given,
    inputs: &SceneInputs,
) -> Result<(), EstimateError> {
    let path = match given {
        Given::Constant(v) => {
            set_constant(values, kind, *v, inputs);
            return Ok(());
        }
        Given::Map(path) => path,
    };
    let fail = |reason: String| EstimateError::GivenMap {
        param: kind,
        path: path.clone(),
        reason,
    };
    let (w, h) = (inputs.width as u32, inputs.height as u32);
    let unit = |v: f32| v.clamp(0.0, 1.0);
    if kind == Param::Basecolor {
        let map = read_rgb_exr(path).map_err(|e| fail(e.to_string()))?;
        if (map.width, map.height) != (w, h) {
            return Err(fail(size_reason(map.width, map.height, w, h)));
        }
        values.basecolor = Some(map.data.iter().map(|c| c.map(unit)).collect());
    } else {
        let map = read_scalar_exr(path).map_err(|e| fail(e.to_string()))?;
        if (map.width, map.height) != (w, h) {
            return Err(fail(size_reason(map.width, map.height, w, h)));
        }
        values
            .scalar
            .insert(kind, map.data.iter().map(|&v| unit(v)).collect());
    }
    Ok(())
}

fn size_reason(w: u32, h: u32, want_w: u32, want_h: u32) -> String {
    format!("the map is {w}x{h}, the reference camera image is {want_w}x{want_h}")
}

/// The maps to write: every estimated or given parameter, with the
/// refinement's confidence where it fitted one.
fn written_maps(
    plan: &Plan,
    values: &Values,
    inputs: &SceneInputs,
    mut confidence: BTreeMap<Param, ScalarRaster>,
) -> Result<Vec<ParamMap>, EstimateError> {
    let (w, h) = (inputs.width as u32, inputs.height as u32);
    let mut maps = Vec::new();
    for kind in crate::net::spec::PIPELINE_ORDER {
        if matches!(plan.decision(kind), Decision::Skip { .. }) {
            continue;
        }
        let map = if kind == Param::Basecolor {
            values
                .basecolor
                .clone()
                .and_then(|d| RgbRaster::from_vec(w, h, d))
                .map(ParamMap::basecolor)
        } else {
            values
                .scalar
                .get(&kind)
                .cloned()
                .and_then(|d| ScalarRaster::from_vec(w, h, d))
                .map(|r| ParamMap::scalar(kind, r))
                .transpose()?
        };
        if let Some(map) = map {
            maps.push(match confidence.remove(&kind) {
                Some(c) => map.with_confidence(c)?,
                None => map,
            });
        }
    }
    Ok(maps)
}

/// MAD, MSE and PSNR of each written map against the truth, over the truth
/// mask (the reference object mask where the scan has no truth mask).
fn metrics(
    bundle: &Bundle,
    reference: &str,
    maps: &[ParamMap],
    inputs: &SceneInputs,
) -> Result<BTreeMap<String, crate::pipeline::metrics::ErrorMetrics>, EstimateError> {
    let mask = bundle
        .truth_mask(reference)?
        .map_or_else(|| inputs.mask.data.clone(), |m| m.data);
    let mut out = BTreeMap::new();
    for map in maps {
        let kind = map.param();
        let Some(truth) = bundle.truth_param(reference, kind)? else {
            continue;
        };
        let ((estimated, channels), (truth, truth_channels)) = (map.values().flat(), truth.flat());
        let found = if channels == truth_channels {
            error_metrics(estimated, truth, &mask, channels)
        } else {
            None
        };
        if let Some(m) = found {
            out.insert(kind.name().to_string(), m);
        }
    }
    Ok(out)
}
