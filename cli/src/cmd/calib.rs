//! `matscan calib`: write a bundle's calibration maps, check its
//! calibration against its photos, or (through [`super::rig_calib`])
//! calibrate the rig itself from photos of a printed board.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use matscan_calib::check::{check, CheckOptions, CheckReport};
use matscan_calib::{calibrate_bundle, write_maps, CalibOptions};
use matscan_scan::{Bundle, Manifest};
use std::path::Path;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Debug, Args)]
pub struct CalibArgs {
    #[command(subcommand)]
    pub action: Option<CalibAction>,
    /// The scan bundle folder.
    #[arg(required = true)]
    pub scan: Option<PathBuf>,
    /// Output folder (default: SCAN/calib).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum CalibAction {
    /// Validate the calibration against the photos: silhouette IoU of the
    /// projected mesh against the object in the photos, light positions
    /// against the shading, and a verdict per position. Exits 2 when a
    /// check fails.
    Check {
        /// The scan bundle folder.
        scan: PathBuf,
        /// Check the photos against this rig file (as `calib rig` wrote
        /// it) instead of the rig the scan recorded: does the calibration
        /// still explain a new scan? Also prints how far the scan's
        /// recorded rig lies from it.
        #[arg(long)]
        rig: Option<PathBuf>,
        /// Print one JSON object with the per-position figures.
        #[arg(long)]
        json: bool,
    },
    /// Photograph a calibration target through the running daemon: the
    /// operator is prompted for each board pose and presses the footswitch
    /// (the simulated rig's operator places the board itself). Prints the
    /// calibration bundle for `matscan calib rig`. Exit codes as
    /// `capture-now`.
    Capture(CaptureArgs),
    /// Calibrate the rig's camera from a calibration bundle (photos of a
    /// printed chessboard): intrinsics, distortion and the camera's pose at
    /// every position, written as a rig file with a report. Exits 2 when
    /// the calibration is refused (the report says which shots to retake).
    Rig(super::rig_calib::RigArgs),
    /// Locate the flashes from a light-calibration bundle (a glossy
    /// sphere's highlights, `calib capture --target sphere`) with the
    /// camera of a rig file; writes that rig file with the flashes moved
    /// where they were found, and a report.
    Lights(super::rig_calib::LightsArgs),
    /// Measure each light's intensity from a radiometric calibration
    /// bundle (a white card of known reflectance, `calib capture --target
    /// white`) with the camera and lights of a rig file, and check the
    /// camera's linearity; writes that rig file with the intensities, and
    /// a report.
    Radiometry(super::rig_calib::RadiometryArgs),
    /// Render a calibration bundle on the simulated rig: a printed board
    /// at several poses per position, with the true rig beside it.
    Board(super::rig_calib::BoardArgs),
    /// Compare two rig files: focal length, principal point, and the
    /// camera's pose at every position both name.
    Compare {
        /// The rig file to judge.
        measured: PathBuf,
        /// The rig file to judge it against.
        reference: PathBuf,
    },
}

/// What a calibration capture photographs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CalibTarget {
    /// A printed chessboard: the cameras, and the projector by Gray codes.
    Board,
    /// A glossy sphere of known radius: the flashes' positions.
    Sphere,
    /// A matte white card of known reflectance on the board's mount: the
    /// lights' intensities and the camera's linearity.
    White,
}

#[derive(Debug, Args)]
pub struct CaptureArgs {
    /// What to photograph.
    #[arg(long, value_enum)]
    pub target: CalibTarget,
    /// Board poses per position, the reference placement included
    /// (default: the daemon's `[calibration] shots`).
    #[arg(long)]
    pub shots: Option<usize>,
    /// Gray-code poses for the projector, 0 for none (default: the
    /// daemon's `[calibration] projector_shots`).
    #[arg(long)]
    pub projector_shots: Option<usize>,
    /// Places of the sphere, at least 2 (default: the daemon's
    /// `[calibration] sphere_placements`).
    #[arg(long)]
    pub placements: Option<usize>,
    /// Exposures of the white card for the linearity check, 1 to 6
    /// (default: the daemon's `[calibration] white_exposures`).
    #[arg(long)]
    pub exposures: Option<usize>,
    /// The daemon's control socket.
    #[arg(long, default_value = matscan_daemon::service::config::DEFAULT_SOCKET)]
    pub socket: PathBuf,
    /// Print one JSON object (`bundle` and `summary`).
    #[arg(long)]
    pub json: bool,
}

fn run_capture(a: &CaptureArgs) -> Result<()> {
    let target = match a.target {
        CalibTarget::Board => "board",
        CalibTarget::Sphere => "sphere",
        CalibTarget::White => "white",
    };
    let code =
        matscan_daemon::client::calib_capture(&matscan_daemon::client::CalibCaptureOptions {
            socket: a.socket.clone(),
            target: target.to_string(),
            shots: a.shots,
            projector_shots: a.projector_shots,
            placements: a.placements,
            exposures: a.exposures,
            json: a.json,
        });
    match code {
        0 => Ok(()),
        code => std::process::exit(i32::from(code)),
    }
}

/// Runs `matscan calib`: exit code 2 when a check fails.
pub fn run(a: CalibArgs) -> Result<()> {
    match (a.action, a.scan) {
        (Some(CalibAction::Check { scan, rig, json }), _) => {
            if run_check(&scan, rig.as_deref(), json)? {
                Ok(())
            } else {
                std::process::exit(2)
            }
        }
        (Some(CalibAction::Capture(c)), _) => run_capture(&c),
        (Some(CalibAction::Rig(r)), _) => super::rig_calib::run_rig(r),
        (Some(CalibAction::Lights(l)), _) => super::rig_calib::run_lights(l),
        (Some(CalibAction::Radiometry(r)), _) => super::rig_calib::run_radiometry(r),
        (Some(CalibAction::Board(b)), _) => super::rig_calib::run_board(b),
        (
            Some(CalibAction::Compare {
                measured,
                reference,
            }),
            _,
        ) => super::rig_calib::run_compare(&measured, &reference),
        (None, Some(scan)) => {
            let out = a.out.unwrap_or_else(|| scan.join("calib"));
            write(&scan, &out)
        }
        (None, None) => anyhow::bail!("give a scan folder: matscan calib SCAN"),
    }
}

/// Writes every map of every position under `out` and prints a summary.
pub fn write(scan: &Path, out: &Path) -> Result<()> {
    let bundle = open(scan)?;
    let t = Instant::now();
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())
        .with_context(|| format!("calibrating {}", scan.display()))?;
    let secs = t.elapsed().as_secs_f64();
    let files = write_maps(&calibration, out)
        .with_context(|| format!("writing calibration maps to {}", out.display()))?;
    for pc in &calibration.positions {
        let name = &pc.maps.position;
        let pixels = pc.maps.geometry.mask.data.iter().filter(|&&m| m).count();
        let light = match &pc.light_response {
            Ok(_) => "white reference ok".to_string(),
            Err(e) => format!("no white reference: {e}"),
        };
        let bad = match pc.bad_light.reason() {
            Some(reason) => format!("; left out: {reason}"),
            None => String::new(),
        };
        println!("{name}: {pixels} object pixels; {light}{bad}");
    }
    println!(
        "{} files in {} ({secs:.2} s to calibrate)",
        files.len(),
        out.display()
    );
    Ok(())
}

/// Checks the calibration; returns whether every check passed.
pub fn run_check(scan: &Path, rig: Option<&Path>, json: bool) -> Result<bool> {
    let mut bundle = open(scan)?;
    if let Some(path) = rig {
        let (rig, _) = Manifest::read_rig(path)
            .with_context(|| format!("reading rig file {}", path.display()))?;
        let d = matscan_rigcal::compare::compare(&bundle.manifest, &rig);
        if !json {
            println!(
                "the scan's recorded rig against {}: focal length {:.3} %, camera position \
                 {:.2} mm, orientation {:.3} deg (worst of {} positions)",
                path.display(),
                d.focal_percent,
                1000.0 * d.position,
                d.rotation_deg,
                d.positions
            );
            for (name, off) in &d.intensities {
                println!("  {name}: intensity {:+.2} %", 100.0 * off);
            }
        }
        bundle
            .manifest
            .adopt_rig(&rig, path)
            .with_context(|| format!("checking {} against {}", scan.display(), path.display()))?;
    }
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())
        .with_context(|| format!("calibrating {}", scan.display()))?;
    let report = check(
        &bundle.manifest,
        &calibration,
        &bundle,
        &CheckOptions::default(),
    )
    .with_context(|| format!("checking {}", scan.display()))?;
    if json {
        println!("{}", report.to_json());
    } else {
        print_report(&report);
    }
    Ok(report.passed())
}

fn open(scan: &Path) -> Result<Bundle> {
    let bundle = Bundle::open(scan).with_context(|| format!("opening scan {}", scan.display()))?;
    for w in &bundle.warnings {
        eprintln!("warning: {w}");
    }
    Ok(bundle)
}

fn print_report(report: &CheckReport) {
    for p in &report.positions {
        let sil = match &p.silhouette {
            Some(s) => format!("silhouette IoU {:.4} ({:?})", s.iou, s.source),
            None => "no silhouette to compare (no mask, no backlit capture)".to_string(),
        };
        println!("{}: {sil}", p.position);
        for l in &p.lights {
            match l.correlation {
                Some(c) => println!(
                    "  {} ({}): shading correlation {c:.3} over {} px{}",
                    l.capture,
                    l.light,
                    l.pixels,
                    if c < 0.5 {
                        " (weak: expected on textured or glossy objects; near 0 or below means a misplaced light)"
                    } else {
                        ""
                    }
                ),
                None => println!(
                    "  {} ({}): no shading variation to compare",
                    l.capture, l.light
                ),
            }
        }
    }
    if report.passed() {
        println!("verdict: calibration consistent with the photos");
    } else {
        println!("verdict: PROBLEMS");
        for p in &report.problems {
            println!("  - {p}");
        }
    }
}
