//! `matscan sheet`: a scan's contact sheet (see `matscan_evaluate::sheet`).

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct SheetArgs {
    /// The scan bundle folder.
    pub scan: PathBuf,
    /// Output PNG (default: SCAN/sheet.png).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `matscan sheet`.
pub fn run(a: SheetArgs) -> Result<()> {
    let out = a.out.unwrap_or_else(|| a.scan.join("sheet.png"));
    matscan_evaluate::sheet::draw_contact_sheet(&a.scan, &out)?;
    println!("{}", out.display());
    Ok(())
}
