//! `matscan export`: bakes a scan's estimate into UV textures and writes
//! the mesh with that material as glTF 2.0 (see `matscan_bake`).
//!
//! Reads `SCAN/estimate/<position>/<param>.exr` for every position that has
//! maps (run `matscan estimate --every-position` first for textures that
//! cover the whole object), writes `texture/<param>.png`,
//! `texture/coverage.png`, `material.gltf` + `material.bin` (or
//! `material.glb` with `--glb`) and `principled.md` into `--out`
//! (default: the estimate folder).

use anyhow::{bail, Context, Result};
use clap::Args;
use matscan_bake::{
    bake_bundle, export_gltf, metres_per_unit, BakeOptions, GltfFormat, DEFAULT_SIZE,
};
use matscan_scan::Bundle;
use std::path::PathBuf;
use std::time::Instant;

/// The flags of `matscan export`.
#[derive(Args, Debug, Clone)]
pub struct ExportArgs {
    /// The scan folder.
    pub scan: PathBuf,
    /// Output folder (default: SCAN/estimate, where the maps are read).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Side of the square textures, texels.
    #[arg(long, default_value_t = DEFAULT_SIZE)]
    pub size: u32,
    /// Write one self-contained material.glb instead of .gltf + .bin.
    #[arg(long)]
    pub glb: bool,
}

/// Runs `matscan export`.
pub fn run(args: &ExportArgs) -> Result<()> {
    let estimate = args
        .scan
        .join(matscan_estimate::pipeline::output::ESTIMATE_DIR);
    if !estimate.is_dir() {
        bail!(
            "{}: no estimate; run `matscan estimate --every-position {}` first",
            estimate.display(),
            args.scan.display()
        );
    }
    let bundle = Bundle::open(&args.scan)
        .with_context(|| format!("opening scan {}", args.scan.display()))?;
    let started = Instant::now();
    let options = BakeOptions {
        size: args.size,
        ..BakeOptions::default()
    };
    let textures = bake_bundle(&bundle, &estimate, None, &options)
        .with_context(|| format!("baking {}", estimate.display()))?;
    let baked_s = started.elapsed().as_secs_f64();
    let out = args.out.clone().unwrap_or(estimate);
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let mesh = bundle.read_mesh()?;
    let format = if args.glb {
        GltfFormat::Binary
    } else {
        GltfFormat::Separate
    };
    let metres = metres_per_unit(&bundle.manifest.units);
    let path = export_gltf(&mesh, &textures, &out, format, metres)
        .with_context(|| format!("exporting glTF into {}", out.display()))?;
    let measured = textures.coverage().data.iter().filter(|&&c| c).count();
    let total = textures.coverage().data.len().max(1);
    println!(
        "baked {} at {}x{} in {baked_s:.2} s: {:.1}% of texels measured, the rest filled",
        textures
            .params()
            .iter()
            .map(|p| p.name())
            .collect::<Vec<_>>()
            .join(", "),
        textures.width(),
        textures.height(),
        100.0 * measured as f64 / total as f64
    );
    println!("wrote {}", path.display());
    Ok(())
}
