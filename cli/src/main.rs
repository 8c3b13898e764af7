//! `matscan`: the command line and the daemon of the scanner PC.
//!
//! This binary is the edge of the system: it parses arguments, sets up
//! logging, and turns library errors into context-rich messages (`anyhow`).
//! The work itself lives in the library crates: `matscan-scan` (bundles),
//! `matscan-sim` (the simulated rig), `matscan-calib` (per-pixel maps),
//! `matscan-estimate` (the estimator), `matscan-bake` (textures, glTF),
//! `matscan-evaluate` (eval, bench, re-rendering) and `matscan-daemon` (the
//! capture service and its client); each command is one module of
//! [`cmd`].
//!
//! Crate choices: `clap` (derive) for arguments and `--help`; `indicatif`
//! for progress bars on long runs; `tracing-subscriber` for logs on stderr
//! (`RUST_LOG` selects the level).

mod cmd;

use clap::Parser;

/// Whether stderr is the journal stream systemd gave this service
/// (`JOURNAL_STREAM` holds its `device:inode`).
fn stderr_is_the_journal() -> bool {
    let Some(stream) = std::env::var_os("JOURNAL_STREAM") else {
        return false;
    };
    let Some((dev, ino)) = stream.to_str().and_then(|s| s.split_once(':')) else {
        return false;
    };
    // SAFETY: fstat on fd 2 writes into a zeroed stat buffer.
    let mut st: libc::stat = unsafe { std::mem::zeroed() };
    if unsafe { libc::fstat(2, &mut st) } != 0 {
        return false;
    }
    dev.parse::<u64>().ok() == Some(st.st_dev) && ino.parse::<u64>().ok() == Some(st.st_ino)
}

/// Logs to the journal under systemd (levels become priorities), else to
/// stderr, coloured only on a terminal. `RUST_LOG` filters (default warn).
fn init_logging() {
    use std::io::IsTerminal;
    use tracing_subscriber::prelude::*;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    if stderr_is_the_journal() {
        if let Ok(journal) = tracing_journald::layer() {
            tracing_subscriber::registry()
                .with(filter)
                .with(journal.with_syslog_identifier("matscan".into()))
                .init();
            return;
        }
    }
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_env_filter(filter)
        .init();
}

fn main() -> std::process::ExitCode {
    init_logging();
    let args = cmd::Cli::parse();
    match cmd::run(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(1)
        }
    }
}
