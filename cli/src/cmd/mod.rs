//! The command line: one module per command, each with its own flags and a
//! thin dispatch into the libraries. No command module uses another.

pub mod bench;
pub mod calib;
pub mod capture_now;
pub mod daemon;
pub mod demo;
pub mod estimate;
pub mod eval;
pub mod export;
pub mod render;
pub mod rig_calib;
pub mod sheet;
pub mod simulate;
pub mod status;
pub mod train;

use anyhow::Result;
use clap::{Parser, Subcommand};

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
    /// process, capture one scan of an object framed as an operator would,
    /// estimate its BSDF maps with the default method (the physical fit
    /// and the embedded networks), print per parameter who answered, its
    /// error and its time, and draw a contact sheet.
    Demo(demo::DemoArgs),
    /// Estimate a scan's BSDF parameter maps into SCAN/estimate (float EXR
    /// maps, 8-bit previews, result.toml with statuses, timings and, where
    /// the scan has truth, error metrics).
    Estimate(estimate::EstimateArgs),
    /// Error against run time over a folder of simulated scans: MAD, MSE
    /// and PSNR per parameter for 1, 3 and all views, beside a trivial
    /// baseline and the thesis's figures.
    Eval(eval::EvalArgs),
    /// Error against run time over the knobs that trade one for the other
    /// (views, resolution, network width, CPU/GPU backend, refinement
    /// iterations) on a cached simulated set: a table, and with --out
    /// bench.csv and bench.png.
    Bench(bench::BenchArgs),
    /// Re-render the scanned object with its estimated material under
    /// novel lights (--light) or views (--orbit); for simulated scans also
    /// with the true material, printing PSNR and SSIM per image.
    Render(render::RenderArgs),
    /// Bake a scan's estimate into UV textures (SCAN/estimate/texture) and
    /// write the mesh with that material as glTF 2.0 (material.gltf +
    /// material.bin, or --glb), plus principled.md for Blender.
    Export(export::ExportArgs),
    /// Train one parameter network on simulated bundles (resumable after a
    /// kill: run the same command again); writes weights, checkpoints,
    /// loss.csv and loss.png.
    Train(train::TrainArgs),
    /// Run the capture service (systemd Type=notify; see
    /// docs/daemon-protocol.md).
    Daemon(daemon::DaemonArgs),
    /// Ask the daemon for a capture. Exit codes: 0 done, 1 usage or
    /// protocol error, 3 daemon unreachable, 4 refused, 5 capture failed,
    /// 6 captured but the estimate failed.
    CaptureNow(capture_now::CaptureNowArgs),
    /// Show the daemon's rig, queue and last scans (exit codes as
    /// capture-now).
    Status(status::StatusArgs),
    /// Render a simulated scan bundle (or a dataset of them) with the
    /// built-in path tracer.
    Simulate(simulate::SimulateArgs),
    /// Write a bundle's calibration maps (float EXR, one folder per
    /// position), `calib check SCAN` to check its calibration, or `calib
    /// rig BUNDLE` to calibrate the rig's camera from board photos.
    #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
    Calib(calib::CalibArgs),
    /// Draw a contact sheet of a scan bundle: the estimate beside the
    /// truth with error maps and a re-render under a novel light (where
    /// there is an estimate), then captures, mask, truth and calibration
    /// maps per position.
    Sheet(sheet::SheetArgs),
}

/// Runs the command `cli` names.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo(a) => demo::run(&a),
        Command::Estimate(a) => estimate::run(&a),
        Command::Eval(a) => eval::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Export(a) => export::run(&a),
        Command::Train(a) => train::run(&a),
        Command::Daemon(a) => daemon::run(&a),
        Command::CaptureNow(a) => capture_now::run(&a),
        Command::Status(a) => status::run(&a),
        Command::Simulate(a) => simulate::run(a),
        Command::Calib(a) => calib::run(a),
        Command::Sheet(a) => sheet::run(a),
    }
}
