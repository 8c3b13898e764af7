//! `matscan daemon`: the capture service (systemd `Type=notify`; see
//! docs/daemon-protocol.md).

use anyhow::{Context, Result};
use clap::Args;
use matscan_daemon::service::{run_daemon, DaemonOptions};
use std::path::PathBuf;

/// The flags of `matscan daemon`.
#[derive(Debug, Args)]
pub struct DaemonArgs {
    /// The configuration file (TOML; see docs/daemon-protocol.md).
    #[arg(long)]
    pub config: PathBuf,
    /// Control socket path (overrides the config's `socket`; default
    /// /run/matscan/matscan.sock).
    #[arg(long)]
    pub socket: Option<PathBuf>,
    /// Scans folder (overrides the config's `scans`; default
    /// /var/lib/matscan/scans).
    #[arg(long)]
    pub scans: Option<PathBuf>,
}

/// Runs the daemon until SIGTERM or SIGINT.
pub fn run(a: &DaemonArgs) -> Result<()> {
    run_daemon(&DaemonOptions {
        config: a.config.clone(),
        socket: a.socket.clone(),
        scans: a.scans.clone(),
    })
    .context("matscan daemon")
}
