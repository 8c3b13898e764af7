//! `matscan status`: the daemon's rig, queue and last scans (exit codes as
//! `capture-now`).

use anyhow::Result;
use clap::Args;
use matscan_daemon::client::{status, StatusOptions};
use matscan_daemon::service::config::DEFAULT_SOCKET;
use std::path::PathBuf;

/// The flags of `matscan status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// The daemon's control socket.
    #[arg(long, default_value = DEFAULT_SOCKET)]
    pub socket: PathBuf,
    /// Print the daemon's reply as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `matscan status`, ending the process with its exit code.
pub fn run(a: &StatusArgs) -> Result<()> {
    match status(&StatusOptions {
        socket: a.socket.clone(),
        json: a.json,
    }) {
        0 => Ok(()),
        code => std::process::exit(i32::from(code)),
    }
}
