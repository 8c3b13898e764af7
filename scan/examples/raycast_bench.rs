//! Ray-casting benchmark: builds a ~524k-triangle displaced cube-sphere in
//! code and prints the BVH build time and rays per second (median of
//! several runs) for coherent primary rays and incoherent random rays,
//! closest hit and occlusion, on one thread and on every core.
//!
//! Run: `cargo run --release -p matscan-scan --example raycast_bench`.
//! The figures go into the `//!` doc of `scan/src/bvh.rs`.

use glam::Vec3;
use matscan_scan::bvh::{Bvh, Ray, RayCaster};
use matscan_scan::mesh_io::{read_mesh, write_mesh};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::time::{Duration, Instant};

mod bench_common;

use bench_common::{displaced_cube_sphere, median_pair, ms, Clock, RUNS};

fn main() {
    let cells = 209; // 6 faces x 209^2 quads x 2 = 524 172 triangles
    let mesh = displaced_cube_sphere(cells);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "mesh: {} triangles, {} vertices; {threads} hardware threads",
        mesh.triangle_count(),
        mesh.positions.len()
    );

    let build = median_pair(|| {
        let clock = Clock::start();
        let bvh = Bvh::build(&mesh);
        std::hint::black_box(bvh.node_count());
        clock.stop()
    });
    println!(
        "build: {:.1} ms wall, {:.1} ms on-CPU (median of {RUNS})",
        ms(build.0),
        ms(build.1)
    );

    // Mesh I/O at the same size, for scale: binary PLY and OBJ.
    let dir = std::env::temp_dir().join(format!("matscan-raycast-bench-{}", std::process::id()));
    if std::fs::create_dir_all(&dir).is_ok() {
        for name in ["bench.ply", "bench.obj"] {
            let path = dir.join(name);
            let write = median_pair(|| {
                let clock = Clock::start();
                if let Err(e) = write_mesh(&path, &mesh) {
                    eprintln!("write {name}: {e}");
                }
                clock.stop()
            });
            let read = median_pair(|| {
                let clock = Clock::start();
                let read = read_mesh(&path);
                let times = clock.stop();
                assert_eq!(read.ok().as_ref(), Some(&mesh), "{name} round trip");
                times
            });
            let size = std::fs::metadata(&path).map_or(0, |m| m.len());
            println!(
                "{name} ({:.1} MB): write {:.0} ms, read {:.0} ms on-CPU",
                size as f64 / 1e6,
                ms(write.1),
                ms(read.1)
            );
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    let caster = RayCaster::new(mesh);
    println!("nodes: {}", caster.bvh.node_count());

    let primary = primary_rays(1024, 512);
    let random = random_rays(primary.len(), 7);
    let light = Vec3::new(2.0, 2.5, -3.0);
    // Shadow segments from the primary hits to a point light: coherent
    // occlusion queries as the renderer issues them.
    let shadow: Vec<Ray> = primary
        .iter()
        .filter_map(|r| caster.closest(r))
        .map(|(_, s)| {
            let from = caster.offset(s.position, s.geometric_normal);
            let d = light - from;
            Ray::segment(from, d.normalize(), 0.0, d.length())
        })
        .collect();

    let primary_hits = primary
        .iter()
        .filter(|r| caster.bvh.intersect(r).is_some())
        .count();
    let random_hits = random
        .iter()
        .filter(|r| caster.bvh.intersect(r).is_some())
        .count();
    println!(
        "primary: {} rays ({:.0}% hit); random: {} rays ({:.0}% hit); shadow: {} rays",
        primary.len(),
        100.0 * primary_hits as f64 / primary.len() as f64,
        random.len(),
        100.0 * random_hits as f64 / random.len() as f64,
        shadow.len()
    );

    let bvh = &caster.bvh;
    let closest = |rays: &[Ray]| rays.iter().filter(|r| bvh.intersect(r).is_some()).count();
    let occluded = |rays: &[Ray]| rays.iter().filter(|r| bvh.occluded(r)).count();
    println!(
        "{:<20} {:>16} {:>16} {:>16}",
        "query (Mrays/s)",
        "1 thread wall",
        "1 thread on-CPU",
        format!("{threads} threads wall")
    );
    for (name, rays, query) in [
        (
            "primary closest",
            &primary,
            &closest as &(dyn Fn(&[Ray]) -> usize + Sync),
        ),
        ("random closest", &random, &closest),
        ("shadow occluded", &shadow, &occluded),
        ("random occluded", &random, &occluded),
    ] {
        let single = median_pair(|| {
            let clock = Clock::start();
            std::hint::black_box(query(rays));
            clock.stop()
        });
        let multi = median(|| {
            let t = Instant::now();
            let chunk = rays.len().div_ceil(threads);
            std::thread::scope(|s| {
                for part in rays.chunks(chunk) {
                    s.spawn(move || std::hint::black_box(query(part)));
                }
            });
            t.elapsed()
        });
        println!(
            "{name:<20} {:>16.2} {:>16.2} {:>16.2}",
            mrays(rays.len(), single.0),
            mrays(rays.len(), single.1),
            mrays(rays.len(), multi)
        );
    }
}

fn median(mut f: impl FnMut() -> Duration) -> Duration {
    let mut v: Vec<Duration> = (0..RUNS).map(|_| f()).collect();
    v.sort();
    v[RUNS / 2]
}

fn mrays(n: usize, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64() / 1e6
}

/// Rays of a pinhole camera 3 units from the centre, scanline order.
fn primary_rays(width: usize, height: usize) -> Vec<Ray> {
    let eye = Vec3::new(0.3, -0.4, -3.0);
    let forward = (-eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let f = 1.8 * width as f32 / 2.0;
    let mut rays = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let px = (x as f32 + 0.5 - width as f32 / 2.0) / f;
            let py = (y as f32 + 0.5 - height as f32 / 2.0) / f;
            let dir = (forward + right * px - up * py).normalize();
            rays.push(Ray::new(eye, dir));
        }
    }
    rays
}

/// Rays from random points on a sphere of radius 3 towards random points
/// in the ball of radius 1.2: no coherence between neighbours.
fn random_rays(count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let unit = |rng: &mut Pcg64| loop {
        let p = Vec3::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        if p.length_squared() <= 1.0 && p.length_squared() > 1e-6 {
            return p;
        }
    };
    (0..count)
        .map(|_| {
            let origin = unit(&mut rng).normalize() * 3.0;
            let target = unit(&mut rng) * 1.2;
            let d = target - origin;
            Ray::segment(origin, d.normalize(), 0.0, d.length() * 2.0)
        })
        .collect()
}
