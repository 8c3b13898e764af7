//! `matscan calib rig`, `calib board` and `calib compare`: the rig
//! calibrated from photos of a printed chessboard, the simulated rig's
//! board photos, and two rig files side by side.

use anyhow::{Context, Result};
use clap::Args;
use matscan_rigcal::compare::compare;
use matscan_rigcal::lights::calibrate_lights;
use matscan_rigcal::projector::calibrate_projector;
use matscan_rigcal::radiometry::calibrate_radiometry;
use matscan_rigcal::sheet::write_contact_sheet;
use matscan_rigcal::write::{write_calibration, REPORT_FILE};
use matscan_rigcal::write::{write_lights, write_radiometry, WrittenRig};
use matscan_rigcal::{calibrate_camera, Acceptance};
use matscan_scan::calib_bundle::{BoardFrames, CalibManifest};
use matscan_scan::lights_bundle::LightsManifest;
use matscan_scan::white_bundle::WhiteManifest;
use matscan_scan::Manifest;
use matscan_sim::calib_target::{write_board_bundle, BoardBundleOptions, TRUTH_RIG};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug, Args)]
pub struct RigArgs {
    /// The calibration bundle folder (`calib.toml` and the board photos).
    pub bundle: PathBuf,
    /// Output folder for `rig.toml` and `calib-report.toml` (default:
    /// BUNDLE/result).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep each position's lights from this rig file (same position
    /// names); without it the rig file has no lights and the report says so.
    #[arg(long)]
    pub lights_from: Option<PathBuf>,
    /// Refuse a calibration whose reprojection RMS is above this, pixels.
    #[arg(long, default_value_t = Acceptance::default().max_rms_px)]
    pub max_rms: f64,
    /// A light-calibration bundle (`calib capture --target sphere`): the
    /// flashes are located from it with the camera just calibrated, as
    /// `calib lights` does, and the rig file gets them.
    #[arg(long)]
    pub spheres: Option<PathBuf>,
    /// A radiometric calibration bundle (`calib capture --target white`):
    /// each light's intensity is measured from it with the camera and
    /// flashes just calibrated, as `calib radiometry` does, and the rig
    /// file gets them. Needs --spheres (the flashes' positions).
    #[arg(long, requires = "spheres")]
    pub white: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct BoardArgs {
    /// Output folder (must not exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Photo width and height, pixels.
    #[arg(long, default_value_t = 1024)]
    pub size: u32,
    #[arg(long, default_value_t = 3)]
    pub positions: usize,
    /// Shots per position, the reference shot included.
    #[arg(long, default_value_t = 8)]
    pub shots: usize,
    /// Gray-code shots for the projector, at the first position.
    #[arg(long, default_value_t = 12)]
    pub projector_shots: usize,
    /// Leave out the photo per position of the board on the mount's second
    /// seat.
    #[arg(long)]
    pub no_seat: bool,
    /// Frames averaged into each photo of the resting board (the
    /// reference and the seat), each rendered with its own noise.
    #[arg(long, default_value_t = BoardFrames::DEFAULT.resting, value_parser = frames)]
    pub resting_frames: usize,
    /// Frames averaged into each photo of a held board (the hand-held and
    /// the Gray-code poses, propped still): 1 for a board held by hand.
    #[arg(long, default_value_t = BoardFrames::DEFAULT.held, value_parser = frames)]
    pub held_frames: usize,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Paths per pixel.
    #[arg(long, default_value_t = 16)]
    pub samples: u32,
}

/// Runs `matscan calib rig`: exit code 2 when the calibration is refused.
pub fn run_rig(a: RigArgs) -> Result<()> {
    let manifest = CalibManifest::read(&a.bundle)
        .with_context(|| format!("reading calibration bundle {}", a.bundle.display()))?;
    let lights = match &a.lights_from {
        Some(path) => Some((
            path.as_path(),
            Manifest::read_rig(path)
                .with_context(|| format!("reading lights from {}", path.display()))?
                .0,
        )),
        None => None,
    };
    let acceptance = Acceptance {
        max_rms_px: a.max_rms,
        ..Acceptance::default()
    };
    let t = Instant::now();
    let calibration = calibrate_camera(&a.bundle, &manifest, &acceptance)
        .with_context(|| format!("calibrating the camera from {}", a.bundle.display()))?;
    // Printed before the steps that may still fail, so the shots to retake
    // are named whatever comes next.
    for s in &calibration.report.skipped {
        println!(
            "  {} left out: {}; {}",
            s.file.display(),
            s.reason,
            match &s.graycode {
                Some(g) => format!(
                    "retake the pose with its Gray codes ({}), which the projector lost too",
                    g.display()
                ),
                None => "retake it to add its pose".to_string(),
            }
        );
    }
    let projector = if calibration.report.accepted {
        calibrate_projector(&a.bundle, &calibration)
            .with_context(|| format!("calibrating the projector from {}", a.bundle.display()))?
    } else {
        None
    };
    let seconds = t.elapsed().as_secs_f64();
    let out = a.out.unwrap_or_else(|| a.bundle.join("result"));
    let written = write_calibration(
        &out,
        &calibration,
        projector.as_ref(),
        lights.as_ref().map(|(p, m)| (*p, m)),
    )
    .with_context(|| format!("writing the calibration to {}", out.display()))?;
    let sheet = write_contact_sheet(&calibration, &out)
        .with_context(|| format!("drawing the contact sheet into {}", out.display()))?;
    let r = &calibration.report;
    println!("camera {}", r.lens);
    println!(
        "{} shots, reprojection RMS {:.3} px, coverage {:.0} %, {seconds:.2} s",
        r.shots.len(),
        r.rms_px,
        100.0 * r.coverage
    );
    for s in &r.shots {
        println!(
            "  {} {}: {} corners, RMS {:.3} px (max {:.3}), weight {:.2}, tilt {:.0} deg{}",
            s.position,
            s.file.display(),
            s.corners,
            s.rms_px,
            s.max_px,
            s.weight,
            s.tilt_deg,
            match (&s.seat, s.reference) {
                (Some(seat), _) => format!(", on {seat}"),
                (None, true) => ", reference".to_string(),
                (None, false) => String::new(),
            }
        );
    }
    for seat in &r.seats {
        println!(
            "  {} holds the board turned {:.1} deg from the reference",
            seat.name, seat.turn_deg
        );
    }
    if let Some(p) = &projector {
        let r = &p.report;
        println!(
            "projector {}; {} Gray-code shots, reprojection RMS {:.3} projector px, pose \
             spread {:.2} mm / {:.3} deg",
            r.lens,
            r.shots.len(),
            r.rms_px,
            1000.0 * r.pose_spread,
            r.pose_spread_deg
        );
    }
    let Some(mut written) = written else {
        eprintln!(
            "calibration refused (see {} and {}):",
            out.join(REPORT_FILE).display(),
            sheet.display()
        );
        for p in &r.problems {
            eprintln!("  - {p}");
        }
        for f in &r.retake {
            eprintln!("  retake {}", f.display());
        }
        std::process::exit(2)
    };
    println!(
        "wrote {}, {} and {}",
        written.path.display(),
        out.join(REPORT_FILE).display(),
        sheet.display()
    );
    if let Some(spheres) = &a.spheres {
        written = locate_flashes(spheres, &written.rig, &written.path, &out)?;
        println!("wrote the flashes into {}", written.path.display());
    }
    if let Some(white) = &a.white {
        written = radiometry(white, &written.rig, &written.path, &out)?;
        println!("wrote the intensities into {}", written.path.display());
    }
    Ok(())
}

/// A frame count of 1 to [`BoardFrames::MAX`], as the daemon takes it.
fn frames(text: &str) -> Result<usize, String> {
    let n = text
        .parse::<usize>()
        .map_err(|e| format!("{text:?}: {e}"))?;
    BoardFrames::check("frames", n).map(|()| n)
}

/// Runs `matscan calib board`: the simulated rig's board photos.
pub fn run_board(a: BoardArgs) -> Result<()> {
    let opts = BoardBundleOptions {
        width: a.size,
        height: a.size,
        positions: a.positions,
        shots_per_position: a.shots,
        projector_shots: a.projector_shots,
        seat: !a.no_seat,
        frames: BoardFrames {
            resting: a.resting_frames,
            held: a.held_frames,
        },
        seed: a.seed,
        samples: a.samples,
        ..BoardBundleOptions::default()
    };
    let t = Instant::now();
    let manifest = write_board_bundle(&opts, &a.out)
        .with_context(|| format!("rendering a board bundle into {}", a.out.display()))?;
    println!(
        "{} positions x {} shots{} of a {}x{} board ({} m squares) in {} ({:.1} s); the true rig is {}",
        manifest.positions.len(),
        a.shots,
        if a.no_seat { "" } else { " and the second seat" },
        manifest.board.cols,
        manifest.board.rows,
        manifest.board.square,
        a.out.display(),
        t.elapsed().as_secs_f64(),
        a.out.join(TRUTH_RIG).display()
    );
    Ok(())
}

/// Runs `matscan calib compare MEASURED REFERENCE`.
pub fn run_compare(measured: &Path, reference: &Path) -> Result<()> {
    let read = |p: &Path| {
        Manifest::read_rig(p)
            .map(|(m, _)| m)
            .with_context(|| format!("reading rig file {}", p.display()))
    };
    let d = compare(&read(measured)?, &read(reference)?);
    println!(
        "camera: focal length {:.4} %, principal point {:.3} px; over {} positions: position \
         {:.3} mm, orientation {:.4} deg, the object's box {:.3} px apart (worst)",
        d.focal_percent,
        d.principal_px,
        d.positions,
        1000.0 * d.position,
        d.rotation_deg,
        d.object_px
    );
    match d.projector {
        Some(p) => println!(
            "projector: focal length {:.4} %, principal point {:.3} px, position {:.3} mm, \
             orientation {:.4} deg (worst)",
            p.focal_percent,
            p.principal_px,
            1000.0 * p.position,
            p.rotation_deg
        ),
        None => println!("projector: not in both files"),
    }
    for (name, d) in &d.flashes {
        println!("{name}: position {:.3} mm (worst)", 1000.0 * d);
    }
    for (name, d) in &d.intensities {
        println!("{name}: intensity {:+.3} % (worst)", 100.0 * d);
    }
    Ok(())
}

#[derive(Debug, Args)]
pub struct LightsArgs {
    /// The light-calibration bundle folder (`lights.toml` and the sphere's
    /// photos).
    pub bundle: PathBuf,
    /// The rig file whose camera took the photos (as `calib rig` wrote
    /// it); its flashes are replaced by the ones measured.
    #[arg(long)]
    pub rig: PathBuf,
    /// Output folder for `rig.toml` and `lights-report.toml` (default:
    /// BUNDLE/result).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Prints each place's sphere and each flash found.
fn print_lights(lights: &matscan_rigcal::lights::LightCalibration) {
    for (folder, s) in &lights.spheres {
        println!(
            "  {}: sphere at {:.1} mm, radius {:.1} px, outline RMS {:.3} px ({} edge points), \
             centred by the {}",
            folder.display(),
            1000.0 * s.centre.length(),
            s.radius_px,
            s.edge_rms_px,
            s.edge_points,
            if s.centred_by_projector {
                "projector's highlight"
            } else {
                "outline"
            }
        );
    }
    for f in &lights.flashes {
        println!(
            "{}: {:.1} {:.1} {:.1} mm from the camera, {} rays {:.2} mm apart (RMS), spread \
             {:.1} deg",
            f.name,
            1000.0 * f.position.x,
            1000.0 * f.position.y,
            1000.0 * f.position.z,
            f.rays,
            1000.0 * f.ray_rms,
            f.spread_deg
        );
    }
}

#[derive(Debug, Args)]
pub struct RadiometryArgs {
    /// The radiometric calibration bundle folder (`white.toml` and the
    /// card's photos).
    pub bundle: PathBuf,
    /// The rig file whose camera took the photos, with the flashes located
    /// (as `calib lights` wrote it); its intensities are replaced by the
    /// ones measured.
    #[arg(long)]
    pub rig: PathBuf,
    /// Output folder for `rig.toml` and `white-report.toml` (default:
    /// BUNDLE/result).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Measures the intensities from the white-card bundle at `bundle` with
/// `rig` (read from `rig_path`), prints them and writes the rig file and
/// report into `out`; returns the rig file's path.
fn radiometry(bundle: &Path, rig: &Manifest, rig_path: &Path, out: &Path) -> Result<WrittenRig> {
    let manifest = WhiteManifest::read(bundle).with_context(|| {
        format!(
            "reading radiometric calibration bundle {}",
            bundle.display()
        )
    })?;
    let t = Instant::now();
    let measured = calibrate_radiometry(bundle, &manifest, rig)
        .with_context(|| format!("measuring the lights from {}", bundle.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    for l in &measured.lights {
        println!(
            "{}: intensity {:.4}, colour {:.4} {:.4} {:.4}, {} pixels, spread {:.2} % ({})",
            l.name,
            l.intensity,
            l.color[0],
            l.color[1],
            l.color[2],
            l.pixels,
            100.0 * l.spread,
            l.file.display()
        );
    }
    for l in &measured.linearity {
        let readings: Vec<String> = l
            .readings
            .iter()
            .map(|(e, r)| format!("{r:.4} at {e:.4} s"))
            .collect();
        println!(
            "linearity of {}: {} (worst {:.2} %)",
            l.light,
            readings.join(", "),
            100.0 * l.worst()
        );
    }
    let written = write_radiometry(out, rig, &measured, rig_path)
        .with_context(|| format!("writing the intensities to {}", out.display()))?;
    println!("{seconds:.2} s");
    Ok(written)
}

/// Runs `matscan calib radiometry`.
pub fn run_radiometry(a: RadiometryArgs) -> Result<()> {
    let (rig, _) = Manifest::read_rig(&a.rig)
        .with_context(|| format!("reading rig file {}", a.rig.display()))?;
    let out = a.out.unwrap_or_else(|| a.bundle.join("result"));
    let written = radiometry(&a.bundle, &rig, &a.rig, &out)?;
    println!("wrote {}", written.path.display());
    Ok(())
}

/// Locates the flashes from the sphere bundle at `bundle` with `rig` (read
/// from `rig_path`), prints them and writes the rig file and report into
/// `out`.
fn locate_flashes(
    bundle: &Path,
    rig: &Manifest,
    rig_path: &Path,
    out: &Path,
) -> Result<WrittenRig> {
    let manifest = LightsManifest::read(bundle)
        .with_context(|| format!("reading light-calibration bundle {}", bundle.display()))?;
    let t = Instant::now();
    let lights = calibrate_lights(bundle, &manifest, rig)
        .with_context(|| format!("locating the flashes from {}", bundle.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    let written = write_lights(out, rig, &lights, rig_path)
        .with_context(|| format!("writing the lights to {}", out.display()))?;
    print_lights(&lights);
    println!("{seconds:.2} s");
    Ok(written)
}

/// Runs `matscan calib lights`.
pub fn run_lights(a: LightsArgs) -> Result<()> {
    let (rig, _) = Manifest::read_rig(&a.rig)
        .with_context(|| format!("reading rig file {}", a.rig.display()))?;
    let out = a.out.unwrap_or_else(|| a.bundle.join("result"));
    let written = locate_flashes(&a.bundle, &rig, &a.rig, &out)?;
    println!("wrote {}", written.path.display());
    Ok(())
}
