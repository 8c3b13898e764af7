//! `matscan simulate`: one simulated scan, a run of seeds, or a recipe's
//! whole set (see `matscan_sim::dataset`), with a progress bar.

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use matscan_sim::dataset::{render_scene, render_scenes, seed_run, PlannedScene, Recipe, Shard};
use matscan_sim::render::SimOptions;
use matscan_sim::scene::geometry::{UserMesh, UvProjection};
use matscan_sim::scene::{GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct SceneArgs {
    /// Random seed; the same seed gives the same scene and the same photos.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene kind: multimat, multimat-noenv, 2mat, 2mat-transmission, 3mat,
    /// realworld, sweep-subsurface, sweep-basecolor, sweep-roughness.
    #[arg(long, default_value = "2mat")]
    pub kind: String,
    /// Geometry: sphere, torus, superquadric, blob, leaves, vase, box, rock,
    /// figurine, random (one of the first five), or a path to a PLY or OBJ
    /// mesh.
    #[arg(long, default_value = "random")]
    pub geometry: String,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Number of scan-head positions.
    #[arg(long, default_value_t = 3)]
    pub positions: usize,
    /// Path-tracing samples per pixel (for the ambient image; the rig
    /// lights' contributions use the renderer's own default ratio).
    #[arg(long)]
    pub samples: Option<u32>,
}

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Folder of the bundle to write (must not exist); with --recipe, the
    /// folder of the set.
    #[arg(long, required_unless_present = "dataset", conflicts_with = "dataset")]
    pub out: Option<PathBuf>,
    /// Write a dataset of `--count` bundles into this folder instead
    /// (resumable: bundles already there are kept).
    #[arg(long, requires = "count")]
    pub dataset: Option<PathBuf>,
    /// Number of scenes in the dataset; seeds run from `--seed` upward.
    #[arg(long)]
    pub count: Option<u64>,
    /// Render the set a recipe file names (data/recipes/*.toml) into
    /// --out, as OUT/<kind>-<geometry>/scene-<seed> (resumable); the scene
    /// flags do not apply.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["dataset", "count"])]
    pub recipe: Option<PathBuf>,
    /// With --recipe: render only slice K of N (K from 0), for a batch
    /// scheduler's array job (docs/cluster.md).
    #[arg(long, value_name = "K/N", requires = "recipe")]
    pub shard: Option<Shard>,
    /// Also write, beside every bundle, the scene that made it as
    /// `<bundle>.scene/` (mesh, material maps, environment map, rig and
    /// captures in `scene.json`; docs/scene-description.md), for a second
    /// renderer (tools/mitsuba/). Scenes already rendered get theirs too.
    #[arg(long)]
    pub describe: bool,
    #[command(flatten)]
    pub scene: SceneArgs,
}

pub fn scene_options(a: &SceneArgs) -> Result<(SceneOptions, SimOptions)> {
    let kind: SceneKind = a
        .kind
        .parse()
        .map_err(|e| anyhow::anyhow!("--kind {}: {e}", a.kind))?;
    let geometry = match a.geometry.as_str() {
        "random" => GeometrySource::Random,
        name => match name.parse::<GeometryKind>() {
            Ok(k) => GeometrySource::Kind(k),
            Err(_) if Path::new(name).exists() => {
                let mesh = matscan_scan::mesh_io::read_mesh(Path::new(name))
                    .with_context(|| format!("--geometry {name}"))?;
                let mesh = UserMesh::new(mesh, UvProjection::default())
                    .with_context(|| format!("--geometry {name}"))?;
                GeometrySource::Mesh(mesh)
            }
            Err(e) => bail!("--geometry {name}: {e}, and no such mesh file exists"),
        },
    };
    if a.size < 8 {
        bail!("--size {}: expected at least 8 pixels", a.size);
    }
    if a.positions == 0 {
        bail!("--positions 0: expected at least one position");
    }
    let options = SceneOptions {
        seed: a.seed,
        kind,
        geometry,
        width: a.size,
        height: a.size,
        positions: a.positions,
        ..SceneOptions::default()
    };
    let mut sim = SimOptions {
        seed: a.seed,
        ..SimOptions::default()
    };
    if let Some(s) = a.samples {
        if s == 0 {
            bail!("--samples 0: expected at least one sample per pixel");
        }
        sim.samples = s;
    }
    Ok((options, sim))
}

/// A progress bar over a set's scenes.
fn render_with_bar(scenes: &[PlannedScene], dir: &Path, describe: bool) -> Result<()> {
    let bar = ProgressBar::new(scenes.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} scenes, {elapsed} elapsed, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let summary = render_scenes(scenes, dir, describe, &mut |done, _| {
        bar.set_position(done as u64)
    })?;
    bar.finish_and_clear();
    println!(
        "dataset {}: {} scenes rendered, {} already present",
        dir.display(),
        summary.rendered,
        summary.present
    );
    Ok(())
}

/// Runs `matscan simulate`.
pub fn run(a: SimulateArgs) -> Result<()> {
    if let Some(recipe_path) = &a.recipe {
        let Some(out) = &a.out else {
            bail!(
                "--recipe {}: give --out DIR for the set",
                recipe_path.display()
            );
        };
        let recipe = Recipe::read(recipe_path)?;
        let scenes = recipe
            .shard(a.shard)
            .map_err(|e| anyhow::anyhow!("{}: {e}", recipe_path.display()))?;
        return render_with_bar(&scenes, out, a.describe);
    }
    let (options, sim) = scene_options(&a.scene)?;
    match (a.out, a.dataset, a.count) {
        (Some(out), _, _) => {
            let secs = render_scene(&options, &sim, &out, a.describe)?;
            println!("{}  ({secs:.1} s)", out.display());
            Ok(())
        }
        (None, Some(dataset), Some(count)) => render_with_bar(
            &seed_run(&options, &sim, a.scene.seed, count),
            &dataset,
            a.describe,
        ),
        _ => bail!("give --out DIR, --dataset DIR with --count N, or --recipe FILE with --out DIR"),
    }
}
