//! `matscan eval SCANS...`: error against run time over simulated scans,
//! as the thesis's tables (see `matscan_evaluate::eval`).

use anyhow::{Context, Result};
use clap::Args;
use matscan_estimate::fit::FitLight;
use matscan_estimate::pipeline::method::Method;
use matscan_estimate::pipeline::oracle::Oracles;
use matscan_evaluate::eval::rig_error::RigError;
use matscan_evaluate::eval::tables::GroupBy;
use matscan_evaluate::eval::{run as evaluate, DependencySource, EvalOptions};
use std::path::PathBuf;

/// The flags of `matscan eval`.
#[derive(Args, Debug)]
pub struct EvalArgs {
    /// Simulated scans with truth maps: scan folders, or folders of them
    /// (as `matscan simulate --dataset` writes, also one level deeper).
    #[arg(required = true, value_name = "SCANS")]
    pub data: Vec<PathBuf>,
    /// Folder with `<param>.weights` per network (default: the weights
    /// built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
    /// View counts to compare, comma-separated; 0 = every view.
    #[arg(long, value_delimiter = ',', default_value = "1,3,0")]
    pub views: Vec<usize>,
    /// A training set whose mean truth per parameter is the trivial
    /// baseline (default: the evaluated set's own mean).
    #[arg(long, value_name = "DIR")]
    pub baseline_from: Option<PathBuf>,
    /// Evaluate at most this many scans (in name order).
    #[arg(long)]
    pub limit: Option<usize>,
    /// Also write every table as one CSV here (column `table`: overall,
    /// group, family or scene).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Rows of the per-group tables: kind (the scene kind) or dataset
    /// (kind and geometry).
    #[arg(long, default_value = "kind")]
    pub group_by: GroupBy,
    /// Also print each scene's run time beside its errors (the CSV always
    /// has them).
    #[arg(long)]
    pub per_scene: bool,
    /// Where each network's dependencies come from: estimated (the other
    /// networks' estimates: the product's chained path, what `matscan
    /// estimate` does; the thesis's section 4.8) or truth (each network on
    /// its own, as the thesis measured its Tables 4.1 to 4.3, section 4.5;
    /// run time is the networks' alone).
    #[arg(long, default_value = "estimated")]
    pub dependencies: DependencySource,
    /// Also bake estimate and truth into UV textures of SIZE texels
    /// (default 256) and report per-parameter error on measured texels and
    /// re-render PSNR/SSIM under 2 novel lights and 2 novel views.
    #[arg(long, value_name = "SIZE", num_args = 0..=1, default_missing_value = "256")]
    pub textures: Option<u32>,
    /// Who answers basecolor, roughness and metallic in the chained
    /// estimate: networks, fit, hybrid, fit-metallic, fit-specular or
    /// fit-dielectric (see `matscan estimate --help`; default: the
    /// estimator's, fit-dielectric). The
    /// truth-fed protocol measures the networks alone.
    #[arg(long)]
    pub method: Option<Method>,
    /// Which light the physical fit explains: total (lit minus ambient),
    /// direct (the global light measured with the projector's checker
    /// subtracted) or material (the default: direct, total for a material
    /// whose light is largely global; see `matscan estimate --help`).
    #[arg(long, value_name = "LIGHT")]
    pub fit_light: Option<FitLight>,
    /// The error budget: besides the estimate as it is, estimate again with
    /// each SET of pieces fed from the truth (repeatable; a SET is pieces
    /// joined by commas, from segmentation, roughness, metallic,
    /// transmission and subsurface) and print each parameter's MAD per set
    /// and scene kind, at the last count of --views. Simulated scans only.
    #[arg(long, value_name = "SET")]
    pub oracle: Vec<Oracles>,
    /// Estimate with a deliberately wrong rig calibration, to measure what
    /// a calibration error costs: focal=PERCENT (fx and fy scaled),
    /// camera-shift=MM (the camera moved along its x axis),
    /// camera-turn=DEG (turned about its y axis), light-shift=MM (every
    /// flash moved along the camera's x axis) or intensity=PERCENT (every
    /// light's intensity scaled), at every position.
    #[arg(long, value_name = "KEY=VALUE")]
    pub rig_error: Option<RigError>,
    /// Estimate with calibrated rig files in place of each scan's rig: a
    /// rig file for every scan, or a folder with `<scan folder
    /// name>/rig.toml` per scan (as `matscan calib rig --out` writes it):
    /// what a rig calibrated from photos costs against the true rig.
    #[arg(long, value_name = "PATH")]
    pub rig_from: Option<PathBuf>,
}

/// Runs `matscan eval`: prints the tables, writes the CSV.
pub fn run(a: &EvalArgs) -> Result<()> {
    let report = evaluate(&EvalOptions {
        data: a.data.clone(),
        weights: a.weights.clone(),
        views: a.views.clone(),
        baseline_from: a.baseline_from.clone(),
        limit: a.limit,
        group_by: a.group_by,
        per_scene: a.per_scene,
        dependencies: a.dependencies,
        textures: a.textures,
        method: a.method,
        fit_light: a.fit_light,
        oracles: a.oracle.clone(),
        rig_error: a.rig_error,
        rig_from: a.rig_from.clone(),
    })?;
    print!("{}", report.table);
    if let Some(path) = &a.csv {
        matscan_scan::atomic::write_atomic(path, report.csv.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
