//! Soak: `cargo run --release -p matscan --example soak -- [CAPTURES] [SIZE]`
//! (default 200 captures of 16x16 px, one position, one sample), each
//! estimated with small random width-8 networks, through the control socket
//! of a daemon in this process. Prints file descriptors, threads and
//! resident memory every 20 captures and the growth from the baseline taken
//! after 10 warm-up captures.

use matscan_daemon::service::config::Config;
use matscan_daemon::service::notify::Notifier;
use matscan_daemon::service::server::Server;
use matscan_daemon::soak::soak;
use matscan_estimate::{cpu_device, Models};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let captures: usize = args
        .next()
        .map_or(Ok(200), |a| a.parse())
        .map_err(|e| format!("CAPTURES: {e}"))?;
    let size: u32 = args
        .next()
        .map_or(Ok(16), |a| a.parse())
        .map_err(|e| format!("SIZE: {e}"))?;
    let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
    let weights = dir.path().join("weights");
    Models::seeded(&matscan_estimate::PIPELINE_ORDER, 8, 1, &cpu_device())
        .map_err(|e| e.to_string())?
        .save_dir(&weights)
        .map_err(|e| e.to_string())?;
    let text = format!(
        "rig = \"simulated\"\nsocket = {:?}\nscans = {:?}\n[estimate]\nweights = {weights:?}\n\
         [simulated]\nseed = 3\ngeometry = \"sphere\"\nsize = {size}\npositions = 1\nsamples = 1\n",
        dir.path().join("s.sock"),
        dir.path().join("scans"),
    );
    let config = Config::parse(&text, Path::new("soak.toml")).map_err(|e| e.to_string())?;
    let socket = config.socket.clone();
    let server = Server::bind(config, Notifier::new(None, None)).map_err(|e| e.to_string())?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    let daemon = std::thread::spawn(move || server.run(&flag));
    let report = soak(&socket, captures, 10.min(captures), 20)?;
    stop.store(true, Ordering::SeqCst);
    let _ = daemon.join();
    println!("captures  fds  threads  rss MiB");
    let b = report.baseline;
    println!(
        "{:>8} {:>4} {:>8} {:>8.1}  (baseline)",
        10,
        b.fds,
        b.threads,
        b.rss_kib as f64 / 1024.0
    );
    for (i, u) in &report.samples {
        println!(
            "{i:>8} {:>4} {:>8} {:>8.1}",
            u.fds,
            u.threads,
            u.rss_kib as f64 / 1024.0
        );
    }
    let e = report.end;
    println!(
        "growth after {captures} captures: {:+} fds, {:+} threads, {:+.1} MiB; median {:.3} s per capture",
        e.fds as i64 - b.fds as i64,
        e.threads as i64 - b.threads as i64,
        (e.rss_kib as f64 - b.rss_kib as f64) / 1024.0,
        report.median_seconds()
    );
    Ok(())
}
