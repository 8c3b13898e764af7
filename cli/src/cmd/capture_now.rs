//! `matscan capture-now`: ask the daemon for a capture; the exit code says
//! how it went (0 done, 1 usage or protocol error, 3 daemon unreachable,
//! 4 refused, 5 capture failed, 6 captured but the estimate failed).

use anyhow::Result;
use clap::Args;
use matscan_daemon::client::{capture_now, CaptureNowOptions};
use matscan_daemon::service::config::DEFAULT_SOCKET;
use std::path::PathBuf;

/// The flags of `matscan capture-now`.
#[derive(Debug, Args)]
pub struct CaptureNowArgs {
    /// The daemon's control socket.
    #[arg(long, default_value = DEFAULT_SOCKET)]
    pub socket: PathBuf,
    /// Follow the capture and print the scan's folder and summary.
    #[arg(long)]
    pub wait: bool,
    /// Print one JSON object (with `--wait`: `scan` and `summary`).
    #[arg(long)]
    pub json: bool,
    /// Capture profile (default: the daemon's `default_profile`).
    #[arg(long)]
    pub profile: Option<String>,
}

/// Runs `matscan capture-now`, ending the process with its exit code.
pub fn run(a: &CaptureNowArgs) -> Result<()> {
    let code = capture_now(&CaptureNowOptions {
        socket: a.socket.clone(),
        wait: a.wait,
        json: a.json,
        profile: a.profile.clone(),
    });
    match code {
        0 => Ok(()),
        code => std::process::exit(i32::from(code)),
    }
}
