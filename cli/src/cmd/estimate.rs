//! `matscan estimate`: the five BSDF parameter maps of a scan, written to
//! `estimate/` (see `matscan_estimate::pipeline`).
//!
//! Weights: `--weights DIR` with `<param>.weights` per network, else the
//! trained weights embedded in the binary (a build without them refuses and
//! says where it looked).
//!
//! `--every-position` estimates in every usable position's camera image, not
//! only the reference's: what `matscan export` needs to bake textures that
//! cover the whole object.
//!
//! `--refine N` runs the per-pixel refinement after the networks with N
//! solver iterations (0, the default, turns it off; see
//! `matscan_estimate::refine`); it writes `<param>_confidence.exr` beside
//! the maps and its stop reasons into `result.toml`.

use anyhow::{bail, Context, Result};
use clap::Args;
use matscan_estimate::fit::{FitLight, FitOptions};
use matscan_estimate::net::models::weights_file_name;
use matscan_estimate::net::weights::EMBEDDED;
use matscan_estimate::pipeline::method::Method;
use matscan_estimate::pipeline::plan::{parse_given, parse_param};
use matscan_estimate::refine::RefineOptions;
use matscan_estimate::{estimate, Backend, EstimateOptions, ModelSource, References, ViewFilter};
use matscan_scan::Param;
use std::path::PathBuf;

/// The flags of `matscan estimate`.
#[derive(Args, Debug, Clone)]
pub struct EstimateArgs {
    /// The scan folder.
    pub scan: PathBuf,
    /// Output folder (default: SCAN/estimate).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A known parameter: a constant in [0, 1] or an EXR map in the
    /// reference camera's image, e.g. `--given transmission=0`,
    /// `--given roughness=map.exr`. Repeatable.
    #[arg(long, value_name = "P=V|FILE")]
    pub given: Vec<String>,
    /// Only these parameters (and what they need), comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "P,...")]
    pub only: Vec<String>,
    /// Only these views: a capture name, or POSITION/CAPTURE; comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "VIEW,...")]
    pub views: Vec<String>,
    /// Only these positions, comma-separated.
    #[arg(long, value_delimiter = ',', value_name = "POSITION,...")]
    pub positions: Vec<String>,
    /// Folder with the trained networks, `<param>.weights` each (default:
    /// the weights built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
    /// Write maps for every usable position (each in turn as reference with
    /// the same views), not only the reference: texture baking then covers
    /// what any camera saw. Costs one network pass per position.
    #[arg(long)]
    pub every_position: bool,
    /// Refine basecolor, roughness and metallic per pixel against the
    /// photos after the networks, with at most N solver iterations per
    /// pixel (0: off). Run time grows linearly with N.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub refine: u32,
    /// Who answers basecolor, roughness and metallic: networks (the
    /// thesis's), fit (the physical fit to the photos under the calibrated
    /// lights), hybrid (the fit where the photos pin a value, the networks
    /// elsewhere), fit-metallic (metallic as hybrid answers it, basecolor
    /// and roughness by their networks fed that metallic), fit-specular
    /// (fit-metallic, then the fit's roughness where the photos pin it) or
    /// fit-dielectric (the default: fit-specular, then the fit's basecolor
    /// on the materials it reads as opaque dielectrics).
    /// Under every method but networks and hybrid, transmission and
    /// subsurface are measured where the photos speak (0 on a material
    /// they show lacks them, a clear material's transmission from the
    /// backlight, a scattering material's subsurface from renders of the
    /// object under the flashes); their networks answer elsewhere.
    #[arg(long, default_value_t = Method::default())]
    pub method: Method,
    /// Which light the physical fit explains: total (lit minus ambient as
    /// photographed), direct (the global light, interreflections and
    /// light scattered inside, measured with the projector's checker
    /// against its uniform field and subtracted; a scan without them is
    /// fitted to its total light) or material (the default: direct, but a
    /// material whose measured global light is at least 30 % of its light
    /// scatters inside and is fitted to its total light).
    #[arg(long, value_name = "LIGHT", default_value_t = FitLight::default())]
    pub fit_light: FitLight,
    /// Where the networks run: cpu (the build's default CPU backend), flex,
    /// ndarray or gpu (Vulkan; needs a build with `--features vulkan`).
    #[arg(long, default_value = "cpu")]
    pub backend: Backend,
}

/// Runs `matscan estimate`.
pub fn run(args: &EstimateArgs) -> Result<()> {
    let given = args
        .given
        .iter()
        .map(|g| parse_given(g))
        .collect::<Result<Vec<_>, _>>()?;
    let only = if args.only.is_empty() {
        None
    } else {
        Some(
            args.only
                .iter()
                .map(|p| parse_param(p))
                .collect::<Result<Vec<Param>, _>>()?,
        )
    };
    let models = match &args.weights {
        Some(dir) => {
            if !dir.is_dir() {
                bail!("--weights {}: no such folder", dir.display());
            }
            ModelSource::Dir(dir.clone())
        }
        None if EMBEDDED.is_empty() => bail!(
            "no trained weights: this build embeds none (they would come from \
             estimate/weights/ at build time); pass --weights DIR with {}",
            matscan_estimate::PIPELINE_ORDER
                .iter()
                .map(|k| weights_file_name(*k))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None => ModelSource::Embedded,
    };
    let options = EstimateOptions {
        out: args.out.clone(),
        given,
        only,
        filter: ViewFilter {
            positions: args.positions.clone(),
            views: args.views.clone(),
        },
        references: if args.every_position {
            References::Every
        } else {
            References::First
        },
        refine: RefineOptions {
            iterations: args.refine,
            ..RefineOptions::default()
        },
        method: args.method,
        fit: FitOptions {
            light: args.fit_light,
            ..FitOptions::default()
        },
        ..EstimateOptions::default()
    };
    let (device, adapter) = args
        .backend
        .device()
        .with_context(|| format!("--backend {}", args.backend.label()))?;
    if let Some(adapter) = adapter {
        tracing::info!("networks on the GPU: {adapter}");
    }
    let report = estimate(&args.scan, models, &options, &device)
        .with_context(|| format!("estimating {}", args.scan.display()))?;
    let result = &report.result;
    for w in &result.warnings {
        eprintln!("warning: {w}");
    }
    for reason in &result.left_out {
        eprintln!("left out: {reason}");
    }
    println!(
        "reference position {}, {} views; maps for {}",
        result.reference_position,
        result.views.len(),
        result.positions.join(", ")
    );
    // The same table `capture-now --wait` and the demo print.
    let summary = matscan_daemon::service::worker::summary(&report.out, result);
    print!(
        "{}",
        matscan_daemon::client::format_estimate(&serde_json::json!({
            "outcome": "estimated",
            "summary": summary,
        }))
    );
    if let Some(r) = &result.refine {
        let stops: Vec<String> = r.stops.iter().map(|(k, v)| format!("{k} {v}")).collect();
        println!(
            "refined {} ({} iterations, {:.2} s): {}",
            r.fitted.join(", "),
            r.iterations,
            result.timings.refine_s,
            stops.join(", ")
        );
    }
    if let Some(f) = &result.fit {
        println!(
            "fit ({}, {:.2} s, of which backlight {:.2} s, scattering {:.2} s): {} materials; \
             scale from {}",
            f.method,
            result.timings.fit_s,
            result.timings.backlight_s,
            result.timings.scattering_s,
            f.materials.len(),
            f.scale
        );
        for note in &f.notes {
            println!("  note: {note}");
        }
    }
    println!(
        "{:.2} s; wrote {}",
        result.timings.total_s,
        report.out.display()
    );
    Ok(())
}
