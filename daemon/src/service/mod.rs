//! `matscan daemon`: the capture service of the scanner PC.
//!
//! - [`config`]: the TOML configuration, validated;
//! - [`plan`]: the capture plan from a profile;
//! - [`sequencer`]: carries a plan out on the rig's drivers and publishes
//!   the scan bundle atomically;
//! - [`rig`]: opens the configured rig (simulated, or [`hardware`]: V4L2
//!   camera, serial lights, evdev footswitch, rig calibration file and the
//!   scanner's mesh export);
//! - [`server`]: the daemon's life (socket, capture thread listening to
//!   the footswitch while idle, stop);
//! - [`socket`]: the control protocol (`docs/daemon-protocol.md`);
//! - [`request`]: a capture request from the socket or the footswitch,
//!   queued or refused by the busy policy;
//! - [`state`]: the queue and the jobs, shared between threads;
//! - [`worker`]: the estimation worker (calibration check, then
//!   `matscan_estimate::estimate` into the scan's `estimate/`);
//! - [`notify`]: systemd notification.
//!
//! Boundaries: the estimator is called only from the worker.

pub mod config;
pub mod hardware;
pub mod notify;
pub mod plan;
pub mod request;
pub mod rig;
pub mod sequencer;
pub mod server;
pub mod socket;
pub mod state;
pub mod worker;

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// What `matscan daemon` runs with: the configuration file and its
/// command-line overrides.
#[derive(Clone, Debug)]
pub struct DaemonOptions {
    /// The configuration file (TOML; see docs/daemon-protocol.md).
    pub config: PathBuf,
    /// Control socket path (overrides the config's `socket`; default
    /// /run/matscan/matscan.sock).
    pub socket: Option<PathBuf>,
    /// Scans folder (overrides the config's `scans`; default
    /// /var/lib/matscan/scans).
    pub scans: Option<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum DaemonError {
    #[error(transparent)]
    Config(#[from] config::ConfigError),
    #[error(transparent)]
    Server(#[from] server::ServerError),
}

/// The configuration `args` select: the file, then the command-line
/// overrides.
pub fn load_config(args: &DaemonOptions) -> Result<config::Config, DaemonError> {
    let mut config = config::Config::load(&args.config)?;
    if let Some(s) = &args.socket {
        config.socket = s.clone();
    }
    if let Some(s) = &args.scans {
        config.scans = s.clone();
    }
    Ok(config)
}

/// Runs the daemon until SIGTERM or SIGINT (exit code 0), or fails to start
/// (exit code 1).
pub fn run_daemon(args: &DaemonOptions) -> Result<(), DaemonError> {
    let config = load_config(args)?;
    server::install_signal_handlers()?;
    let server = server::Server::bind(config, notify::Notifier::from_env())?;
    server.run(&AtomicBool::new(false))?;
    Ok(())
}
