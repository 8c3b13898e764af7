//! What the scan crate's benchmark examples share: medians of wall and
//! on-CPU time, and the ~524k-triangle displaced cube-sphere they load and
//! ray-cast. Each example includes it with `mod bench_common;`.

use glam::{Vec2, Vec3};
use matscan_scan::Mesh;
use std::time::{Duration, Instant};

/// Runs per measurement; the medians are quoted.
pub const RUNS: usize = 5;

/// Medians of (wall, on-CPU) pairs, each sorted on its own.
pub fn median_pair(mut f: impl FnMut() -> (Duration, Duration)) -> (Duration, Duration) {
    let runs: Vec<_> = (0..RUNS).map(|_| f()).collect();
    let mut wall: Vec<_> = runs.iter().map(|r| r.0).collect();
    let mut cpu: Vec<_> = runs.iter().map(|r| r.1).collect();
    wall.sort();
    cpu.sort();
    (wall[RUNS / 2], cpu[RUNS / 2])
}

/// Wall time plus this thread's on-CPU time (Linux `schedstat`), so that
/// figures taken on a shared, loaded machine still say what one core does.
/// Where `schedstat` is missing the on-CPU time is the wall time.
pub struct Clock {
    wall: Instant,
    cpu: Option<u64>,
}

impl Clock {
    pub fn start() -> Self {
        Self {
            wall: Instant::now(),
            cpu: thread_cpu_ns(),
        }
    }

    pub fn stop(&self) -> (Duration, Duration) {
        let wall = self.wall.elapsed();
        let cpu = match (self.cpu, thread_cpu_ns()) {
            (Some(a), Some(b)) => Duration::from_nanos(b.saturating_sub(a)),
            _ => wall,
        };
        (wall, cpu)
    }
}

pub fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}

pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// A cube with `cells` x `cells` quads per face, pushed onto the unit sphere
/// and displaced by a few octaves of smooth noise (radius 0.85 to 1.15).
pub fn displaced_cube_sphere(cells: usize) -> Mesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let mut triangles = Vec::new();
    let axes = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    let n = cells + 1;
    for (normal, a, b) in axes {
        let base = positions.len() as u32;
        for j in 0..n {
            for i in 0..n {
                let s = i as f32 / cells as f32;
                let t = j as f32 / cells as f32;
                let d = (normal + a * (2.0 * s - 1.0) + b * (2.0 * t - 1.0)).normalize();
                positions.push(d * (1.0 + displacement(d)));
                uvs.push(Vec2::new(s, t));
            }
        }
        for j in 0..cells {
            for i in 0..cells {
                let v = |i: usize, j: usize| base + (j * n + i) as u32;
                triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
    }
    let mut mesh = Mesh {
        positions,
        normals: None,
        uvs: Some(uvs),
        triangles,
    };
    mesh.compute_vertex_normals();
    mesh
}

pub fn displacement(d: Vec3) -> f32 {
    let mut sum = 0.0;
    let mut freq = 3.0;
    let mut amp = 0.08;
    for k in 0..5 {
        let phase = k as f32 * 1.7;
        sum += amp
            * (freq * d.x + phase).sin()
            * (freq * 1.3 * d.y + 2.0 * phase).sin()
            * (freq * 0.7 * d.z - phase).sin();
        freq *= 2.1;
        amp *= 0.45;
    }
    sum
}
