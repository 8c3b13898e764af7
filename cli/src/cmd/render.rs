//! `matscan render SCAN (--light L,... | --orbit N) --out DIR`: the scanned
//! object with its estimated material under novel lights or views, and for
//! simulated scans beside its true material with PSNR and SSIM (see
//! `matscan_evaluate::render`).

use anyhow::Result;
use clap::Args;
use matscan_evaluate::render::{run as render, RenderOptions};
use matscan_evaluate::rerender::Lighting;
use std::path::PathBuf;

/// The flags of `matscan render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The scan bundle folder.
    pub scan: PathBuf,
    /// Lightings, comma-separated: key-left, key-right, top, rim, camera
    /// (a light at the camera), none; append `+env` for the environment
    /// (e.g. `top+env`, `none+env`). Default with --orbit: camera.
    #[arg(long, value_delimiter = ',', required_unless_present = "orbit")]
    pub light: Vec<Lighting>,
    /// Render N views on a circle around the object (at the reference
    /// camera's distance and elevation) instead of the reference view.
    #[arg(long, value_name = "N")]
    pub orbit: Option<usize>,
    /// Output folder (created; files in it are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Image width in pixels (the height follows the camera's aspect).
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Path-tracing samples per pixel.
    #[arg(long, default_value_t = 32)]
    pub samples: u32,
    /// The estimate folder (default: SCAN/estimate).
    #[arg(long, value_name = "DIR")]
    pub estimate: Option<PathBuf>,
    /// Texture side when the estimate has no baked textures and is baked
    /// in memory (and for the truth when it has).
    #[arg(long, default_value_t = 1024)]
    pub texture_size: u32,
}

/// Runs `matscan render`.
pub fn run(a: &RenderArgs) -> Result<()> {
    let report = render(&RenderOptions {
        scan: a.scan.clone(),
        light: a.light.clone(),
        orbit: a.orbit,
        out: a.out.clone(),
        size: a.size,
        samples: a.samples,
        estimate: a.estimate.clone(),
        texture_size: a.texture_size,
    })?;
    print!("{report}");
    Ok(())
}
