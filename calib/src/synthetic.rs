//! Analytic scenes and rigs built in code, for tests and benchmarks here and
//! downstream: a finely tessellated sphere with exact normals, a flat quad
//! (exact with two triangles), a displaced blob, and builders for rig
//! lights, captures, positions and manifests.
//!
//! Boundaries: constructs plain `matscan-scan` values only; nothing here is
//! used by calibration itself.

use glam::{DMat4, DVec3, Vec2, Vec3};
use matscan_scan::{Capture, Intrinsics, Light, LightKind, Manifest, Mesh, Pattern, Position};
use std::collections::HashMap;
use std::path::PathBuf;

/// An icosphere: the icosahedron subdivided `subdivisions` times (20 * 4^s
/// triangles), vertices on the sphere, vertex normals exactly radial. Since
/// every hit point of a triangle is an affine mix of its vertices, the
/// interpolated normal there is exactly the radial direction of the hit.
pub fn icosphere(center: Vec3, radius: f32, subdivisions: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut dirs: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| Vec3::from_array(v).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, dirs: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                dirs.push((dirs[a as usize] + dirs[b as usize]).normalize());
                (dirs.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = mid(a, b, &mut dirs);
            let bc = mid(b, c, &mut dirs);
            let ca = mid(c, a, &mut dirs);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let uvs = dirs
        .iter()
        .map(|d| {
            Vec2::new(
                0.5 + d.z.atan2(d.x) / std::f32::consts::TAU,
                0.5 + d.y.asin() / std::f32::consts::PI,
            )
        })
        .collect();
    Mesh {
        positions: dirs.iter().map(|&d| center + d * radius).collect(),
        normals: Some(dirs),
        uvs: Some(uvs),
        triangles: tris,
    }
}

/// A flat quad of two triangles with corners `origin`, `origin + u`,
/// `origin + u + v`, `origin + v`; its normal is `u x v`, UVs span 0..1.
pub fn quad(origin: Vec3, u: Vec3, v: Vec3) -> Mesh {
    let n = u.cross(v).normalize();
    Mesh {
        positions: vec![origin, origin + u, origin + u + v, origin + v],
        normals: Some(vec![n; 4]),
        uvs: Some(vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// An icosphere whose radius varies smoothly with direction by up to
/// `amplitude` (relative): a bumpy, self-shadowing blob. Vertex normals are
/// recomputed from the displaced triangles.
pub fn blob(center: Vec3, radius: f32, amplitude: f32, subdivisions: u32) -> Mesh {
    let mut mesh = icosphere(Vec3::ZERO, 1.0, subdivisions);
    for p in &mut mesh.positions {
        let d = *p;
        let bump = (5.0 * d.x).sin() * (4.0 * d.y).cos() + 0.5 * (7.0 * d.z + 1.0).sin();
        *p = center + d * radius * (1.0 + amplitude * bump);
    }
    mesh.compute_vertex_normals();
    mesh
}

/// Concatenates meshes; UVs are kept only when every part has them.
pub fn merge(parts: &[Mesh]) -> Mesh {
    let mut out = Mesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Mesh::default()
    };
    for m in parts {
        let base = out.positions.len() as u32;
        out.positions.extend(&m.positions);
        match (&mut out.normals, &m.normals) {
            (Some(n), Some(mn)) => n.extend(mn),
            (Some(n), None) => n.extend(std::iter::repeat_n(Vec3::ZERO, m.positions.len())),
            _ => {}
        }
        match (&mut out.uvs, &m.uvs) {
            (Some(t), Some(mt)) => t.extend(mt),
            _ => out.uvs = None,
        }
        out.triangles
            .extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

/// A square camera of `size` pixels with the given horizontal field of
/// view, principal point at the image centre, no distortion.
pub fn intrinsics(size: u32, fov_deg: f64) -> Intrinsics {
    let f = f64::from(size) / 2.0 / (fov_deg.to_radians() / 2.0).tan();
    Intrinsics {
        width: size,
        height: size,
        fx: f,
        fy: f,
        cx: f64::from(size) / 2.0,
        cy: f64::from(size) / 2.0,
        distortion: [0.0; 5],
    }
}

pub fn point_light(name: &str, position: DVec3) -> Light {
    Light {
        name: name.to_string(),
        kind: LightKind::Point { position },
        color: [1.0; 3],
        intensity: None,
    }
}

pub fn projector(name: &str, projector_to_world: DMat4, intrinsics: Intrinsics) -> Light {
    Light {
        name: name.to_string(),
        kind: LightKind::Projector {
            projector_to_world,
            intrinsics,
        },
        color: [1.0; 3],
        intensity: None,
    }
}

pub fn backlight(name: &str) -> Light {
    Light {
        name: name.to_string(),
        kind: LightKind::Backlight,
        color: [1.0; 3],
        intensity: None,
    }
}

/// A capture of `position` with the given lights on, exposure 1/50 s.
pub fn capture(position: &str, name: &str, lights: &[&str], pattern: Option<Pattern>) -> Capture {
    Capture {
        name: name.to_string(),
        file: PathBuf::from(format!("views/{position}/{name}.exr")),
        exposure_s: 0.02,
        lights: lights.iter().map(|s| s.to_string()).collect(),
        pattern,
        encoding: None,
    }
}

/// The thesis's rig at one position: flash0 at the camera, flash1 beside
/// it, a projector between them, the backlight, and the seven captures
/// (ambient, three lit, backlit, two checkers).
pub fn thesis_rig(name: &str, camera_to_world: DMat4) -> Position {
    let at = |x: f64, y: f64| camera_to_world.transform_point3(DVec3::new(x, y, 0.0));
    let proj_pose = camera_to_world * DMat4::from_translation(DVec3::new(0.15, 0.0, 0.0));
    let proj = Intrinsics {
        width: 1280,
        height: 800,
        fx: 1500.0,
        fy: 1500.0,
        cx: 640.0,
        cy: 400.0,
        distortion: [0.0; 5],
    };
    let checker = |period_px| Pattern::Checker {
        period_px,
        phase_px: [0.0, 0.0],
        low: 0.0,
        high: 1.0,
    };
    Position {
        name: name.to_string(),
        camera_to_world,
        lights: vec![
            point_light("flash0", at(0.0, 0.0)),
            point_light("flash1", at(0.3, 0.0)),
            projector("projector", proj_pose, proj),
            backlight("backlight"),
        ],
        captures: vec![
            capture(name, "ambient", &[], None),
            capture(name, "flash0", &["flash0"], None),
            capture(name, "flash1", &["flash1"], None),
            capture(
                name,
                "projector",
                &["projector"],
                Some(Pattern::Uniform { level: 0.5 }),
            ),
            capture(name, "backlit", &["backlight"], None),
            capture(name, "checker_8", &["projector"], Some(checker(8.0))),
            capture(name, "checker_32", &["projector"], Some(checker(32.0))),
        ],
        white_reference_mask: None,
    }
}

pub fn manifest(camera: Intrinsics, positions: Vec<Position>) -> Manifest {
    Manifest {
        units: "m".to_string(),
        name: "synthetic".to_string(),
        created: "2026-01-01T00:00:00Z".to_string(),
        camera,
        positions,
    }
}
