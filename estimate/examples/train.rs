//! Trains one network from the command line, without the `matscan` CLI:
//! `cargo run --release -p matscan-estimate --features train --example train --
//! --param metallic --data DIR --out DIR [--test DIR] [--steps N] [--width W]
//! [--crop PX] [--max-views N] [--max-minutes M] [--seed S]`.
//!
//! Progress goes to stderr as plain lines (this is what runs under `nohup`);
//! the `matscan train` command (`cli`, feature `train`) shows a progress bar.

use matscan_estimate::cpu_device;
use matscan_estimate::device::backend::training_device;
use matscan_estimate::train::{train, Event, TrainConfig};
use matscan_scan::Param;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |key: &str| {
        args.iter()
            .position(|a| a == key)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let need = |key: &str| get(key).ok_or_else(|| format!("{key} is required"));
    let kind = need("--param")?
        .parse::<Param>()
        .ok()
        .ok_or("unknown --param")?;
    let mut config = TrainConfig::new(
        kind,
        PathBuf::from(need("--data")?),
        PathBuf::from(need("--out")?),
    );
    config.test = get("--test").map(PathBuf::from);
    if let Some(v) = get("--steps") {
        config.steps = v.parse()?;
    }
    if let Some(v) = get("--width") {
        config.width = Some(v.parse()?);
    }
    if let Some(v) = get("--crop") {
        config.crop = v.parse()?;
    }
    if let Some(v) = get("--max-views") {
        config.max_views = v.parse()?;
    }
    if let Some(v) = get("--seed") {
        config.seed = v.parse()?;
    }
    if let Some(v) = get("--log-every") {
        config.log_every = v.parse()?;
    }
    if let Some(v) = get("--checkpoint-every") {
        config.checkpoint_every = v.parse()?;
    }
    if let Some(v) = get("--max-minutes") {
        config.max_seconds = Some(v.parse::<f64>()? * 60.0);
    }
    if let Some(v) = get("--max-scenes") {
        config.max_scenes = Some(v.parse()?);
    }
    let device = training_device(cpu_device());
    let start = Instant::now();
    let summary = train(&config, &device, &mut |event| {
        match event {
        Event::Loading { done, total } if done == total || done % 20 == 0 => {
            eprintln!("[{:.0}s] loaded {done}/{total}", start.elapsed().as_secs_f64())
        }
        Event::Skipped { path, reason } => eprintln!("skipped {}: {reason}", path.display()),
        Event::Start { step, steps, scenes, test_scenes } => eprintln!(
            "[{:.0}s] start at step {step}/{steps}: {scenes} training scenes, {test_scenes} test scenes",
            start.elapsed().as_secs_f64()
        ),
        Event::Logged(row) => eprintln!(
            "[{:.0}s] step {} {} views={} train={:.5} test={}",
            start.elapsed().as_secs_f64(),
            row.step,
            row.phase,
            row.views,
            row.train,
            row.test.map(|t| format!("{t:.5}")).unwrap_or_default()
        ),
        _ => {}
    }
    })?;
    eprintln!(
        "done: {} steps in {:.0} s, weights {}",
        summary.steps,
        summary.seconds,
        summary.weights.display()
    );
    Ok(())
}
