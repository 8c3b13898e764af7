//! Command-line arguments and dispatch.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use matscan_sim::render::SimOptions;
use matscan_sim::scene::geometry::{UserMesh, UvProjection};
use matscan_sim::scene::{GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Parser)]
#[command(
    name = "matscan",
    version,
    about = "Capture-and-estimate daemon and tools for 3D-scanner rigs: Principled BSDF maps from photos under known light and geometry.",
    long_about = None
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the main job on the simulated rig: simulate a capture, then draw
    /// its contact sheet; prints timings.
    Demo(DemoArgs),
    /// Render a simulated scan bundle (or a dataset of them) with the
    /// built-in path tracer.
    Simulate(SimulateArgs),
    /// Write a bundle's calibration maps (float EXR, one folder per
    /// position), or `calib check SCAN` to check its calibration.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Calib(CalibArgs),
    /// Draw a contact sheet of a scan bundle: captures, mask, truth and
    /// estimates where present.
    Sheet(SheetArgs),
}

#[derive(Debug, Args)]
pub struct SceneArgs {
    /// Random seed; the same seed gives the same scene and the same photos.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene kind: multimat, multimat-noenv, 2mat, 2mat-transmission, 3mat,
    /// sweep-subsurface, sweep-basecolor, sweep-roughness.
    #[arg(long, default_value = "2mat")]
    pub kind: String,
    /// Geometry: sphere, torus, superquadric, blob, leaves, random, or a
    /// path to a PLY or OBJ mesh.
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
    /// Folder of the bundle to write (must not exist).
    #[arg(long, required_unless_present = "dataset", conflicts_with = "dataset")]
    pub out: Option<PathBuf>,
    /// Write a dataset of `--count` bundles into this folder instead
    /// (resumable: bundles already there are kept).
    #[arg(long, requires = "count")]
    pub dataset: Option<PathBuf>,
    /// Number of scenes in the dataset; seeds run from `--seed` upward.
    #[arg(long)]
    pub count: Option<u64>,
    #[command(flatten)]
    pub scene: SceneArgs,
}

#[derive(Debug, Args)]
pub struct CalibArgs {
    #[command(subcommand)]
    pub action: Option<CalibAction>,
    /// The scan bundle folder.
    #[arg(required = true)]
    pub scan: Option<PathBuf>,
    /// Output folder (default: SCAN/calib).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum CalibAction {
    /// Validate the calibration against the photos: silhouette IoU of the
    /// projected mesh against the object in the photos, light positions
    /// against the shading, and a verdict per position. Exits 2 when a
    /// check fails.
    Check {
        /// The scan bundle folder.
        scan: PathBuf,
        /// Print one JSON object with the per-position figures.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Debug, Args)]
pub struct SheetArgs {
    /// The scan bundle folder.
    pub scan: PathBuf,
    /// Output PNG (default: SCAN/sheet.png).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for the demo's scans (created; a new numbered scan each run).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    #[command(flatten)]
    pub scene: SceneArgs,
}

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(a) => demo(a),
        Command::Simulate(a) => simulate(a),
        Command::Calib(a) => match (a.action, a.scan) {
            (Some(CalibAction::Check { scan, json }), _) => {
                if crate::calib_cmd::run_check(&scan, json)? {
                    Ok(())
                } else {
                    std::process::exit(2)
                }
            }
            (None, Some(scan)) => {
                let out = a.out.unwrap_or_else(|| scan.join("calib"));
                crate::calib_cmd::write(&scan, &out)
            }
            (None, None) => bail!("give a scan folder: matscan calib SCAN"),
        },
        Command::Sheet(a) => {
            let out = a.out.unwrap_or_else(|| a.scan.join("sheet.png"));
            crate::sheet::draw_contact_sheet(&a.scan, &out)?;
            println!("{}", out.display());
            Ok(())
        }
    }
}

fn scene_options(a: &SceneArgs) -> Result<(SceneOptions, SimOptions)> {
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

fn simulate(a: SimulateArgs) -> Result<()> {
    let (options, sim) = scene_options(&a.scene)?;
    match (a.out, a.dataset, a.count) {
        (Some(out), _, _) => {
            let secs = crate::simulate::simulate_one(&options, &sim, &out)?;
            println!("{}  ({secs:.1} s)", out.display());
            Ok(())
        }
        (None, Some(dataset), Some(count)) => {
            crate::simulate::simulate_dataset(&options, &sim, &dataset, a.scene.seed, count)
        }
        _ => bail!("give --out DIR, or --dataset DIR with --count N"),
    }
}

/// A fresh, numbered scan folder under `root`, so a demo never overwrites an
/// earlier scan.
fn next_scan_folder(root: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(root).with_context(|| format!("creating {}", root.display()))?;
    for i in 1..100_000u32 {
        let p = root.join(format!("scan-{i:04}"));
        if !p.exists() {
            return Ok(p);
        }
    }
    bail!("{}: no free scan-NNNN name left", root.display())
}

fn demo(a: DemoArgs) -> Result<()> {
    let (options, sim) = scene_options(&a.scene)?;
    let scan = next_scan_folder(&a.out)?;
    println!(
        "simulated rig: {} scene, {} positions, {}x{} px, seed {}",
        a.scene.kind, a.scene.positions, a.scene.size, a.scene.size, a.scene.seed
    );
    let t = Instant::now();
    let secs = crate::simulate::simulate_one(&options, &sim, &scan)?;
    println!("capture (render)   {secs:8.2} s  -> {}", scan.display());
    let t_sheet = Instant::now();
    let sheet = scan.join("sheet.png");
    crate::sheet::draw_contact_sheet(&scan, &sheet)?;
    println!(
        "contact sheet      {:8.2} s  -> {}",
        t_sheet.elapsed().as_secs_f64(),
        sheet.display()
    );
    println!("total              {:8.2} s", t.elapsed().as_secs_f64());
    Ok(())
}
