//! Training of one parameter network on simulated scan bundles (thesis
//! section 3.2.2 and the losses of 3.2.3.1 to 3.2.3.5), on the CPU.
//!
//! The loop: Adam at a learning rate of 1e-3 (the thesis's; optionally
//! decayed by a cosine to `final_learning_rate`, which settles the noisy
//! batch-of-one steps of a short CPU run), batch size 1 (one scene per
//! step), from random weights or from a weight file (`init`, to continue
//! a shipped network on new data), every network conditioned on the **true**
//! dependency maps (see `crate::pipeline::truth_fed`). The thesis's schedule, scaled to a CPU
//! budget of a few thousand steps instead of 150 epochs:
//!
//! 1. **stems**: the first `stems_steps` steps (default 5 % of the run; the
//!    thesis's first 100 batches) train on crops mean-pooled to at most
//!    16x16, where the network runs only its input and output stems;
//! 2. **single**: up to `single_steps` more (default 20 %; the thesis's
//!    first 2000 batches) use one random view at full resolution;
//! 3. then alternately **all** views and a random **pair** of views, the
//!    full pyramid. "All" is capped at `max_views` views drawn at random
//!    (default 3), since a 9-view step costs nine times one view on CPU.
//!
//! Samples are random crops (`crop`, default 64) of the scene in the
//! reference camera image, with the thesis's augmentations: inputs centred
//! to [-1, 1] (done by `inputs`) and a random removal of input pixels
//! (`dropout_permille`, default 2 %).
//!
//! Every random choice of step `s` comes from a generator seeded by
//! `(seed, s)`, so a run resumed from a checkpoint draws the same samples
//! as one never interrupted; checkpoints also hold the Adam state (see
//! `checkpoint`). Losses go to `loss.csv` (see `history`; the caller draws
//! it), the
//! final network to `<out>/<param>.weights` in the `weights` format.
//!
//! Out of scope: progress display (the caller's, through [`Event`]), data
//! generation (the simulator).

pub mod checkpoint;
pub mod data;
pub mod error;
pub mod history;
pub mod loss;

use crate::net::network::{ConfigError, NetConfig, ParamNet};
use crate::net::weights::{self, WeightSource};
use crate::pipeline::truth_fed::{self, SceneData, SceneError};
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::Device;
use data::Cut;
pub use error::TrainError;
use loss::Batch;
use matscan_scan::Param;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The thesis's learning rate.
pub const LEARNING_RATE: f64 = 1.0e-3;

/// What to train and how.
#[derive(Clone, Debug)]
pub struct TrainConfig {
    /// The network.
    pub kind: Param,
    /// Folder of training bundles.
    pub data: PathBuf,
    /// Folder of test bundles (the test loss); none when `None`.
    pub test: Option<PathBuf>,
    /// Output folder: weights, checkpoints, loss.csv.
    pub out: PathBuf,
    /// Total steps (one scene each).
    pub steps: usize,
    /// Feature width; the shipped width ([`NetConfig::shipped`]) when `None`.
    pub width: Option<usize>,
    /// Crop side in pixels.
    pub crop: usize,
    /// Most views per step.
    pub max_views: usize,
    /// Adam's learning rate.
    pub learning_rate: f64,
    /// Seed of the initial weights and of every sampling choice.
    pub seed: u64,
    /// Checkpoint every this many steps (0: only at the end).
    pub checkpoint_every: usize,
    /// Log (and evaluate the test loss) every this many steps.
    pub log_every: usize,
    /// Test scenes evaluated per log (the first ones, all views up to
    /// `max_views`, whole image, no dropout).
    pub test_scenes: usize,
    /// Input pixels dropped, in thousandths.
    pub dropout_permille: u32,
    /// Steps of the stems-only phase; 5 % of `steps` when `None`.
    pub stems_steps: Option<usize>,
    /// Steps of the single-view phase; 20 % of `steps` when `None`.
    pub single_steps: Option<usize>,
    /// Stop (checkpoint and write the weights) after this many training
    /// seconds, counting earlier runs of a resumed training.
    pub max_seconds: Option<f64>,
    /// Use at most this many training scenes.
    pub max_scenes: Option<usize>,
    /// The starting weights of a fresh run (fine-tuning); random weights
    /// seeded by `seed` when `None`. A resumed run ignores it: the
    /// checkpoint is newer.
    pub init: Option<WeightSource>,
    /// Where the learning rate ends: cosine decay from `learning_rate` at
    /// step 0 to this at the last step; constant (the thesis's) when `None`.
    pub final_learning_rate: Option<f64>,
}

impl TrainConfig {
    /// Defaults for `kind`: 2000 steps, 64-pixel crops, up to 3 views.
    pub fn new(kind: Param, data: PathBuf, out: PathBuf) -> Self {
        TrainConfig {
            kind,
            data,
            test: None,
            out,
            steps: 2000,
            width: None,
            crop: 64,
            max_views: 3,
            learning_rate: LEARNING_RATE,
            seed: 1,
            checkpoint_every: 100,
            log_every: 50,
            test_scenes: 8,
            dropout_permille: 20,
            stems_steps: None,
            single_steps: None,
            max_seconds: None,
            max_scenes: None,
            init: None,
            final_learning_rate: None,
        }
    }

    /// The learning rate of step `step` (0-based). A function of the step
    /// alone, so a resumed run continues the same schedule.
    pub fn learning_rate_at(&self, step: usize) -> f64 {
        match self.final_learning_rate {
            None => self.learning_rate,
            Some(end) => {
                let t = (step as f64 / self.steps.max(1) as f64).clamp(0.0, 1.0);
                end + (self.learning_rate - end) * 0.5 * (1.0 + (std::f64::consts::PI * t).cos())
            }
        }
    }

    /// The network's configuration.
    pub fn net_config(&self) -> Result<NetConfig, ConfigError> {
        match self.width {
            Some(w) => NetConfig::new(self.kind, w),
            None => Ok(NetConfig::shipped(self.kind)),
        }
    }

    fn stems(&self) -> usize {
        self.stems_steps.unwrap_or(self.steps / 20)
    }

    fn single(&self) -> usize {
        self.single_steps.unwrap_or(self.steps / 5)
    }

    /// The schedule phase of step `step` (0-based).
    pub fn phase(&self, step: usize) -> Phase {
        if step < self.stems() {
            Phase::Stems
        } else if step < self.stems() + self.single() {
            Phase::Single
        } else if (step - self.stems() - self.single()).is_multiple_of(2) {
            Phase::All
        } else {
            Phase::Pair
        }
    }
}

/// A step's strategy (section 3.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Input and output stems only (crops pooled to 16x16 or less).
    Stems,
    /// One view, full resolution.
    Single,
    /// All views (up to the cap), full pyramid.
    All,
    /// A random pair of views, full pyramid.
    Pair,
}

impl Phase {
    /// Lower-case name, as in `loss.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Stems => "stems",
            Phase::Single => "single",
            Phase::All => "all",
            Phase::Pair => "pair",
        }
    }
}

/// What the loop reports to its caller.
#[derive(Clone, Debug)]
pub enum Event {
    /// Scenes read so far.
    Loading {
        /// Read.
        done: usize,
        /// To read.
        total: usize,
    },
    /// A bundle was left out (it cannot be read, calibrated or lacks truth).
    Skipped {
        /// The bundle.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// Training begins (or resumes) at `step` of `steps`.
    Start {
        /// Steps already done.
        step: usize,
        /// Total.
        steps: usize,
        /// Training scenes.
        scenes: usize,
        /// Test scenes.
        test_scenes: usize,
    },
    /// A step finished.
    Step {
        /// Steps done.
        step: usize,
        /// Its loss.
        loss: f64,
        /// Its phase.
        phase: Phase,
    },
    /// A log row was written.
    Logged(history::Row),
    /// A checkpoint was written.
    Checkpoint(PathBuf),
}

/// What a finished run produced.
#[derive(Clone, Debug)]
pub struct TrainSummary {
    /// Steps done in total.
    pub steps: usize,
    /// The weight file.
    pub weights: PathBuf,
    /// The last logged training loss.
    pub train_loss: Option<f64>,
    /// The last test loss.
    pub test_loss: Option<f64>,
    /// Training seconds, all runs of a resumed training together.
    pub seconds: f64,
}

/// Reads every bundle under `dir` for `kind`, two at a time; bundles
/// without a usable view for `kind`, and bundles that fail to load
/// (reported as [`Event::Skipped`]), are left out.
pub fn load_scenes(
    dir: &Path,
    kind: Param,
    limit: Option<usize>,
    progress: &mut dyn FnMut(Event),
) -> Result<Vec<SceneData>, TrainError> {
    let mut paths = matscan_scan::bundle::find_bundles(dir)?;
    if let Some(limit) = limit {
        paths.truncate(limit);
    }
    let total = paths.len();
    let mut scenes = Vec::with_capacity(total);
    for (i, chunk) in paths.chunks(2).enumerate() {
        let loaded: Vec<Result<Option<SceneData>, SceneError>> = std::thread::scope(|scope| {
            let handles: Vec<_> = chunk
                .iter()
                .map(|p| scope.spawn(move || truth_fed::load_scene(p, kind)))
                .collect();
            handles
                .into_iter()
                .map(|h| match h.join() {
                    Ok(r) => r,
                    Err(panic) => std::panic::resume_unwind(panic),
                })
                .collect()
        });
        for (scene, path) in loaded.into_iter().zip(chunk) {
            match scene {
                Ok(Some(scene)) => scenes.push(scene),
                Ok(None) => {}
                // A scene the pipeline itself would refuse (no usable
                // position, bad light) teaches nothing: skip it, say so.
                Err(e) => progress(Event::Skipped {
                    path: path.clone(),
                    reason: e.to_string(),
                }),
            }
        }
        progress(Event::Loading {
            done: ((i + 1) * 2).min(total),
            total,
        });
    }
    if scenes.is_empty() {
        return Err(TrainError::NoScenes {
            dir: dir.to_path_buf(),
            kind,
        });
    }
    Ok(scenes)
}

fn step_rng(seed: u64, step: usize) -> Pcg64 {
    Pcg64::seed_from_u64(seed ^ (step as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// The views of one step: indices into the scene's views.
fn choose_views(phase: Phase, available: usize, max_views: usize, rng: &mut Pcg64) -> Vec<usize> {
    let mut all: Vec<usize> = (0..available).collect();
    all.shuffle(rng);
    let take = match phase {
        Phase::Stems | Phase::Single => 1,
        Phase::Pair => 2,
        Phase::All => max_views.max(1),
    };
    all.truncate(take.min(available));
    all
}

/// The loss of `net` on `scene` (no gradient is used).
pub fn evaluate(
    net: &ParamNet,
    scene: &SceneData,
    max_views: usize,
    device: &Device,
) -> Result<f64, TrainError> {
    // Evenly spread views, deterministic.
    let n = scene.views.len();
    let take = max_views.clamp(1, n);
    let views: Vec<usize> = (0..take).map(|i| i * n / take).collect();
    let cut = Cut {
        crop: scene.width.max(scene.height),
        pool_to: None,
        dropout_permille: 0,
    };
    let sample = scene.sample(&views, cut, &mut Pcg64::seed_from_u64(0));
    let batch = Batch::new(net.config().kind(), sample, device);
    let out = net.forward(&batch.views)?;
    Ok(f64::from(batch.loss(&out).into_scalar::<f32>()))
}

/// Trains `config.kind`'s network, resuming from `<out>/latest` when a
/// checkpoint exists.
pub fn train(
    config: &TrainConfig,
    device: &Device,
    progress: &mut dyn FnMut(Event),
) -> Result<TrainSummary, TrainError> {
    let net_config = config.net_config()?;
    std::fs::create_dir_all(&config.out).map_err(|source| TrainError::Io {
        path: config.out.clone(),
        source,
    })?;
    let scenes = load_scenes(&config.data, config.kind, config.max_scenes, progress)?;
    let tests = match &config.test {
        Some(dir) if config.test_scenes > 0 => {
            load_scenes(dir, config.kind, Some(config.test_scenes), progress)?
        }
        _ => Vec::new(),
    };
    let csv = config.out.join("loss.csv");

    let mut optimizer = AdamConfig::new().init();
    let (mut net, mut step, past_seconds) = match checkpoint::load(&config.out, net_config, device)?
    {
        Some(restored) => {
            optimizer = optimizer.load_record(restored.optimizer);
            history::truncate(&csv, restored.step)?;
            (restored.net, restored.step, restored.seconds)
        }
        None => {
            device.seed(config.seed);
            // A fresh run starts a fresh history.
            if csv.exists() {
                history::truncate(&csv, 0)?;
            }
            let net = match &config.init {
                None => ParamNet::new(net_config, device),
                Some(source) => weights::load(source, net_config, device)?,
            };
            (net, 0, 0.0)
        }
    };
    progress(Event::Start {
        step,
        steps: config.steps,
        scenes: scenes.len(),
        test_scenes: tests.len(),
    });

    let start = Instant::now();
    let seconds = |start: &Instant| past_seconds + start.elapsed().as_secs_f64();
    let mut log = LossLog {
        config,
        tests: &tests,
        device,
        csv: &csv,
        start,
        past_seconds,
        interval: (0.0, 0),
        last_train: None,
        last_test: None,
    };
    let mut non_finite = 0usize;
    let mut last_phase = config.phase(step);
    let mut last_views = 0usize;
    while step < config.steps {
        if config
            .max_seconds
            .is_some_and(|limit| seconds(&start) >= limit)
        {
            break;
        }
        let phase = config.phase(step);
        let mut rng = step_rng(config.seed, step);
        let scene = &scenes[rng.gen_range(0..scenes.len())];
        let views = choose_views(phase, scene.views.len(), config.max_views, &mut rng);
        let cut = Cut {
            crop: config.crop,
            pool_to: (phase == Phase::Stems).then_some(crate::net::pyramid::COARSEST_MAX),
            dropout_permille: config.dropout_permille,
        };
        let sample = scene.sample(&views, cut, &mut rng);
        let batch = Batch::new(config.kind, sample, device);
        let out = net.forward(&batch.views)?;
        let loss = batch.loss(&out);
        let value = f64::from(loss.clone().into_scalar::<f32>());
        step += 1;
        if value.is_finite() {
            non_finite = 0;
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = optimizer.step(config.learning_rate_at(step - 1), net, grads);
            log.interval.0 += value;
            log.interval.1 += 1;
        } else {
            non_finite += 1;
            if non_finite >= 20 {
                return Err(TrainError::Diverged(non_finite));
            }
        }
        last_phase = phase;
        last_views = views.len();
        progress(Event::Step {
            step,
            loss: value,
            phase,
        });
        let log_now = config.log_every > 0 && step % config.log_every == 0;
        if log_now || step == config.steps {
            log.row(&net, step, phase, last_views, progress)?;
        }
        if config.checkpoint_every > 0 && step % config.checkpoint_every == 0 {
            let dir = checkpoint::save(
                &config.out,
                &net,
                optimizer.to_record(),
                step,
                seconds(&start),
            )?;
            progress(Event::Checkpoint(dir));
        }
    }
    // What the steps since the last row (a time limit's break) add.
    log.row(&net, step, last_phase, last_views, progress)?;
    let dir = checkpoint::save(
        &config.out,
        &net,
        optimizer.to_record(),
        step,
        seconds(&start),
    )?;
    progress(Event::Checkpoint(dir));
    let weights_path = config
        .out
        .join(crate::net::models::weights_file_name(config.kind));
    weights::save_file(&net, &weights_path)?;
    Ok(TrainSummary {
        steps: step,
        weights: weights_path,
        train_loss: log.last_train,
        test_loss: log.last_test,
        seconds: seconds(&start),
    })
}

/// `loss.csv` of a run, and the losses since the last row.
struct LossLog<'a> {
    config: &'a TrainConfig,
    tests: &'a [SceneData],
    device: &'a Device,
    csv: &'a Path,
    start: Instant,
    past_seconds: f64,
    /// Sum and count of the training losses since the last row.
    interval: (f64, usize),
    last_train: Option<f64>,
    last_test: Option<f64>,
}

impl LossLog<'_> {
    /// Writes one row of `loss.csv` (evaluating the test scenes) and
    /// reports it as [`Event::Logged`]; nothing when no step ran since the
    /// last row.
    fn row(
        &mut self,
        net: &ParamNet,
        step: usize,
        phase: Phase,
        views: usize,
        progress: &mut dyn FnMut(Event),
    ) -> Result<(), TrainError> {
        if self.interval.1 == 0 {
            return Ok(());
        }
        let train = self.interval.0 / self.interval.1 as f64;
        self.interval = (0.0, 0);
        let test = if self.tests.is_empty() {
            None
        } else {
            // No backward pass: the graph built here is dropped unused.
            let mut sum = 0.0;
            for scene in self.tests {
                sum += evaluate(net, scene, self.config.max_views, self.device)?;
            }
            Some(sum / self.tests.len() as f64)
        };
        let row = history::Row {
            step,
            phase: phase.name().to_string(),
            views,
            train,
            test,
            seconds: self.past_seconds + self.start.elapsed().as_secs_f64(),
        };
        history::append(self.csv, &row)?;
        self.last_train = Some(train);
        if test.is_some() {
            self.last_test = test;
        }
        progress(Event::Logged(row));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_runs_stems_then_single_then_alternates() {
        let config = TrainConfig::new(Param::Metallic, "d".into(), "o".into());
        // 2000 steps: 100 stems, 400 single.
        assert_eq!(config.phase(0), Phase::Stems);
        assert_eq!(config.phase(99), Phase::Stems);
        assert_eq!(config.phase(100), Phase::Single);
        assert_eq!(config.phase(499), Phase::Single);
        assert_eq!(config.phase(500), Phase::All);
        assert_eq!(config.phase(501), Phase::Pair);
    }

    #[test]
    fn the_learning_rate_is_constant_or_falls_by_cosine_to_its_end() {
        let mut config = TrainConfig::new(Param::Metallic, "d".into(), "o".into());
        config.steps = 100;
        assert_eq!(config.learning_rate_at(0), LEARNING_RATE);
        assert_eq!(config.learning_rate_at(99), LEARNING_RATE);
        config.final_learning_rate = Some(1.0e-5);
        assert!((config.learning_rate_at(0) - 1.0e-3).abs() < 1e-12);
        assert!((config.learning_rate_at(50) - (1.0e-5 + 0.5 * (1.0e-3 - 1.0e-5))).abs() < 1e-12);
        assert!((config.learning_rate_at(100) - 1.0e-5).abs() < 1e-12);
        // Past the planned steps (a run extended by hand) it stays at the end.
        assert!((config.learning_rate_at(500) - 1.0e-5).abs() < 1e-12);
        let rates: Vec<f64> = (0..=100).map(|s| config.learning_rate_at(s)).collect();
        assert!(rates.windows(2).all(|w| w[1] <= w[0]));
    }

    #[test]
    fn views_are_capped_and_distinct() {
        let mut rng = step_rng(1, 3);
        let v = choose_views(Phase::All, 9, 3, &mut rng);
        assert_eq!(v.len(), 3);
        let unique: std::collections::HashSet<_> = v.iter().collect();
        assert_eq!(unique.len(), 3);
        assert_eq!(choose_views(Phase::Pair, 1, 3, &mut rng).len(), 1);
    }
}
