//! Small hand-built scenes for the renderer's tests: meshes, a rig at one
//! position, materials; independent of the procedural scene generators.

#![allow(dead_code)]

use glam::{DVec3, Vec2, Vec3};
use matscan_bsdf::material::Material;
use matscan_scan::camera::{look_at, Intrinsics};
use matscan_scan::{Mesh, Pattern};
use matscan_sim::scene::{
    Backlight, EnvSource, EnvSpec, MaterialField, PointLight, Projector, Rig, RigPosition, Scene,
};

pub fn intrinsics(size: u32, fov_scale: f64, distortion: [f64; 5]) -> Intrinsics {
    Intrinsics {
        width: size,
        height: size,
        fx: size as f64 * fov_scale,
        fy: size as f64 * fov_scale,
        cx: size as f64 / 2.0,
        cy: size as f64 / 2.0,
        distortion,
    }
}

/// A closed UV sphere, counter-clockwise seen from outside, with normals.
pub fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push(center + n * radius);
            normals.push(n);
            uvs.push(Vec2::new(
                s as f32 / segments as f32,
                1.0 - r as f32 / rings as f32,
            ));
        }
    }
    let mut triangles = Vec::new();
    let row = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let a = r * row + s;
            let b = a + row;
            if r != 0 {
                triangles.push([a, a + 1, b]);
            }
            if r != rings - 1 {
                triangles.push([a + 1, b + 1, b]);
            }
        }
    }
    let mut mesh = Mesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        triangles,
    };
    fix_winding(&mut mesh, center);
    mesh
}

/// Makes every triangle face away from `inside` (convex meshes only).
fn fix_winding(mesh: &mut Mesh, inside: Vec3) {
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.triangle_vertices(t as u32);
        let n = (b - a).cross(c - a);
        if n.dot((a + b + c) / 3.0 - inside) < 0.0 {
            mesh.triangles[t].swap(1, 2);
        }
    }
}

/// An axis-aligned box, closed, facing outward.
pub fn cuboid(center: Vec3, half: Vec3) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..8 {
        let s = Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        positions.push(center + s * half);
    }
    let faces = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let mut triangles = Vec::new();
    for f in faces {
        triangles.push([f[0], f[1], f[2]]);
        triangles.push([f[0], f[2], f[3]]);
    }
    let mut mesh = Mesh {
        positions,
        normals: None,
        uvs: None,
        triangles,
    };
    fix_winding(&mut mesh, center);
    mesh
}

/// A one-sided rectangle (two triangles) facing `normal_side`.
pub fn quad(center: Vec3, half_u: Vec3, half_v: Vec3, facing: Vec3) -> Mesh {
    let positions = vec![
        center - half_u - half_v,
        center + half_u - half_v,
        center + half_u + half_v,
        center - half_u + half_v,
    ];
    let mut triangles = vec![[0, 1, 2], [0, 2, 3]];
    if (half_u).cross(half_v).dot(facing) < 0.0 {
        triangles = vec![[0, 2, 1], [0, 3, 2]];
    }
    Mesh {
        positions,
        normals: None,
        uvs: Some(vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]),
        triangles,
    }
}

pub fn merge(meshes: &[Mesh]) -> Mesh {
    let mut out = Mesh::default();
    let mut uvs = Vec::new();
    let mut normals = Vec::new();
    let all_normals = meshes.iter().all(|m| m.normals.is_some());
    for m in meshes {
        let base = out.positions.len() as u32;
        out.positions.extend(&m.positions);
        out.triangles
            .extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
        match &m.uvs {
            Some(u) => uvs.extend(u),
            None => uvs.extend(std::iter::repeat_n(Vec2::ZERO, m.positions.len())),
        }
        if let Some(n) = &m.normals {
            normals.extend(n);
        }
    }
    out.uvs = Some(uvs);
    out.normals = all_normals.then_some(normals);
    out
}

pub fn no_env() -> EnvSpec {
    EnvSpec {
        source: EnvSource::None,
        strength: 1.0,
        rotation: 0.0,
    }
}

/// A backlight of zero size: the rig without a panel.
pub fn no_panel() -> Backlight {
    Backlight {
        name: "backlight".into(),
        center: Vec3::new(0.0, 0.0, 10.0),
        half_u: Vec3::ZERO,
        half_v: Vec3::ZERO,
        radiance: Vec3::ZERO,
        albedo: 0.85,
    }
}

pub fn panel_at(center: Vec3, half: f32, radiance: f32) -> Backlight {
    Backlight {
        name: "backlight".into(),
        center,
        half_u: Vec3::new(half, 0.0, 0.0),
        half_v: Vec3::new(0.0, half, 0.0),
        radiance: Vec3::splat(radiance),
        albedo: 0.85,
    }
}

pub fn flash(name: &str, position: Vec3, intensity: f32) -> PointLight {
    PointLight {
        name: name.into(),
        position,
        color: Vec3::ONE,
        intensity,
    }
}

/// A projector at `eye` looking at the origin.
pub fn projector(eye: DVec3, size: u32, f: f64, intensity: f32) -> Projector {
    Projector {
        name: "projector".into(),
        projector_to_world: look_at(eye, DVec3::ZERO, DVec3::Y),
        intrinsics: Intrinsics {
            width: size,
            height: size,
            fx: f,
            fy: f,
            cx: size as f64 / 2.0,
            cy: size as f64 / 2.0,
            distortion: [0.0; 5],
        },
        color: Vec3::ONE,
        intensity,
    }
}

/// One position: camera at `eye` looking at the origin, +Y up.
pub fn position(
    eye: DVec3,
    flashes: Vec<PointLight>,
    projector: Projector,
    backlight: Backlight,
) -> RigPosition {
    RigPosition {
        name: "p0".into(),
        camera_to_world: look_at(eye, DVec3::ZERO, DVec3::Y),
        flashes,
        projector,
        backlight,
        exposure_s: 1.0,
    }
}

pub fn scene(
    mesh: Mesh,
    material: &Material,
    environment: EnvSpec,
    intrinsics: Intrinsics,
    positions: Vec<RigPosition>,
) -> Scene {
    Scene {
        name: "test".into(),
        kind: "test".into(),
        geometry: "mesh".into(),
        mesh,
        material: MaterialField::uniform(material),
        environment,
        rig: Rig {
            intrinsics,
            positions,
        },
    }
}

pub fn diffuse(albedo: f32) -> Material {
    Material {
        basecolor: Vec3::splat(albedo),
        roughness: 1.0,
        metallic: 0.0,
        transmission: 0.0,
        subsurface: 0.0,
        subsurface_radius: Vec3::ONE,
    }
}

pub fn checker(period_px: f64) -> Pattern {
    Pattern::Checker {
        period_px,
        phase_px: [0.0, 0.0],
        low: 0.0,
        high: 1.0,
    }
}
