//! `matscan train`: trains one parameter network on a folder of simulated
//! bundles (`matscan simulate --dataset`), with a progress bar.
//!
//! All the work is `matscan_estimate::train`, built in with this binary's
//! feature `train` (`cargo build --release -p matscan --features train`;
//! without it the command says so): this command parses arguments, picks the device and
//! draws progress and the loss plot (`loss.png`, redrawn from `loss.csv`
//! after every logged row by `matscan_evaluate::plot::loss`). Training resumes from `<out>/latest` when a checkpoint
//! exists, so a killed run is continued by running the same command again.
//! Output: `<out>/<param>.weights` (load with `--weights <out>` or copy into
//! `estimate/weights/` to embed), `loss.csv`, `loss.png`, `checkpoint-*/`.
//!
//! Out of scope: data generation (`simulate`), evaluation (`estimate`).

use anyhow::Result;
use matscan_estimate::Backend;
use std::path::PathBuf;

/// Arguments of `matscan train`.
#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    /// The network: roughness, transmission, subsurface, metallic, basecolor.
    #[arg(long)]
    pub param: String,
    /// Folder of training bundles (searched two levels deep).
    #[arg(long)]
    pub data: PathBuf,
    /// Output folder: weights, checkpoints, loss.csv, loss.png.
    #[arg(long)]
    pub out: PathBuf,
    /// Total training steps (one scene each).
    #[arg(long, default_value_t = 2000)]
    pub steps: usize,
    /// Feature width (default: the shipped width of the network).
    #[arg(long)]
    pub width: Option<usize>,
    /// Where to train: cpu (the build's default CPU backend), flex,
    /// ndarray or gpu (Vulkan; needs a build with `--features vulkan`).
    #[arg(long, default_value = "cpu")]
    pub backend: Backend,
    /// Folder of test bundles for the test loss.
    #[arg(long)]
    pub test: Option<PathBuf>,
    /// Crop side in pixels.
    #[arg(long, default_value_t = 64)]
    pub crop: usize,
    /// Most views per step.
    #[arg(long, default_value_t = 3)]
    pub max_views: usize,
    /// Seed of the initial weights and of the sampling.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Checkpoint every this many steps.
    #[arg(long, default_value_t = 100)]
    pub checkpoint_every: usize,
    /// Log (and evaluate the test loss) every this many steps.
    #[arg(long, default_value_t = 50)]
    pub log_every: usize,
    /// Stop after this many minutes of training (weights are still written).
    #[arg(long)]
    pub max_minutes: Option<f64>,
    /// Start a fresh run from these weights instead of random ones: a
    /// weight file, or `embedded` for the network built into this binary
    /// (fine-tuning). Ignored when resuming from a checkpoint in --out.
    #[arg(long)]
    pub init: Option<String>,
    /// Adam's learning rate [default: the thesis's 1e-3].
    #[arg(long)]
    pub lr: Option<f64>,
    /// Decay the learning rate by a cosine from --lr to this at the last
    /// step (default: constant, as the thesis).
    #[arg(long)]
    pub final_lr: Option<f64>,
    /// Steps of the stems-only phase (default 5 % of --steps).
    #[arg(long)]
    pub stems_steps: Option<usize>,
    /// Steps of the single-view phase (default 20 % of --steps).
    #[arg(long)]
    pub single_steps: Option<usize>,
}

/// Runs `matscan train`.
/// Runs `matscan train`.
pub fn run(args: &TrainArgs) -> Result<()> {
    #[cfg(feature = "train")]
    {
        imp::train_network(args)
    }
    #[cfg(not(feature = "train"))]
    {
        let _ = args;
        anyhow::bail!(
            "this build has no training (burn's autodiff and optimizers); rebuild with \
             `cargo build --release -p matscan --features train`"
        )
    }
}

#[cfg(feature = "train")]
mod imp {
    use crate::cmd::train::TrainArgs;
    use anyhow::{bail, Context, Result};
    use indicatif::{ProgressBar, ProgressStyle};
    use matscan_estimate::device::backend::training_device;
    use matscan_estimate::net::weights::WeightSource;
    use matscan_estimate::train::history::read_rows;
    use matscan_estimate::train::{train, Event, TrainConfig};
    use matscan_evaluate::plot::loss::{write_loss_png, LossPoint};
    use matscan_scan::Param;
    use std::path::Path;
    use std::path::PathBuf;

    pub fn train_network(args: &TrainArgs) -> Result<()> {
        let Some(kind) = args.param.parse::<Param>().ok() else {
            bail!(
                "--param {}: expected one of roughness, transmission, subsurface, metallic, basecolor",
                args.param
            );
        };
        let (device, adapter) = args
            .backend
            .device()
            .with_context(|| format!("--backend {}", args.backend.label()))?;
        if let Some(adapter) = adapter {
            tracing::info!("training on the GPU: {adapter}");
        }
        let device = training_device(device);
        let mut config = TrainConfig::new(kind, args.data.clone(), args.out.clone());
        config.test = args.test.clone();
        config.steps = args.steps;
        config.width = args.width;
        config.crop = args.crop;
        config.max_views = args.max_views;
        config.seed = args.seed;
        config.checkpoint_every = args.checkpoint_every;
        config.log_every = args.log_every;
        config.max_seconds = args.max_minutes.map(|m| m * 60.0);
        if let Some(lr) = args.lr {
            config.learning_rate = lr;
        }
        config.final_learning_rate = args.final_lr;
        config.stems_steps = args.stems_steps;
        config.single_steps = args.single_steps;
        config.init = args.init.as_deref().map(|init| match init {
            "embedded" => WeightSource::Embedded,
            path => WeightSource::File(PathBuf::from(path)),
        });
        for (name, rate) in [("--lr", args.lr), ("--final-lr", args.final_lr)] {
            if let Some(rate) = rate {
                if !(rate.is_finite() && rate > 0.0) {
                    bail!("{name} {rate}: expected a positive learning rate");
                }
            }
        }

        let bar = ProgressBar::new(0);
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>9} [{elapsed_precise}] {bar:40} {pos}/{len} ({eta}) {msg}",
            )
            .context("progress bar template")?,
        );
        bar.set_prefix("loading");
        // indicatif drops `println` when the bar is hidden (stderr not a
        // terminal: nohup, a service, a pipe); the log lines still matter there.
        let say = |bar: &ProgressBar, line: String| {
            if bar.is_hidden() {
                eprintln!("{line}");
            } else {
                bar.println(line);
            }
        };
        let summary = train(&config, &device, &mut |event| match event {
            Event::Loading { done, total } => {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            }
            Event::Skipped { path, reason } => {
                say(&bar, format!("skipped {}: {reason}", path.display()));
            }
            Event::Start {
                step,
                steps,
                scenes,
                test_scenes,
            } => {
                bar.set_prefix(kind.name());
                bar.set_length(steps as u64);
                bar.set_position(step as u64);
                say(
                    &bar,
                    format!(
                    "training {kind} from step {step}: {scenes} training scenes, {test_scenes} test scenes"
                ));
            }
            Event::Step { step, loss, phase } => {
                bar.set_position(step as u64);
                bar.set_message(format!("{} loss {loss:.4}", phase.name()));
            }
            Event::Logged(row) => {
                let test = row.test.map(|t| format!(", test {t:.5}")).unwrap_or_default();
                say(&bar, format!("step {}: train {:.5}{test}", row.step, row.train));
                // The plot is a view of loss.csv: failing to draw it costs
                // the picture, never the training.
                if let Err(e) = draw_loss(kind, &args.out) {
                    say(&bar, format!("loss plot: {e:#}"));
                }
            }
            Event::Checkpoint(_) => {}
        })
        .with_context(|| format!("training the {kind} network"))?;
        bar.finish_and_clear();
        println!(
            "{kind}: {} steps in {:.0} s; weights {}; loss history {}",
            summary.steps,
            summary.seconds,
            summary.weights.display(),
            args.out.join("loss.csv").display()
        );
        Ok(())
    }

    /// Redraws `<out>/loss.png` from `<out>/loss.csv`, the whole history.
    fn draw_loss(kind: Param, out: &Path) -> Result<()> {
        let csv = out.join("loss.csv");
        let history: Vec<LossPoint> = read_rows(&csv)
            .with_context(|| format!("reading {}", csv.display()))?
            .iter()
            .map(|r| LossPoint {
                step: r.step,
                train: r.train,
                test: r.test,
            })
            .collect();
        write_loss_png(kind.name(), &history, &out.join("loss.png"))
    }
}
