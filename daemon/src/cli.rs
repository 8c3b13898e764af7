//! Command-line arguments and dispatch.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use matscan_sim::render::SimOptions;
use matscan_sim::scene::geometry::{UserMesh, UvProjection};
use matscan_sim::scene::{GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::path::{Path, PathBuf};

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
    /// Run the main job on the simulated rig: start the daemon in this
    /// process, capture one scan, estimate its BSDF maps with the embedded
    /// networks, print per-parameter error and timings, draw a contact
    /// sheet.
    Demo(DemoArgs),
    /// Estimate a scan's BSDF parameter maps into SCAN/estimate (float EXR
    /// maps, 8-bit previews, result.toml with statuses, timings and, where
    /// the scan has truth, error metrics).
    Estimate(crate::estimate_cmd::EstimateArgs),
    /// Error against run time over a folder of simulated scans: MAD, MSE
    /// and PSNR per parameter for 1, 3 and all views, beside a trivial
    /// baseline and the thesis's figures.
    Eval(crate::eval_cmd::EvalArgs),
    /// Error against run time over the knobs that trade one for the other
    /// (views, resolution, network width, CPU/GPU backend, refinement
    /// iterations) on a cached simulated set: a table, and with --out
    /// bench.csv and bench.png.
    Bench(crate::bench_cmd::BenchArgs),
    /// Re-render the scanned object with its estimated material under
    /// novel lights (--light) or views (--orbit); for simulated scans also
    /// with the true material, printing PSNR and SSIM per image.
    Render(crate::render_cmd::RenderArgs),
    /// Bake a scan's estimate into UV textures (SCAN/estimate/texture) and
    /// write the mesh with that material as glTF 2.0 (material.gltf +
    /// material.bin, or --glb), plus principled.md for Blender.
    Export(crate::export_cmd::ExportArgs),
    /// Train one parameter network on simulated bundles (resumable after a
    /// kill: run the same command again); writes weights, checkpoints,
    /// loss.csv and loss.png.
    Train(crate::train_cmd::TrainArgs),
    /// Run the capture service (systemd Type=notify; see
    /// docs/daemon-protocol.md).
    Daemon(matscan::service::DaemonArgs),
    /// Ask the daemon for a capture. Exit codes: 0 done, 1 usage or
    /// protocol error, 3 daemon unreachable, 4 refused, 5 capture failed,
    /// 6 captured but the estimate failed.
    CaptureNow(matscan::client::CaptureNowArgs),
    /// Show the daemon's rig, queue and last scans (exit codes as
    /// capture-now).
    Status(matscan::client::StatusArgs),
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
    /// Folder for the demo's daemon socket and scans (created; each run
    /// adds a new numbered scan under OUT/scans).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Random seed of the scene and the renderer.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene kind: multimat, multimat-noenv, 2mat, 2mat-transmission, 3mat,
    /// sweep-subsurface, sweep-basecolor, sweep-roughness.
    #[arg(long, default_value = "2mat")]
    pub kind: String,
    /// Geometry: sphere, torus, superquadric, blob, leaves or random.
    #[arg(long, default_value = "random")]
    pub geometry: String,
    /// Photo width and height in pixels.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Number of scan-head positions (the simulated turntable turns
    /// between them).
    #[arg(long, default_value_t = 3)]
    pub positions: usize,
    /// Path-tracing samples per pixel of each photo.
    #[arg(long, default_value_t = 16)]
    pub samples: u32,
    /// Folder with `<param>.weights` per network (default: the weights
    /// built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
}

pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(a) => crate::demo::run(&a),
        Command::Estimate(a) => crate::estimate_cmd::run(&a),
        Command::Eval(a) => crate::eval_cmd::run(&a),
        Command::Bench(a) => crate::bench_cmd::run(&a),
        Command::Render(a) => crate::render_cmd::run(&a),
        Command::Export(a) => crate::export_cmd::run(&a),
        Command::Train(a) => crate::train_cmd::run(&a),
        Command::Daemon(a) => {
            matscan::service::run_daemon(&a).context("matscan daemon")?;
            Ok(())
        }
        Command::CaptureNow(a) => exit_with(matscan::client::capture_now(&a)),
        Command::Status(a) => exit_with(matscan::client::status(&a)),
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

/// Ends the process with a client's documented exit code.
fn exit_with(code: u8) -> Result<()> {
    if code == 0 {
        Ok(())
    } else {
        std::process::exit(i32::from(code))
    }
}
