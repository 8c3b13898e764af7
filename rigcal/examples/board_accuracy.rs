//! Development probe: renders a board bundle on a random simulated rig,
//! calibrates the camera from it and prints the result against the truth.
//! `cargo run --release -p matscan-rigcal --example board_accuracy -- SIZE SHOTS SEED SAMPLES [DIR [PROJECTOR_SHOTS]]`

use matscan_rigcal::compare::compare;
use matscan_rigcal::{calibrate_camera, Acceptance};
use matscan_scan::calib_bundle::CalibManifest;
use matscan_scan::Manifest;
use matscan_sim::calib_target::{write_board_bundle, BoardBundleOptions, TRUTH_RIG};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |k: usize, d: u64| args.get(k).and_then(|s| s.parse().ok()).unwrap_or(d);
    let size = arg(1, 512) as u32;
    let opts = BoardBundleOptions {
        width: size,
        height: size,
        shots_per_position: arg(2, 6) as usize,
        projector_shots: arg(6, 6) as usize,
        seed: arg(3, 1),
        samples: arg(4, 16) as u32,
        ..BoardBundleOptions::default()
    };
    let dir = match args.get(5) {
        Some(d) => std::path::PathBuf::from(d),
        None => std::env::temp_dir().join(format!("board-{size}-{}", opts.seed)),
    };
    if !dir.join("calib.toml").exists() {
        let t = Instant::now();
        write_board_bundle(&opts, &dir)?;
        println!(
            "rendered {} in {:.1} s",
            dir.display(),
            t.elapsed().as_secs_f64()
        );
    }
    let manifest = CalibManifest::read(&dir)?;
    let t = Instant::now();
    let cal = calibrate_camera(&dir, &manifest, &Acceptance::default())?;
    let projector = matscan_rigcal::projector::calibrate_projector(&dir, &cal)?;
    let seconds = t.elapsed().as_secs_f64();
    let (truth, _) = Manifest::read_rig(&dir.join(TRUTH_RIG))?;
    let measured = matscan_rigcal::write::rig_manifest(&cal, projector.as_ref(), None, "probe");
    let d = compare(&measured, &truth);
    let (k, r) = (&cal.camera, &truth.camera);
    println!(
        "calibrated in {seconds:.2} s, {} iterations",
        cal.report.iterations
    );
    println!(
        "fx {:.3} fy {:.3} cx {:.3} cy {:.3} dist {:?}",
        k.fx, k.fy, k.cx, k.cy, k.distortion
    );
    println!(
        "truth fx {:.3} cx {:.3} cy {:.3} dist {:?}",
        r.fx, r.cx, r.cy, r.distortion
    );
    println!(
        "focal {:.4} %  principal {:.3} px  position {:.3} mm  rotation {:.4} deg  rms {:.3} px  coverage {:.2}  accepted {} {:?}",
        d.focal_percent,
        d.principal_px,
        1000.0 * d.position,
        d.rotation_deg,
        cal.report.rms_px,
        cal.report.coverage,
        cal.report.accepted,
        cal.report.problems
    );
    println!("projector {:?}", d.projector);
    if let Some(p) = &projector {
        println!(
            "projector report rms {:.3} spread {:.2} mm {:.3} deg",
            p.report.rms_px,
            1000.0 * p.report.pose_spread,
            p.report.pose_spread_deg
        );
        for s in &p.report.shots {
            println!(
                "  {} corners {} bits {:?} rms {:.3}",
                s.graycode.display(),
                s.corners,
                s.finest_bits,
                s.rms_px
            );
        }
    }
    for s in &cal.report.shots {
        println!(
            "  {} rms {:.3} max {:.3} tilt {:.1}",
            s.file.display(),
            s.rms_px,
            s.max_px,
            s.tilt_deg
        );
    }
    Ok(())
}
