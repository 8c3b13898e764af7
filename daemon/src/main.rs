//! `matscan`: the command line and the daemon of the scanner PC.
//!
//! This binary is the edge of the system: it parses arguments, sets up
//! logging, and turns library errors into context-rich messages (`anyhow`).
//! The work itself lives in the library crates: `matscan-scan` (bundles),
//! `matscan-sim` (the simulated rig), `matscan-calib` (per-pixel maps),
//! `matscan-estimate` (the networks), and this package's library (the
//! daemon service and its clients).
//!
//! Crate choices: `clap` (derive) for arguments and `--help`; `indicatif`
//! for progress bars on long runs; `tracing-subscriber` for logs on stderr
//! (`RUST_LOG` selects the level).

mod backend_arg;
mod bench_cmd;
mod calib_cmd;
mod chart;
mod cli;
mod demo;
mod estimate_cmd;
mod eval_cmd;
mod eval_tables;
mod eval_texture;
mod export_cmd;
mod font;
mod render_cmd;
mod sheet;
mod simulate;
mod train_cmd;

use clap::Parser;

fn main() -> std::process::ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn")),
        )
        .init();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(1)
        }
    }
}
