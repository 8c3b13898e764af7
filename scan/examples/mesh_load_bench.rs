//! Mesh loading benchmark: builds the ~524k-triangle displaced cube-sphere
//! of `raycast_bench` (with uvs and normals), writes it once as binary PLY
//! (`write_mesh`), ASCII PLY (by hand, below: the writer only does binary)
//! and OBJ (`write_mesh`), then times `read_mesh` on each: median of 5 runs,
//! wall time and this thread's on-CPU time, and whether the read gave back
//! the mesh exactly.
//!
//! Run: `cargo run --release -p matscan-scan --example mesh_load_bench`.
//! The figures go into the `//!` doc of `scan/src/mesh_io.rs`.

use matscan_scan::mesh_io::{read_mesh, write_mesh};
use matscan_scan::Mesh;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

mod bench_common;

use bench_common::{displaced_cube_sphere, median_pair, ms, Clock};

fn main() {
    let cells = 209; // 6 faces x 209^2 quads x 2 = 524 172 triangles
    let mesh = displaced_cube_sphere(cells);
    println!(
        "mesh: {} triangles, {} vertices, normals and uvs",
        mesh.triangle_count(),
        mesh.positions.len()
    );
    let dir = std::env::temp_dir().join(format!("matscan-mesh-load-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let binary = dir.join("binary.ply");
    let ascii = dir.join("ascii.ply");
    let obj = dir.join("mesh.obj");
    write_mesh(&binary, &mesh).expect("write binary PLY");
    std::fs::write(&ascii, ascii_ply(&mesh)).expect("write ASCII PLY");
    write_mesh(&obj, &mesh).expect("write OBJ");

    println!(
        "{:<18} {:>9} {:>16} {:>16}  read back",
        "format", "size MB", "read ms (wall)", "read ms (CPU)"
    );
    for (name, path) in [
        ("binary LE PLY", &binary),
        ("ASCII PLY", &ascii),
        ("OBJ", &obj),
    ] {
        let mut verdict = String::new();
        let (wall, cpu) = median_pair(|| time_read(path, &mesh, &mut verdict));
        let size = std::fs::metadata(path).map_or(0, |m| m.len());
        println!(
            "{name:<18} {:>9.1} {:>16.0} {:>16.0}  {verdict}",
            size as f64 / 1e6,
            ms(wall),
            ms(cpu)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Times one read and says in `verdict` whether it gave back `mesh`.
fn time_read(path: &Path, mesh: &Mesh, verdict: &mut String) -> (Duration, Duration) {
    let clock = Clock::start();
    let read = read_mesh(path);
    let times = clock.stop();
    *verdict = match read {
        Ok(read) if read == *mesh => "exact".to_string(),
        Ok(read) => format!(
            "DIFFERS ({} vertices, {} triangles)",
            read.positions.len(),
            read.triangles.len()
        ),
        Err(e) => format!("ERROR: {e}"),
    };
    times
}

/// ASCII PLY with the binary writer's layout: `x y z nx ny nz s t` floats
/// and `list uchar uint vertex_indices`; `{}` prints the shortest decimal
/// that reads back to the same f32.
fn ascii_ply(mesh: &Mesh) -> String {
    let normals = mesh.normals.as_ref().expect("bench mesh has normals");
    let uvs = mesh.uvs.as_ref().expect("bench mesh has uvs");
    let mut s = String::with_capacity(mesh.positions.len() * 100 + mesh.triangles.len() * 24);
    let _ = write!(
        s,
        "ply\nformat ascii 1.0\ncomment mesh_load_bench\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float s\nproperty float t\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    for ((p, n), t) in mesh.positions.iter().zip(normals).zip(uvs) {
        let _ = writeln!(
            s,
            "{} {} {} {} {} {} {} {}",
            p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y
        );
    }
    for [a, b, c] in &mesh.triangles {
        let _ = writeln!(s, "3 {a} {b} {c}");
    }
    s
}
