//! Benchmark: every calibration map of a synthetic scan, 3 positions x 7
//! captures at 256x256, a displaced blob of 81 920 triangles before a
//! backplane. Prints the median wall time of the whole calibration (maps,
//! light response, bad light, correspondences) plus warping all 7 photos
//! of every other position into every position.
//!
//! Run: `cargo run --release -p matscan-calib --example calib_bench`
//! (set RAYON_NUM_THREADS=2 to match the CI machine).

use glam::{DVec3, Vec3};
use matscan_calib::calibrate::geometry_maps;
use matscan_calib::synthetic::{blob, intrinsics, manifest, merge, quad, thesis_rig};
use matscan_calib::{calibrate, position_maps, CalibOptions, MemoryScan};
use matscan_scan::bvh::RayCaster;
use matscan_scan::camera::look_at;
use matscan_scan::{CaptureRole, Raster};
use std::time::Instant;

const SIZE: u32 = 256;
const RUNS: usize = 7;

/// CPU seconds (user + system) this process has used, from
/// `/proc/self/stat` (Linux; 0 elsewhere). On a busy shared machine the
/// wall time overstates the cost; CPU time / threads is what an idle
/// machine would take.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the parenthesised command name; utime and stime are the
    // 14th and 15th fields of the whole line, in clock ticks (100 Hz).
    let rest = stat.rsplit(')').next().unwrap_or("");
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let mesh = merge(&[
        blob(Vec3::ZERO, 0.4, 0.08, 6),
        quad(
            Vec3::new(-2.0, -2.0, 1.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
        ),
    ]);
    let triangles = mesh.triangles.len();
    let t = Instant::now();
    let caster = RayCaster::new(mesh);
    let build = t.elapsed().as_secs_f64();

    let up = DVec3::new(0.0, -1.0, 0.0);
    let positions = [
        DVec3::new(0.0, 0.0, -1.5),
        DVec3::new(0.6, 0.3, -1.35),
        DVec3::new(-0.5, -0.4, -1.35),
    ]
    .iter()
    .enumerate()
    .map(|(i, &eye)| thesis_rig(&format!("p{i}"), look_at(eye, DVec3::ZERO, up)))
    .collect();
    let manifest = manifest(intrinsics(SIZE, 40.0), positions);

    // Photos: flat shading from the maps (not timed).
    let mut scan = MemoryScan::default();
    for pos in &manifest.positions {
        let maps = position_maps(&caster, &manifest.camera, pos);
        for c in &pos.captures {
            let photo = Raster::from_fn(SIZE, SIZE, |x, y| {
                let i = maps.geometry.mask.index(x, y);
                let v = match c.role(&pos.lights) {
                    CaptureRole::Lit { light } | CaptureRole::Pattern { light } => {
                        let lm = maps.light(&light).expect("posed light");
                        0.05 + if lm.lit.data[i] {
                            0.5 * lm.cos_nl.data[i].max(0.0)
                        } else {
                            0.0
                        }
                    }
                    CaptureRole::Backlit => {
                        0.05 + if maps.geometry.mask.data[i] { 0.0 } else { 0.8 }
                    }
                    _ => 0.05,
                };
                [v; 3]
            });
            scan.insert_photo(&pos.name, &c.name, photo);
        }
    }

    let mut times = Vec::new();
    let mut cpu = Vec::new();
    let mut warped = 0;
    for _ in 0..RUNS {
        let t = Instant::now();
        let c = cpu_seconds();
        let cal = calibrate(&manifest, &caster, &scan, &CalibOptions::default())
            .expect("synthetic scan calibrates");
        warped = 0;
        for corr in &cal.correspondences {
            let other = manifest.position(&corr.other).expect("known position");
            for c in &other.captures {
                let photo = &scan.photos[&(other.name.clone(), c.name.clone())];
                std::hint::black_box(corr.warp_rgb(photo, &c.name).expect("same size"));
                warped += 1;
            }
        }
        times.push(t.elapsed().as_secs_f64());
        cpu.push(cpu_seconds() - c);
    }
    cpu.sort_by(f64::total_cmp);
    times.sort_by(f64::total_cmp);
    let mut geometry = (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(geometry_maps(&manifest, &caster, &Default::default()));
            t.elapsed().as_secs_f64()
        })
        .collect::<Vec<_>>();
    geometry.sort_by(f64::total_cmp);
    println!(
        "calib_bench: {triangles} triangles, 3 positions x 7 captures at {SIZE}x{SIZE}, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "  BVH build:                  {:.3} s (once per scan)",
        build
    );
    println!(
        "  all maps + {warped} warps: median {:.3} s, min {:.3} s, max {:.3} s over {RUNS} runs",
        times[RUNS / 2],
        times[0],
        times[RUNS - 1]
    );
    println!(
        "  CPU time per run: median {:.3} s (/ {} threads = {:.3} s on an idle machine)",
        cpu[RUNS / 2],
        rayon::current_num_threads(),
        cpu[RUNS / 2] / rayon::current_num_threads() as f64
    );
    println!(
        "  of which ray-cast maps + correspondences: median {:.3} s",
        geometry[RUNS / 2]
    );
}
