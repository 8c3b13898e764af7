//! Helpers of the daemon tests: a daemon on a temporary socket with the
//! simulated rig, in a thread of the test process; and for the tests of
//! the `matscan` binary, running it, a small simulated sphere scan and
//! small random networks.

#![allow(dead_code)]

use matscan_daemon::service::config::Config;
use matscan_daemon::service::notify::Notifier;
use matscan_daemon::service::server::Server;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

/// A config for the simulated rig: tiny photos, one sample, one position.
/// `top` adds top-level keys and sections; `simulated` adds or overrides
/// `[simulated]` keys (then may open `[simulated.faults]`).
pub fn config_text(socket: &Path, scans: &Path, top: &str, simulated: &str) -> String {
    let overridden: Vec<&str> = simulated
        .lines()
        .take_while(|l| !l.trim_start().starts_with('['))
        .filter_map(|l| l.split('=').next())
        .map(str::trim)
        .collect();
    let defaults: String = [
        "seed = 2",
        "geometry = \"sphere\"",
        "size = 24",
        "positions = 1",
        "samples = 1",
    ]
    .iter()
    .filter(|l| !overridden.contains(&l.split('=').next().unwrap_or("").trim()))
    .map(|l| format!("{l}\n"))
    .collect();
    // Estimation is the slow part of a job; tests that are about capture
    // turn it off, tests about estimation bring their own `[estimate]`.
    let estimate = if top.contains("[estimate]") {
        ""
    } else {
        "[estimate]\nenabled = false\n"
    };
    format!(
        "rig = \"simulated\"\nsocket = {socket:?}\nscans = {scans:?}\n{top}\n{estimate}\
         [simulated]\n{defaults}{simulated}\n"
    )
}

/// Small random networks (seed 3) for all five parameters in `dir`, as the
/// daemon's `[estimate] weights` folder; returns the config section naming
/// them.
pub fn test_weights(dir: &Path) -> String {
    let weights = weights_dir(dir, 3);
    format!("[estimate]\nweights = {weights:?}\n")
}

/// Small random networks for all five parameters, from `seed`, saved in
/// `dir/weights` (a `--weights` folder); returns that folder.
pub fn weights_dir(dir: &Path, seed: u64) -> PathBuf {
    use matscan_estimate::{cpu_device, Models};
    let weights = dir.join("weights");
    Models::seeded(&matscan_estimate::PIPELINE_ORDER, 8, seed, &cpu_device())
        .unwrap()
        .save_dir(&weights)
        .unwrap();
    weights
}

/// Runs the `matscan` binary with `args`.
pub fn matscan(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_matscan"))
        .args(args)
        .output()
        .expect("run matscan")
}

/// Its standard output, as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs `matscan` with `args`, asserts it succeeded (showing its output
/// otherwise) and returns its standard output.
pub fn matscan_ok(args: &[&str]) -> String {
    let o = matscan(args);
    assert!(
        o.status.success(),
        "matscan {args:?} failed:\nstdout:\n{}\nstderr:\n{}",
        stdout(&o),
        String::from_utf8_lossy(&o.stderr)
    );
    stdout(&o)
}

/// `matscan simulate` of a sphere, `size` px, `positions` positions,
/// `samples` samples per pixel, plus `extra` flags (at least the output:
/// `--out DIR`, or `--dataset DIR --count N`); asserts it succeeded.
pub fn simulate_sphere(size: u32, positions: u32, samples: u32, extra: &[&str]) {
    let (size, positions, samples) = (size.to_string(), positions.to_string(), samples.to_string());
    let mut args = vec![
        "simulate",
        "--size",
        &size,
        "--positions",
        &positions,
        "--samples",
        &samples,
        "--geometry",
        "sphere",
    ];
    args.extend_from_slice(extra);
    matscan_ok(&args);
}

pub struct TestDaemon {
    pub socket: PathBuf,
    pub scans: PathBuf,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl TestDaemon {
    pub fn start(dir: &Path, top: &str, simulated: &str) -> TestDaemon {
        let socket = dir.join("matscan.sock");
        let scans = dir.join("scans");
        TestDaemon::start_with(&config_text(&socket, &scans, top, simulated))
    }

    pub fn start_with(text: &str) -> TestDaemon {
        let config = Config::parse(text, Path::new("test.toml")).unwrap();
        let (socket, scans) = (config.socket.clone(), config.scans.clone());
        let server = Server::bind(config, Notifier::new(None, None)).unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || server.run(&flag).unwrap());
        TestDaemon {
            socket,
            scans,
            stop,
            thread: Some(thread),
        }
    }

    /// Published scans (folders not hidden), sorted.
    pub fn scans(&self) -> Vec<PathBuf> {
        list(&self.scans, |n| !n.starts_with('.'))
    }

    /// Hidden entries of the scans folder (temporaries).
    pub fn hidden(&self) -> Vec<PathBuf> {
        list(&self.scans, |n| n.starts_with('.'))
    }

    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            t.join().unwrap();
        }
    }
}

impl Drop for TestDaemon {
    fn drop(&mut self) {
        self.halt();
    }
}

pub fn list(dir: &Path, keep: impl Fn(&str) -> bool) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| keep(&e.file_name().to_string_lossy()))
        .map(|e| e.path())
        .collect();
    v.sort();
    v
}

/// The name of this process's group (the socket_group test gives the
/// socket to it, the one group the daemon surely belongs to).
pub fn own_group_name() -> Option<String> {
    // SAFETY: getgid cannot fail.
    let gid = unsafe { libc::getgid() };
    let mut buf = vec![0u8; 1 << 16];
    // SAFETY: `group` and `result` are valid out-pointers, `buf` is
    // writable for its length.
    let mut group: libc::group = unsafe { std::mem::zeroed() };
    let mut result: *mut libc::group = std::ptr::null_mut();
    let rc = unsafe {
        libc::getgrgid_r(
            gid,
            &mut group,
            buf.as_mut_ptr().cast(),
            buf.len(),
            &mut result,
        )
    };
    if rc != 0 || result.is_null() {
        return None;
    }
    // SAFETY: on success gr_name points into `buf`, NUL-terminated.
    let name = unsafe { std::ffi::CStr::from_ptr(group.gr_name) };
    name.to_str().ok().map(str::to_string)
}
