//! `matscan simulate`: one bundle, or a whole dataset of them.
//!
//! A dataset is resumable because bundles are published atomically: a
//! folder that exists is complete, so a restarted run skips it and renders
//! only what is missing. Scenes render one after another, each using every
//! core (tile-parallel inside the renderer), which keeps peak memory at one
//! scene's worth.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, SceneOptions};
use std::path::Path;
use std::time::Instant;

/// Renders one scene into `out` and returns the seconds it took.
pub fn simulate_one(options: &SceneOptions, sim: &SimOptions, out: &Path) -> Result<f64> {
    let start = Instant::now();
    let scene = generate(options);
    write_scan_bundle(&scene, sim, out)
        .with_context(|| format!("writing simulated scan to {}", out.display()))?;
    Ok(start.elapsed().as_secs_f64())
}

/// Renders `count` scenes with seeds `first_seed..first_seed+count` into
/// `dataset/scene-<seed>`, skipping those already there.
pub fn simulate_dataset(
    base: &SceneOptions,
    sim: &SimOptions,
    dataset: &Path,
    first_seed: u64,
    count: u64,
) -> Result<()> {
    std::fs::create_dir_all(dataset)
        .with_context(|| format!("creating dataset folder {}", dataset.display()))?;
    let bar = ProgressBar::new(count);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} scenes, {elapsed} elapsed, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut skipped = 0u64;
    for seed in first_seed..first_seed + count {
        let out = dataset.join(format!("scene-{seed:06}"));
        if out.join("scan.toml").exists() {
            skipped += 1;
        } else {
            let mut options = base.clone();
            options.seed = seed;
            simulate_one(&options, sim, &out)?;
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    println!(
        "dataset {}: {} scenes rendered, {} already present",
        dataset.display(),
        count - skipped,
        skipped
    );
    Ok(())
}
