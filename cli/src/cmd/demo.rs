//! `matscan demo`: the whole product on the simulated rig, in one process.
//!
//! It starts the real daemon (`matscan_daemon::service`) on a socket in the demo
//! folder with `rig = "simulated"`, asks it for one capture through the real
//! client (`capture-now --wait`), so the sequencer, the atomic bundle
//! writer, the calibration check and the estimation worker all run exactly
//! as on a scanner PC, then prints the estimate's per-parameter error
//! against the simulated truth with every stage's time, stops the daemon
//! and draws the scan's contact sheet.
//!
//! Boundaries: configuration and printing only; the work is the daemon's.

use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use matscan_daemon::client::{format_check, format_estimate, request_capture, CaptureNow};
use matscan_daemon::service::config::{
    BusyPolicy, CaptureSettings, Config, EstimateSettings, FaultConfig, Profile, RigChoice,
    SimulatedRigConfig, FULL_PROFILE,
};
use matscan_daemon::service::notify::Notifier;
use matscan_daemon::service::server::Server;
use matscan_estimate::net::weights::EMBEDDED;
use matscan_sim::scene::{GeometryKind, SceneKind};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The default scene: `2mat` on a held-out shape, seeded so that both
/// materials are opaque and one is a metal (a test below holds it to that).
pub const DEFAULT_SEED: u64 = 63;
pub const DEFAULT_GEOMETRY: &str = "rock";

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Folder for the demo's daemon socket and scans (created; each run
    /// adds a new numbered scan under OUT/scans).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Random seed of the scene and the renderer. The default, with the
    /// default kind and geometry, is an opaque rock of two materials, one
    /// of them a metal: what the default method measures best.
    #[arg(long, default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Scene kind: multimat, multimat-noenv, 2mat, 2mat-transmission, 3mat,
    /// realworld, sweep-subsurface, sweep-basecolor, sweep-roughness.
    #[arg(long, default_value = "2mat")]
    pub kind: String,
    /// Geometry: sphere, torus, superquadric, blob, leaves, vase, box, rock,
    /// figurine or random (one of the first five).
    #[arg(long, default_value = DEFAULT_GEOMETRY)]
    pub geometry: String,
    /// Photo width and height in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// How far the object reaches from the image centre towards its
    /// nearest edge: every camera aims at the object and the focal length
    /// is chosen for it, as an operator sets up a rig. 0 keeps the data
    /// sets' random aim and focal length.
    #[arg(long, default_value_t = matscan_daemon::service::config::DEFAULT_FRAME)]
    pub frame: f64,
    /// Number of scan-head positions (the simulated turntable turns
    /// between them).
    #[arg(long, default_value_t = 3)]
    pub positions: usize,
    /// Path-tracing samples per pixel of each photo.
    #[arg(long, default_value_t = 16)]
    pub samples: u32,
    /// Folder with `<param>.weights` per network (default: the weights
    /// built into this binary).
    #[arg(long, value_name = "DIR")]
    pub weights: Option<PathBuf>,
}

/// The daemon configuration the demo's flags describe.
fn config(a: &DemoArgs) -> Result<Config> {
    let kind: SceneKind = a
        .kind
        .parse()
        .map_err(|e| anyhow::anyhow!("--kind {}: {e}", a.kind))?;
    let geometry = match a.geometry.as_str() {
        "random" => None,
        g => Some(
            g.parse::<GeometryKind>()
                .map_err(|e| anyhow::anyhow!("--geometry {g}: {e} or random"))?,
        ),
    };
    if !(8..=4096).contains(&a.size) {
        bail!("--size {}: expected 8 to 4096 pixels", a.size);
    }
    if !(1..=64).contains(&a.positions) {
        bail!("--positions {}: expected 1 to 64", a.positions);
    }
    let frame = matscan_daemon::service::config::framing(a.frame)
        .map_err(|e| anyhow::anyhow!("--frame {e}"))?;
    if a.samples == 0 {
        bail!("--samples 0: expected at least one sample per pixel");
    }
    match &a.weights {
        Some(w) if !w.is_dir() => bail!(
            "--weights {}: expected a folder holding <param>.weights files",
            w.display()
        ),
        None if EMBEDDED.is_empty() => bail!(
            "this build embeds no trained weights (estimate/weights/ was empty when it \
             was built); pass --weights DIR"
        ),
        _ => {}
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let mut profiles = BTreeMap::new();
    profiles.insert(FULL_PROFILE.to_string(), Profile::default());
    Ok(Config {
        rig: RigChoice::Simulated(SimulatedRigConfig {
            seed: a.seed,
            kind,
            geometry,
            size: a.size,
            positions: a.positions,
            samples: a.samples,
            frame,
            rig_from: None,
            turntable: true,
            footswitch: None,
            faults: FaultConfig::default(),
        }),
        socket: a.out.join("matscan.sock"),
        socket_group: None,
        scans: a.out.join("scans"),
        busy: BusyPolicy::Queue { limit: 4 },
        profiles,
        default_profile: FULL_PROFILE.to_string(),
        capture: CaptureSettings::default(),
        calibration: Default::default(),
        estimate: EstimateSettings {
            enabled: true,
            weights: a.weights.clone(),
        },
    })
}

/// Runs the demo.
pub fn run(a: &DemoArgs) -> Result<()> {
    let start = Instant::now();
    let config = config(a)?;
    let socket = config.socket.clone();
    println!("rig: {}", config.rig.describe());
    let server = Server::bind(config, Notifier::new(None, None)).context("starting the daemon")?;
    let stop = Arc::new(AtomicBool::new(false));
    let daemon = {
        let stop = stop.clone();
        std::thread::Builder::new()
            .name("matscan-daemon".into())
            .spawn(move || server.run(&stop))
            .context("starting the daemon thread")?
    };

    let bar = ProgressBar::new(1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg:24} [{bar:30}] {pos}/{len} {elapsed}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t_capture = Instant::now();
    let mut capture_s = None;
    let result = request_capture(&socket, None, true, &mut |e| match e["event"].as_str() {
        Some("progress") => {
            bar.set_length(e["total"].as_u64().unwrap_or(1));
            bar.set_position(e["done"].as_u64().unwrap_or(0));
            bar.set_message(e["what"].as_str().unwrap_or("").to_string());
        }
        Some("done") => {
            capture_s = Some(t_capture.elapsed().as_secs_f64());
            bar.set_message("checking, estimating");
        }
        _ => {}
    });
    bar.finish_and_clear();
    stop.store(true, Ordering::SeqCst);
    match daemon.join() {
        Ok(r) => r.context("the demo daemon")?,
        Err(_) => bail!("the demo daemon panicked"),
    }
    let CaptureNow::Captured {
        scan,
        summary,
        check,
        estimate,
        ..
    } = result.context("the demo capture")?
    else {
        bail!("the demo daemon queued the capture but did not run it");
    };
    println!(
        "capture            {:8.2} s  {} positions, {} photos -> {}",
        capture_s.unwrap_or(0.0),
        summary["positions"],
        summary["photos"],
        scan.display()
    );
    if let Some((position, share)) = object_share(&scan) {
        println!(
            "object             {:7.0} %  of the frame at position {position}",
            100.0 * share
        );
    }
    println!("calibration check: {}", format_check(&check));
    print!("{}", format_estimate(&estimate));
    let t_sheet = Instant::now();
    let sheet = scan.join("sheet.png");
    matscan_evaluate::sheet::draw_contact_sheet(&scan, &sheet)?;
    println!(
        "contact sheet      {:8.2} s  -> {}",
        t_sheet.elapsed().as_secs_f64(),
        sheet.display()
    );
    println!("total              {:8.2} s", start.elapsed().as_secs_f64());
    if estimate["outcome"] == "failed" {
        bail!("the estimate failed (see above)");
    }
    Ok(())
}

/// The share of the first position's frame the object covers (its mask),
/// where the bundle has one.
fn object_share(scan: &std::path::Path) -> Option<(String, f64)> {
    let bundle = matscan_scan::Bundle::open(scan).ok()?;
    let position = bundle.manifest.positions.first()?.name.clone();
    let mask = bundle.read_mask(&position).ok()??;
    let covered = mask.data.iter().filter(|&&m| m).count();
    Some((position, covered as f64 / mask.data.len().max(1) as f64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use matscan_daemon::service::config::RigChoice;
    use matscan_daemon::service::rig::simulated_scene;
    use matscan_sim::scene::Texture;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        demo: DemoArgs,
    }

    fn texel<T: Copy>(t: &Texture<T>, i: usize) -> T {
        match t {
            Texture::Constant(v) => *v,
            Texture::Map(r) => r.data[i],
        }
    }

    #[test]
    fn the_default_scene_is_an_opaque_framed_object_of_two_materials_one_a_metal() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("demo");
        let cli = Cli::parse_from(["demo", "--out", out.to_str().unwrap()]);
        let config = config(&cli.demo).unwrap();
        let RigChoice::Simulated(rig) = &config.rig else {
            panic!("the demo runs the simulated rig");
        };
        assert_eq!((rig.size, rig.positions), (256, 3));
        assert!(rig.frame.is_some(), "the demo frames its object");
        let scene = simulated_scene(rig).unwrap();
        let m = &scene.material;
        let texels = match &m.metallic {
            Texture::Map(r) => r.data.len(),
            Texture::Constant(_) => 1,
        };
        // (metallic, transmission, subsurface, roughness) per texel.
        let mut materials: Vec<[u32; 4]> = (0..texels)
            .map(|i| {
                [
                    texel(&m.metallic, i),
                    texel(&m.transmission, i),
                    texel(&m.subsurface, i),
                    texel(&m.roughness, i),
                ]
                .map(f32::to_bits)
            })
            .collect();
        materials.sort_unstable();
        materials.dedup();
        assert_eq!(materials.len(), 2, "two materials: {materials:?}");
        let value = |bits: u32| f32::from_bits(bits);
        let metals = materials.iter().filter(|t| value(t[0]) == 1.0).count();
        assert_eq!(metals, 1, "one metal: {materials:?}");
        assert!(
            materials
                .iter()
                .all(|t| value(t[1]) == 0.0 && value(t[2]) == 0.0),
            "opaque: {materials:?}"
        );
    }
}
