//! Times baking 3 positions into 2048x2048 textures (all five parameters).
//!
//! Makes a simulated 256x256 scan (sphere, 3 positions, one path per
//! pixel: only the truth maps matter here) in a temporary folder, then
//! bakes its truth maps RUNS times and prints each wall time and the
//! median. `cargo run --release -p matscan-bake --example bake_bench [--
//! SIZE RUNS]`.

use matscan_bake::{bake_maps, read_truth_maps, BakeOptions};
use matscan_sim::render::{write_scan_bundle, SimOptions};
use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let size: u32 = args.next().map_or(Ok(2048), |s| s.parse())?;
    let runs: usize = args.next().map_or(Ok(5), |s| s.parse())?;
    if runs == 0 {
        return Err("RUNS must be at least 1".into());
    }
    let scene = generate(&SceneOptions {
        seed: 1,
        kind: SceneKind::Multimat,
        geometry: GeometrySource::Kind(GeometryKind::Sphere),
        width: 256,
        height: 256,
        positions: 3,
        map_size: 256,
    });
    let dir = tempfile::tempdir()?;
    let sim = SimOptions {
        samples: 1,
        ..SimOptions::default()
    };
    let bundle = write_scan_bundle(&scene, &sim, &dir.path().join("scan"))?;
    let maps = read_truth_maps(&bundle)?;
    let triangles = bundle.read_mesh()?.triangles.len();
    println!(
        "{} positions, 256x256 maps, {triangles} triangles, {size}x{size} textures, {} threads",
        maps.len(),
        rayon::current_num_threads()
    );
    let options = BakeOptions {
        size,
        ..BakeOptions::default()
    };
    let mut times = Vec::new();
    for run in 0..runs {
        let t = Instant::now();
        let baked = bake_maps(&bundle, &maps, None, &options)?;
        let s = t.elapsed().as_secs_f64();
        let measured = baked.coverage().data.iter().filter(|&&c| c).count();
        println!(
            "run {run}: {s:.3} s ({:.1}% measured)",
            100.0 * measured as f64 / baked.coverage().data.len() as f64
        );
        times.push(s);
    }
    times.sort_by(f64::total_cmp);
    println!("median {:.3} s over {runs} runs", times[runs / 2]);
    Ok(())
}
