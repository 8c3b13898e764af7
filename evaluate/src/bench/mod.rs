//! Error against run time (`matscan bench`). Sweeps the knobs that trade one
//! for the other over a fixed, cached set of simulated scenes and prints a
//! table; `--out` also gets `bench.csv` and `bench.png` (x: median seconds
//! per scan, log scale; y: MAD; a panel per parameter, a line per knob).
//!
//! Every row changes one knob of the base configuration (`--base-size`
//! pixels, every view, the shipped network widths, the default CPU
//! backend):
//! - views: the first N views of each scan (as `matscan eval --views`);
//! - resolution: the same scenes rendered at each size;
//! - network width: multiples of the shipped widths. Only the shipped
//!   widths have trained weights, so other widths run random networks of
//!   that shape: their run time is real, their error is not reported
//!   ("untrained");
//! - backend: the CPU backends built in (the others, and any GPU, are
//!   listed as not built rather than left out).
//!
//! A new knob is one [`Knob`] variant, one arm in [`Sweep::settings`] and,
//! if it changes something `RowConfig` does not hold yet, one field.
//!
//! The evaluation set comes from a recipe (`data/recipes/bench.toml`,
//! embedded, or `--recipe FILE`): the first `--scenes` of its scenes, its
//! sets taken in turn, rendered once into `--data DIR` at every image size
//! the knobs need (`DIR/<size>px/<kind>-<geometry>/scene-<seed>`), with the
//! recipe copied to `DIR/bench-recipe.toml`; a later run with another
//! recipe stops instead of mixing sets. Each configuration's run time is
//! the median over the scenes
//! of the estimate's own `total_s` (writing excluded); MAD is the mean over
//! the scenes.
//!
//! Boundaries: renders with `matscan_sim::dataset`, estimates with
//! [`crate::eval::chained::evaluate_scene`], aggregates with
//! [`crate::eval::tables`], draws with [`crate::plot::chart`]; changes no
//! scan outside `--data`.

use crate::eval::chained::evaluate_scene;
use crate::eval::report::views_label;
use crate::eval::tables::{csv_field, csv_number, median, GroupBy, Means};
use crate::plot::chart::{self, Chart, Panel, Point, Series};
use crate::scans::{all_views, view_filter};
use anyhow::{bail, Context, Result};
use burn::tensor::Device;
use matscan_estimate::device::backend::{Backend, BackendError, CpuBackend};
use matscan_estimate::net::weights::EMBEDDED;
use matscan_estimate::pipeline::method::Method;
use matscan_estimate::refine::RefineOptions;
use matscan_estimate::GpuUnavailable;
use matscan_estimate::{EstimateOptions, ModelSource, Models, NetConfig, ParamNet};
use matscan_scan::Param;
use matscan_sim::dataset::Recipe;
use matscan_sim::scene::SceneOptions;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The knobs `matscan bench` sweeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Knob {
    Views,
    Resolution,
    Width,
    Backend,
    /// Iterations of the analysis-by-synthesis refinement after the
    /// networks (`matscan estimate --refine N`; 0 = networks only).
    Refine,
    /// Who answers basecolor, roughness and metallic (`matscan estimate
    /// --method`): networks, fit, hybrid, fit-metallic, fit-specular,
    /// fit-dielectric.
    Method,
}

impl Knob {
    /// Every knob, in table order.
    pub const ALL: [Knob; 6] = [
        Knob::Method,
        Knob::Views,
        Knob::Resolution,
        Knob::Width,
        Knob::Backend,
        Knob::Refine,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Knob::Views => "views",
            Knob::Resolution => "resolution",
            Knob::Width => "width",
            Knob::Backend => "backend",
            Knob::Refine => "refine",
            Knob::Method => "method",
        }
    }

    /// Line colour in the plot.
    fn colour(self) -> [u8; 3] {
        match self {
            Knob::Views => [31, 119, 180],
            Knob::Resolution => [214, 39, 40],
            Knob::Width => [44, 160, 44],
            Knob::Backend => [148, 103, 189],
            Knob::Refine => [255, 127, 14],
            Knob::Method => [23, 190, 207],
        }
    }
}

impl std::str::FromStr for Knob {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Knob::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!("unknown knob `{s}`: expected method, views, resolution, width, backend or refine")
            })
    }
}

/// Image size of every other knob's rows, by default.
pub const DEFAULT_BASE_SIZE: u32 = 256;
/// The shipped bench set's recipe (`data/recipes/bench.toml`).
pub const DEFAULT_RECIPE: &str = include_str!("../../../data/recipes/bench.toml");

/// The shipped bench recipe.
pub fn default_recipe() -> Recipe {
    // A shipped file that a test reads: it parses.
    Recipe::parse(DEFAULT_RECIPE, Path::new("data/recipes/bench.toml"))
        .expect("the shipped bench recipe parses")
}

/// What `matscan bench` sweeps, and on which set. `None` fields take the
/// defaults of [`Sweep::from_options`] (smaller with `quick`).
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// The evaluation set's folder: rendered where missing, reused where
    /// present.
    pub data: PathBuf,
    /// Also write bench.csv and bench.png here.
    pub out: Option<PathBuf>,
    /// A quick run: 1 scene, only the base size, views 1 and all, the
    /// shipped width only (explicit values still win).
    pub quick: bool,
    /// Scenes per size [default: 3; quick: 1].
    pub scenes: Option<usize>,
    /// Image sizes of the resolution knob [default: 128, 256, 512, 768;
    /// quick: the base size].
    pub sizes: Option<Vec<u32>>,
    /// Image size of every other knob's rows.
    pub base_size: u32,
    /// View counts of the views knob; 0 = every view [default: 1, 3, 0;
    /// quick: 1, 0].
    pub views: Option<Vec<usize>>,
    /// Multiples of the shipped network widths [default: 0.5, 1, 2; quick:
    /// 1].
    pub widths: Option<Vec<f64>>,
    /// Refinement iterations of the refine knob [default: 0, 2, 5, 10;
    /// quick: 0, 3].
    pub refine: Option<Vec<u32>>,
    /// Knobs to leave out.
    pub skip: Vec<Knob>,
    /// The set: its scenes, positions and samples (the image size comes
    /// from the knobs).
    pub recipe: Recipe,
    /// Folder with `<param>.weights` per network; `None`: the embedded ones.
    pub weights: Option<PathBuf>,
}

impl BenchOptions {
    /// The full default sweep over the set in `data`.
    pub fn new(data: impl Into<PathBuf>) -> BenchOptions {
        BenchOptions {
            data: data.into(),
            out: None,
            quick: false,
            scenes: None,
            sizes: None,
            base_size: DEFAULT_BASE_SIZE,
            views: None,
            widths: None,
            refine: None,
            skip: Vec::new(),
            recipe: default_recipe(),
            weights: None,
        }
    }
}

/// What one row runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RowConfig {
    /// Image width and height.
    pub size: u32,
    /// Views per scan (0 = every view).
    pub views: usize,
    /// Network widths in percent of the shipped ones.
    pub width_percent: u32,
    pub backend: Backend,
    /// Refinement iterations (0 = networks only).
    pub refine: u32,
    /// Who answers basecolor, roughness and metallic.
    pub method: Method,
}

/// The resolved sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    pub scenes: usize,
    pub base: RowConfig,
    pub sizes: Vec<u32>,
    pub views: Vec<usize>,
    pub width_percents: Vec<u32>,
    pub refine: Vec<u32>,
    pub knobs: Vec<Knob>,
}

impl Sweep {
    /// The sweep `args` ask for: `--quick` defaults, then explicit flags.
    pub fn from_options(args: &BenchOptions) -> Result<Sweep> {
        let quick = args.quick;
        let scenes = args.scenes.unwrap_or(if quick { 1 } else { 3 });
        let sizes = args.sizes.clone().unwrap_or_else(|| {
            if quick {
                vec![args.base_size]
            } else {
                vec![128, 256, 512, 768]
            }
        });
        let views =
            args.views
                .clone()
                .unwrap_or_else(|| if quick { vec![1, 0] } else { vec![1, 3, 0] });
        let widths = args.widths.clone().unwrap_or_else(|| {
            if quick {
                vec![1.0]
            } else {
                vec![0.5, 1.0, 2.0]
            }
        });
        let refine =
            args.refine.clone().unwrap_or_else(
                || {
                    if quick {
                        vec![0, 3]
                    } else {
                        vec![0, 2, 5, 10]
                    }
                },
            );
        if let Some(n) = refine.iter().find(|n| **n > 1000) {
            bail!("--refine {n}: expected at most 1000 iterations");
        }
        if scenes == 0 {
            bail!("--scenes 0: expected at least one scene");
        }
        if let Some(s) = sizes.iter().chain([&args.base_size]).find(|s| **s < 8) {
            bail!("--sizes/--base-size {s}: expected at least 8 pixels");
        }
        let width_percents = widths
            .iter()
            .map(|w| {
                if w.is_finite() && *w > 0.0 && *w <= 8.0 {
                    Ok((w * 100.0).round() as u32)
                } else {
                    bail!("--widths {w}: expected a multiple of the shipped widths in (0, 8]")
                }
            })
            .collect::<Result<Vec<u32>>>()?;
        Ok(Sweep {
            scenes,
            base: RowConfig {
                size: args.base_size,
                views: 0,
                width_percent: 100,
                backend: Backend::Cpu(matscan_estimate::device::backend::default_cpu_backend()),
                refine: 0,
                method: Method::default(),
            },
            sizes,
            views,
            width_percents,
            refine,
            knobs: Knob::ALL
                .into_iter()
                .filter(|k| !args.skip.contains(k))
                .collect(),
        })
    }

    /// The rows of `knob`: each a label and the base with that one change.
    pub fn settings(&self, knob: Knob) -> Vec<(String, RowConfig)> {
        let base = self.base;
        match knob {
            Knob::Views => self
                .views
                .iter()
                .map(|&views| (views_label(views), RowConfig { views, ..base }))
                .collect(),
            Knob::Resolution => self
                .sizes
                .iter()
                .map(|&size| (format!("{size} px"), RowConfig { size, ..base }))
                .collect(),
            Knob::Width => self
                .width_percents
                .iter()
                .map(|&p| {
                    (
                        width_label(p),
                        RowConfig {
                            width_percent: p,
                            ..base
                        },
                    )
                })
                .collect(),
            Knob::Backend => CpuBackend::ALL
                .into_iter()
                .map(Backend::Cpu)
                .chain([Backend::Gpu])
                .map(|backend| (backend.label(), RowConfig { backend, ..base }))
                .collect(),
            Knob::Refine => self
                .refine
                .iter()
                .map(|&refine| (refine_label(refine), RowConfig { refine, ..base }))
                .collect(),
            Knob::Method => Method::ALL
                .into_iter()
                .map(|method| (method.to_string(), RowConfig { method, ..base }))
                .collect(),
        }
    }

    /// Every size some row needs.
    fn sizes_needed(&self) -> Vec<u32> {
        let mut sizes: Vec<u32> = self
            .knobs
            .iter()
            .flat_map(|&k| self.settings(k))
            .map(|(_, c)| c.size)
            .collect();
        sizes.sort_unstable();
        sizes.dedup();
        sizes
    }
}

fn refine_label(iterations: u32) -> String {
    if iterations == 0 {
        "networks only".to_string()
    } else {
        format!("refine {iterations}")
    }
}

fn width_label(percent: u32) -> String {
    if percent == 100 {
        "shipped".to_string()
    } else {
        format!("x{}", f64::from(percent) / 100.0)
    }
}

/// How a row came out.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    /// Run on `scenes` scenes; `mad` only where the weights are trained.
    Measured {
        scenes: usize,
        median_seconds: f64,
        mad: Option<BTreeMap<Param, f64>>,
    },
    /// The configuration cannot run in this build.
    NotBuilt(String),
    /// Every scene failed; the first reason.
    Failed(String),
}

/// Where the set's recipe is recorded, beside the set.
const DATA_RECIPE: &str = "bench-recipe.toml";

/// The scans of the set at `size`, rendering those missing.
fn ensure_scenes(
    dir: &Path,
    recipe: &Recipe,
    size: u32,
    scenes: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>> {
    let folder = dir.join(format!("{size}px"));
    let planned = recipe
        .interleaved()
        .map_err(|e| anyhow::anyhow!("the bench recipe: {e}"))?;
    if planned.len() < scenes {
        bail!(
            "the bench recipe has {} scenes, --scenes asks for {scenes}",
            planned.len()
        );
    }
    let mut scans = Vec::new();
    for p in planned.into_iter().take(scenes) {
        let out = folder.join(&p.folder);
        if !out.join("scan.toml").is_file() {
            progress(&format!(
                "rendering {} ({size}x{size}, {} spp)",
                out.display(),
                p.sim.samples
            ));
            if let Some(parent) = out.parent() {
                std::fs::create_dir_all(parent)
                    .with_context(|| format!("creating {}", parent.display()))?;
            }
            let options = SceneOptions {
                width: size,
                height: size,
                ..p.scene
            };
            let secs = matscan_sim::dataset::render_scene(&options, &p.sim, &out, false)?;
            progress(&format!("  {secs:.1} s"));
        }
        scans.push(out);
    }
    Ok(scans)
}

/// Checks (or records) the recipe the set in `dir` was rendered from.
fn check_data_recipe(dir: &Path, recipe: &Recipe, text: &str) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let path = dir.join(DATA_RECIPE);
    match std::fs::read_to_string(&path) {
        Ok(found_text) => {
            let found = Recipe::parse(&found_text, &path)?;
            if &found != recipe {
                bail!(
                    "{}: the set there was rendered from another recipe ({:?}) than this run's \
                     ({:?}); use another --data folder or the same --recipe",
                    path.display(),
                    found.description,
                    recipe.description
                );
            }
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            matscan_scan::atomic::write_atomic(&path, text.as_bytes())
                .with_context(|| format!("writing {}", path.display()))
        }
        Err(e) => Err(e).with_context(|| format!("reading {}", path.display())),
    }
}

/// Random networks `percent` % as wide as the shipped ones (tracks too).
fn scaled_models(percent: u32, device: &Device) -> Result<Models> {
    let mut models = Models::new();
    for (i, kind) in matscan_estimate::PIPELINE_ORDER.into_iter().enumerate() {
        let shipped = NetConfig::shipped(kind);
        let scale = |v: usize| ((v as f64 * f64::from(percent) / 100.0).round() as usize).max(1);
        // Networks that split their features need an even width.
        let width = (scale(shipped.width()).div_ceil(2) * 2).max(2);
        let config = NetConfig::with_track(kind, width, scale(shipped.track()))
            .with_context(|| format!("{kind} network at {percent} % width"))?;
        device.seed(7 + i as u64);
        models.insert(
            ParamNet::new(config, device),
            format!("{kind}-w{width}-untrained"),
        );
    }
    Ok(models)
}

/// Runs one configuration over `scans`.
fn run_config(
    config: &RowConfig,
    scans: &[PathBuf],
    weights: &Option<PathBuf>,
    views_cache: &mut BTreeMap<PathBuf, Option<Vec<String>>>,
    scratch: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<Outcome> {
    let device = match config.backend.device() {
        Ok((device, adapter)) => {
            if let Some(adapter) = adapter {
                progress(&format!("gpu row on {adapter}"));
            }
            device
        }
        Err(BackendError::Gpu(GpuUnavailable::NotBuilt)) => {
            return Ok(Outcome::NotBuilt(
                "not built (no GPU backend in this build; --features vulkan)".to_string(),
            ))
        }
        Err(BackendError::Gpu(unavailable)) => {
            return Ok(Outcome::NotBuilt(format!("no GPU ({unavailable})")))
        }
        Err(BackendError::Cpu(missing)) => {
            return Ok(Outcome::NotBuilt(format!("not built ({missing})")))
        }
    };
    let trained = config.width_percent == 100;
    let mut results = Vec::new();
    let mut failures = Vec::new();
    for (i, scan) in scans.iter().enumerate() {
        let all = if config.views > 0 {
            views_cache
                .entry(scan.clone())
                // A scan that cannot be calibrated here lets the estimate
                // fail and report it.
                .or_insert_with(|| all_views(scan).ok().flatten())
                .clone()
        } else {
            None
        };
        let models = if trained {
            match weights {
                Some(dir) => ModelSource::Dir(dir.clone()),
                None => ModelSource::Embedded,
            }
        } else {
            ModelSource::Loaded(scaled_models(config.width_percent, &device)?)
        };
        let options = EstimateOptions {
            out: Some(scratch.join(format!("scene-{i}"))),
            filter: view_filter(config.views, all.as_deref()),
            refine: RefineOptions {
                iterations: config.refine,
                ..RefineOptions::default()
            },
            method: config.method,
            ..EstimateOptions::default()
        };
        match evaluate_scene(scan, models, &options, &device, GroupBy::Kind, None) {
            Ok(r) => results.push(r),
            Err(e) => failures.push(format!("{e:#}")),
        }
    }
    let _ = std::fs::remove_dir_all(scratch);
    if results.is_empty() {
        return Ok(Outcome::Failed(
            failures
                .into_iter()
                .next()
                .unwrap_or_else(|| "no scenes".to_string()),
        ));
    }
    let seconds: Vec<f64> = results.iter().map(|r| r.seconds).collect();
    let mad = trained.then(|| {
        matscan_estimate::PIPELINE_ORDER
            .into_iter()
            .filter_map(|k| {
                Means::of(results.iter().filter_map(|r| r.metrics.get(&k))).map(|m| (k, m.mad))
            })
            .collect()
    });
    Ok(Outcome::Measured {
        scenes: results.len(),
        median_seconds: median(&seconds),
        mad,
    })
}

/// One printed row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub knob: Knob,
    pub setting: String,
    pub config: RowConfig,
    pub outcome: Outcome,
}

/// Header of `bench.csv`; the MAD columns follow `matscan_estimate::PIPELINE_ORDER`, the
/// order the values are written in.
pub fn csv_header() -> String {
    let mut header = String::from(
        "knob,setting,size,views,width_scale,backend,refine_iterations,method,scenes,median_seconds,status",
    );
    for kind in matscan_estimate::PIPELINE_ORDER {
        header.push_str(&format!(",{}_mad", kind.name()));
    }
    header
}

/// `bench.csv`: one line per row; MAD fields empty where not measured.
pub fn csv(rows: &[Row]) -> String {
    let mut out = format!("{}\n", csv_header());
    for r in rows {
        let c = &r.config;
        let (scenes, seconds, status, mad) = match &r.outcome {
            Outcome::Measured {
                scenes,
                median_seconds,
                mad,
            } => (
                scenes.to_string(),
                csv_number(Some(*median_seconds)),
                if mad.is_some() {
                    "measured"
                } else {
                    "untrained"
                }
                .to_string(),
                mad.clone(),
            ),
            Outcome::NotBuilt(why) | Outcome::Failed(why) => {
                (String::new(), String::new(), why.clone(), None)
            }
        };
        let _ = write!(
            out,
            "{},{},{},{},{},{},{},{},{scenes},{seconds},{}",
            r.knob.name(),
            csv_field(&r.setting),
            c.size,
            c.views,
            f64::from(c.width_percent) / 100.0,
            csv_field(&c.backend.label()),
            c.refine,
            c.method,
            csv_field(&status),
        );
        for kind in matscan_estimate::PIPELINE_ORDER {
            let v = mad.as_ref().and_then(|m| m.get(&kind).copied());
            let _ = write!(out, ",{}", csv_number(v));
        }
        out.push('\n');
    }
    out
}

/// The printed table.
pub fn table(rows: &[Row]) -> String {
    let mut out = format!(
        "{:<10} {:<22} {:>5} {:>6} {:>10}",
        "knob", "setting", "px", "scenes", "median s"
    );
    for kind in matscan_estimate::PIPELINE_ORDER {
        let _ = write!(out, " {:>12}", kind.name());
    }
    out.push('\n');
    for r in rows {
        let _ = write!(
            out,
            "{:<10} {:<22} {:>5}",
            r.knob.name(),
            r.setting,
            r.config.size
        );
        match &r.outcome {
            Outcome::Measured {
                scenes,
                median_seconds,
                mad,
            } => {
                let _ = write!(out, " {scenes:>6} {median_seconds:>10.2}");
                for kind in matscan_estimate::PIPELINE_ORDER {
                    match mad {
                        Some(m) => match m.get(&kind) {
                            Some(v) => {
                                let _ = write!(out, " {v:>12.4}");
                            }
                            None => {
                                let _ = write!(out, " {:>12}", "-");
                            }
                        },
                        None => {
                            let _ = write!(out, " {:>12}", "untrained");
                        }
                    }
                }
            }
            Outcome::NotBuilt(why) | Outcome::Failed(why) => {
                let _ = write!(out, "  {why}");
            }
        }
        out.push('\n');
    }
    out
}

/// The plot: a panel per parameter, a line per knob through its measured,
/// trained rows (knobs with fewer than two such rows add no line).
pub fn chart(rows: &[Row], title: &str) -> Chart {
    let panels = matscan_estimate::PIPELINE_ORDER
        .into_iter()
        .map(|kind| Panel {
            title: kind.name().to_string(),
            series: Knob::ALL
                .into_iter()
                .map(|knob| Series {
                    name: knob.name().to_string(),
                    colour: knob.colour(),
                    points: rows
                        .iter()
                        .filter(|r| r.knob == knob)
                        .filter_map(|r| match &r.outcome {
                            Outcome::Measured {
                                median_seconds,
                                mad: Some(mad),
                                ..
                            } => mad.get(&kind).map(|&y| Point {
                                x: *median_seconds,
                                y,
                                label: r.setting.clone(),
                            }),
                            _ => None,
                        })
                        .collect(),
                })
                .filter(|s| s.points.len() >= 2)
                .collect(),
        })
        .collect();
    Chart {
        title: title.to_string(),
        x_label: "median seconds per scan (log)".to_string(),
        y_label: "MAD".to_string(),
        x_log: true,
        y_log: false,
        panels,
        columns: 3,
    }
}

/// Runs the sweep `args` describe, handing each progress line to
/// `progress`; returns the report (the table, the bench time, the files
/// written).
pub fn run(args: &BenchOptions, progress: &mut dyn FnMut(&str)) -> Result<String> {
    let started = Instant::now();
    let plan = Sweep::from_options(args)?;
    if args.weights.is_none() && EMBEDDED.is_empty() {
        bail!("this build embeds no trained weights; pass --weights DIR");
    }
    let recipe_text = toml::to_string(&args.recipe).context("encoding the bench recipe")?;
    check_data_recipe(&args.data, &args.recipe, &recipe_text)?;
    let mut scans_at = BTreeMap::new();
    for size in plan.sizes_needed() {
        scans_at.insert(
            size,
            ensure_scenes(&args.data, &args.recipe, size, plan.scenes, progress)?,
        );
    }
    let render_s = started.elapsed().as_secs_f64();

    let scratch = std::env::temp_dir().join(format!("matscan-bench-{}", std::process::id()));
    // Rows sharing a configuration (the base appears under every knob) are
    // measured once.
    let mut done: Vec<(RowConfig, Outcome)> = Vec::new();
    let mut views_cache = BTreeMap::new();
    let mut rows = Vec::new();
    for &knob in &plan.knobs {
        for (setting, config) in plan.settings(knob) {
            let outcome = match done.iter().find(|(c, _)| *c == config) {
                Some((_, o)) => o.clone(),
                None => {
                    progress(&format!("bench: {} = {setting}", knob.name()));
                    let scans = scans_at.get(&config.size).map_or(&[][..], |s| &s[..]);
                    let o = run_config(
                        &config,
                        scans,
                        &args.weights,
                        &mut views_cache,
                        &scratch,
                        progress,
                    )?;
                    done.push((config, o.clone()));
                    o
                }
            };
            rows.push(Row {
                knob,
                setting,
                config,
                outcome,
            });
        }
    }
    let total_s = started.elapsed().as_secs_f64();
    let mut report = String::new();
    let _ = writeln!(
        report,
        "matscan bench: {} scenes per size from {}; base {} px, all views, shipped widths, {}",
        plan.scenes,
        args.data.display(),
        plan.base.size,
        plan.base.backend.label()
    );
    report.push_str(&table(&rows));
    let _ = writeln!(
        report,
        "bench time {total_s:.0} s (rendering the set {render_s:.0} s of it); \
         'untrained': random networks of that width, run time only"
    );
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
        let csv_path = out.join("bench.csv");
        matscan_scan::atomic::write_atomic(&csv_path, csv(&rows).as_bytes())
            .with_context(|| format!("writing {}", csv_path.display()))?;
        let png = out.join("bench.png");
        let title = format!(
            "matscan bench: MAD against run time, {} scenes, base {} px",
            plan.scenes, plan.base.size
        );
        chart::write_png(&chart(&rows, &title), &png)?;
        let _ = writeln!(report, "wrote {} and {}", csv_path.display(), png.display());
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(options: BenchOptions) -> Sweep {
        Sweep::from_options(&options).unwrap()
    }

    #[test]
    fn the_set_records_its_recipe_and_refuses_another() {
        let shipped = default_recipe();
        assert!(shipped.interleaved().unwrap().len() >= 12);
        let text = toml::to_string(&shipped).unwrap();
        let dir = tempfile::tempdir().unwrap();
        check_data_recipe(dir.path(), &shipped, &text).unwrap();
        check_data_recipe(dir.path(), &shipped, &text).unwrap();
        let mut other = shipped.clone();
        other.samples += 1;
        let e = check_data_recipe(dir.path(), &other, &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bench-recipe.toml") && e.contains("--recipe"),
            "{e}"
        );
    }

    #[test]
    fn every_row_changes_one_knob_of_the_base() {
        let p = plan(BenchOptions::new("d"));
        assert_eq!(p.scenes, 3);
        let res = p.settings(Knob::Resolution);
        let sizes: Vec<u32> = res.iter().map(|(_, c)| c.size).collect();
        assert_eq!(sizes, [128, 256, 512, 768]);
        assert!(res
            .iter()
            .all(|(_, c)| c.views == 0 && c.width_percent == 100));
        let widths: Vec<u32> = p
            .settings(Knob::Width)
            .iter()
            .map(|(_, c)| c.width_percent)
            .collect();
        assert_eq!(widths, [50, 100, 200]);
        let backends: Vec<String> = p
            .settings(Knob::Backend)
            .iter()
            .map(|(l, _)| l.clone())
            .collect();
        assert_eq!(backends, ["cpu flex", "cpu ndarray", "gpu"]);
        let refine: Vec<(String, u32)> = p
            .settings(Knob::Refine)
            .into_iter()
            .map(|(l, c)| (l, c.refine))
            .collect();
        assert_eq!(refine[0], ("networks only".to_string(), 0));
        assert_eq!(refine[3], ("refine 10".to_string(), 10));
        assert_eq!(p.sizes_needed(), [128, 256, 512, 768]);
    }

    #[test]
    fn quick_shrinks_the_sweep_but_explicit_flags_win() {
        let p = plan(BenchOptions {
            quick: true,
            base_size: 32,
            skip: vec![Knob::Width],
            ..BenchOptions::new("d")
        });
        assert_eq!(p.scenes, 1);
        assert_eq!(p.sizes, [32]);
        assert_eq!(p.views, [1, 0]);
        assert!(!p.knobs.contains(&Knob::Width));
        assert_eq!(p.sizes_needed(), [32]);
        let p = plan(BenchOptions {
            quick: true,
            scenes: Some(2),
            ..BenchOptions::new("d")
        });
        assert_eq!(p.scenes, 2);
    }

    #[test]
    fn untrained_and_unbuilt_rows_report_no_error_in_csv_and_chart() {
        let base = plan(BenchOptions::new("d")).base;
        let mad: BTreeMap<Param, f64> = matscan_estimate::PIPELINE_ORDER
            .into_iter()
            .map(|k| (k, 0.1))
            .collect();
        let rows = vec![
            Row {
                knob: Knob::Width,
                setting: "shipped".into(),
                config: base,
                outcome: Outcome::Measured {
                    scenes: 3,
                    median_seconds: 2.0,
                    mad: Some(mad),
                },
            },
            Row {
                knob: Knob::Width,
                setting: "x2".into(),
                config: RowConfig {
                    width_percent: 200,
                    ..base
                },
                outcome: Outcome::Measured {
                    scenes: 3,
                    median_seconds: 6.0,
                    mad: None,
                },
            },
            Row {
                knob: Knob::Backend,
                setting: "gpu".into(),
                config: RowConfig {
                    backend: Backend::Gpu,
                    ..base
                },
                outcome: Outcome::NotBuilt("not built (no GPU backend in this build)".into()),
            },
        ];
        let text = csv(&rows);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 4);
        // Each MAD column holds its own parameter's value.
        let distinct: BTreeMap<Param, f64> = matscan_estimate::PIPELINE_ORDER
            .into_iter()
            .enumerate()
            .map(|(i, k)| (k, 0.1 * (i + 1) as f64))
            .collect();
        let mut labelled = rows[0].clone();
        if let Outcome::Measured { mad, .. } = &mut labelled.outcome {
            *mad = Some(distinct.clone());
        }
        let one = csv(&[labelled]);
        let mut one_lines = one.lines();
        let header: Vec<&str> = one_lines.next().unwrap().split(',').collect();
        let values: Vec<&str> = one_lines.next().unwrap().split(',').collect();
        for (kind, v) in &distinct {
            let col = header
                .iter()
                .position(|h| *h == format!("{}_mad", kind.name()))
                .unwrap();
            assert_eq!(values[col].parse::<f64>().unwrap(), *v, "{kind}");
        }
        assert!(
            lines[1].ends_with(",measured,0.1,0.1,0.1,0.1,0.1"),
            "{}",
            lines[1]
        );
        assert!(
            lines[2].contains(&format!(
                ",2,cpu flex,0,{},3,6,untrained,,,,,",
                Method::default()
            )),
            "{}",
            lines[2]
        );
        assert!(lines[3].contains("not built (no GPU backend in this build)"));
        let printed = table(&rows);
        assert!(printed.contains("untrained"));
        assert!(printed.contains("not built (no GPU backend in this build)"));
        // One trained point only: no line for the width knob.
        assert!(chart(&rows, "t").panels.iter().all(|p| p.series.is_empty()));
    }
}
