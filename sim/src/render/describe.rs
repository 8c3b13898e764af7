//! The scene that made a bundle, written beside it for a second renderer:
//! `<bundle>.scene/` with `scene.json`, the mesh, the material maps and the
//! environment as a map (the format is `docs/scene-description.md`,
//! `matscan-scene/1`). `tools/mitsuba/` renders it with Mitsuba 3 into a
//! bundle with the same captures, the stand-in for a real rig.
//!
//! The captures come from the bundle's manifest, so the description lists
//! exactly the photos the bundle holds. The environment is baked from
//! [`Environment::radiance`], rotation and strength applied, at
//! [`ENV_WIDTH`] x [`ENV_HEIGHT`] with 4 x 4 samples per texel, so a small
//! sun keeps its power. Written atomically: a folder under a temporary name,
//! renamed when complete (an old description is replaced).

use super::environment::{uv_to_dir, Environment};
use super::error::SimError;
use super::SimOptions;
use crate::scene::{MaterialField, RigPosition, Scene, Texture};
use glam::{DMat4, Vec2, Vec3};
use matscan_scan::image_io::{write_rgb_exr, write_scalar_exr, Precision};
use matscan_scan::raster::RgbRaster;
use matscan_scan::{mesh_io, Bundle, Pattern, ScanError};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

/// The description format's name and version.
pub const DESCRIPTION_FORMAT: &str = "matscan-scene/1";
/// Size of the baked environment map.
pub const ENV_WIDTH: u32 = 1024;
pub const ENV_HEIGHT: u32 = 512;
const ENV_SUBSAMPLES: u32 = 4;
/// File names inside the description folder.
pub const DESCRIPTION_FILE: &str = "scene.json";
pub const MESH_FILE: &str = "geometry.ply";
pub const ENVIRONMENT_FILE: &str = "environment.exr";

/// Where the description of the bundle at `bundle_dir` goes.
pub fn description_dir(bundle_dir: &Path) -> PathBuf {
    let mut name = bundle_dir
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_else(|| "bundle".into());
    name.push(".scene");
    bundle_dir.with_file_name(name)
}

/// Writes the description of `scene`, whose render is `bundle` (at
/// `bundle_dir`), beside it; returns its folder.
pub fn write_description(
    scene: &Scene,
    sim: &SimOptions,
    bundle: &Bundle,
    bundle_dir: &Path,
) -> Result<PathBuf, SimError> {
    let dir = description_dir(bundle_dir);
    let tmp = dir.with_file_name(format!(
        "{}.tmp-{}",
        dir.file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        std::process::id()
    ));
    let io = |path: &Path, source: std::io::Error| {
        SimError::Scan(ScanError::Io {
            path: path.to_path_buf(),
            source,
        })
    };
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    }
    std::fs::create_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    let written = fill(&tmp, scene, sim, bundle, bundle_dir);
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    if dir.exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| io(&dir, e))?;
    }
    std::fs::rename(&tmp, &dir).map_err(|e| io(&dir, e))?;
    Ok(dir)
}

fn fill(
    dir: &Path,
    scene: &Scene,
    sim: &SimOptions,
    bundle: &Bundle,
    bundle_dir: &Path,
) -> Result<(), SimError> {
    mesh_io::write_ply(&dir.join(MESH_FILE), &scene.mesh)?;
    let material = material_json(dir, &scene.material)?;
    let env = Environment::from_spec(&scene.environment)?;
    let environment = if env.is_off() {
        Value::Null
    } else {
        write_rgb_exr(&dir.join(ENVIRONMENT_FILE), &bake(&env), Precision::Float)?;
        json!({ "map": ENVIRONMENT_FILE, "width": ENV_WIDTH, "height": ENV_HEIGHT })
    };
    let k = &scene.rig.intrinsics;
    let mut positions = Vec::new();
    for rig in &scene.rig.positions {
        let captured = bundle
            .manifest
            .positions
            .iter()
            .find(|p| p.name == rig.name)
            .ok_or_else(|| SimError::Description {
                path: bundle_dir.to_path_buf(),
                message: format!("the bundle has no position `{}`", rig.name),
            })?;
        positions.push(position_json(rig, &captured.captures));
    }
    let bundle_name = bundle_dir
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let doc = json!({
        "format": DESCRIPTION_FORMAT,
        "name": scene.name,
        "kind": scene.kind,
        "geometry": scene.geometry,
        "bundle": format!("../{bundle_name}"),
        "mesh": MESH_FILE,
        "material": material,
        "environment": environment,
        "camera": {
            "width": k.width, "height": k.height,
            "fx": k.fx, "fy": k.fy, "cx": k.cx, "cy": k.cy,
        },
        "render": { "samples": sim.samples, "max_depth": sim.max_depth, "seed": sim.seed },
        "positions": positions,
    });
    let path = dir.join(DESCRIPTION_FILE);
    let text = serde_json::to_string_pretty(&doc).map_err(|e| SimError::Description {
        path: path.clone(),
        message: e.to_string(),
    })?;
    std::fs::write(&path, text + "\n").map_err(|source| {
        SimError::Scan(ScanError::Io {
            path: path.clone(),
            source,
        })
    })?;
    Ok(())
}

/// One material input: `{ "value": v }`, or `{ "map": "<name>.exr" }`
/// with the map written by `write` into `dir`.
fn texture_json<T: Copy + serde::Serialize>(
    dir: &Path,
    name: &str,
    texture: &Texture<T>,
    write: fn(&Path, &matscan_scan::Raster<T>, Precision) -> Result<(), ScanError>,
) -> Result<Value, SimError> {
    Ok(match texture {
        Texture::Constant(v) => json!({ "value": v }),
        Texture::Map(r) => {
            let file = format!("{name}.exr");
            write(&dir.join(&file), r, Precision::Float)?;
            json!({ "map": file })
        }
    })
}

/// The material section; maps become EXR files in `dir`.
fn material_json(dir: &Path, m: &MaterialField) -> Result<Value, SimError> {
    Ok(json!({
        "model": "principled-cycles-2.9x",
        "basecolor": texture_json(dir, "basecolor", &m.basecolor, write_rgb_exr)?,
        "roughness": texture_json(dir, "roughness", &m.roughness, write_scalar_exr)?,
        "metallic": texture_json(dir, "metallic", &m.metallic, write_scalar_exr)?,
        "transmission": texture_json(dir, "transmission", &m.transmission, write_scalar_exr)?,
        "subsurface": texture_json(dir, "subsurface", &m.subsurface, write_scalar_exr)?,
        "subsurface_radius": m.subsurface_radius.to_array(),
        "specular": matscan_bsdf::material::SPECULAR,
        "ior": matscan_bsdf::material::IOR,
    }))
}

fn mat_rows(m: &DMat4) -> Vec<f64> {
    // glam is column-major; the description is row-major.
    let t = m.transpose();
    t.to_cols_array().to_vec()
}

fn rgb_of(color: Vec3, intensity: f32) -> [f32; 3] {
    (color * intensity).to_array()
}

fn position_json(rig: &RigPosition, captures: &[matscan_scan::Capture]) -> Value {
    let flashes: Vec<Value> = rig
        .flashes
        .iter()
        .map(|f| {
            json!({
                "name": f.name,
                "position": f.position.to_array(),
                "intensity": rgb_of(f.color, f.intensity),
            })
        })
        .collect();
    let p = &rig.projector;
    let b = &rig.backlight;
    let captures: Vec<Value> = captures
        .iter()
        .map(|c| {
            let on = |name: &str| c.lights.iter().any(|l| l == name);
            let projector = if on(&p.name) {
                pattern_json(c.pattern.unwrap_or(Pattern::Uniform { level: 1.0 }))
            } else {
                Value::Null
            };
            json!({
                "name": c.name,
                "file": c.file.to_string_lossy(),
                "flashes": rig.flashes.iter().filter(|f| on(&f.name)).map(|f| f.name.clone()).collect::<Vec<_>>(),
                "projector": projector,
                "backlight": on(&b.name),
            })
        })
        .collect();
    json!({
        "name": rig.name,
        "camera_to_world": mat_rows(&rig.camera_to_world),
        "exposure_s": rig.exposure_s,
        "flashes": flashes,
        "projector": {
            "name": p.name,
            "projector_to_world": mat_rows(&p.projector_to_world),
            "width": p.intrinsics.width, "height": p.intrinsics.height,
            "fx": p.intrinsics.fx, "fy": p.intrinsics.fy,
            "cx": p.intrinsics.cx, "cy": p.intrinsics.cy,
            "intensity": rgb_of(p.color, p.intensity),
        },
        "backlight": {
            "name": b.name,
            "center": b.center.to_array(),
            "half_u": b.half_u.to_array(),
            "half_v": b.half_v.to_array(),
            "radiance": b.radiance.to_array(),
            "albedo": b.albedo,
        },
        "captures": captures,
    })
}

fn pattern_json(p: Pattern) -> Value {
    match p {
        Pattern::Uniform { level } => json!({ "kind": "uniform", "level": level }),
        Pattern::Checker {
            period_px,
            phase_px,
            low,
            high,
        } => json!({
            "kind": "checker", "period_px": period_px, "phase_px": phase_px,
            "low": low, "high": high,
        }),
        Pattern::GrayCode {
            axis,
            bit,
            inverted,
        } => json!({
            "kind": "graycode", "axis": axis.name(), "bit": bit, "inverted": inverted,
        }),
    }
}

/// The environment as an equirectangular map in world directions
/// (`uv_to_dir`'s mapping), each texel the mean of a 4 x 4 grid inside it.
pub fn bake(env: &Environment) -> RgbRaster {
    let n = ENV_SUBSAMPLES as f32;
    RgbRaster::from_fn(ENV_WIDTH, ENV_HEIGHT, |x, y| {
        let mut sum = Vec3::ZERO;
        for j in 0..ENV_SUBSAMPLES {
            for i in 0..ENV_SUBSAMPLES {
                let uv = Vec2::new(
                    (x as f32 + (i as f32 + 0.5) / n) / ENV_WIDTH as f32,
                    (y as f32 + (j as f32 + 0.5) / n) / ENV_HEIGHT as f32,
                );
                sum += env.radiance(uv_to_dir(uv).0);
            }
        }
        (sum / (n * n)).to_array()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_description_sits_beside_its_bundle() {
        assert_eq!(
            description_dir(Path::new("/sets/a/scene-7")),
            PathBuf::from("/sets/a/scene-7.scene")
        );
    }

    #[test]
    fn a_uniform_environment_bakes_to_its_radiance_everywhere() {
        let env = Environment::uniform(Vec3::new(0.5, 1.0, 2.0));
        let map = bake(&env);
        assert_eq!((map.width, map.height), (ENV_WIDTH, ENV_HEIGHT));
        assert!(map.data.iter().all(|p| *p == [0.5, 1.0, 2.0]));
    }

    #[test]
    fn the_baked_map_keeps_the_procedural_skys_mean_radiance() {
        // Mean over the sphere (texels weighted by sin theta) of the map
        // against the sky's own mean, estimated on a fine direction grid.
        let env = Environment::procedural(42, 0.7, 1.1);
        let map = bake(&env);
        let mut baked = (Vec3::ZERO, 0.0f32);
        for y in 0..ENV_HEIGHT {
            let w = (std::f32::consts::PI * (y as f32 + 0.5) / ENV_HEIGHT as f32).sin();
            for x in 0..ENV_WIDTH {
                baked.0 += Vec3::from_array(*map.get(x, y)) * w;
                baked.1 += w;
            }
        }
        let mut direct = (Vec3::ZERO, 0.0f32);
        let (w, h) = (4096u32, 2048u32);
        for y in (0..h).step_by(3) {
            for x in (0..w).step_by(3) {
                let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                let (d, s) = uv_to_dir(uv);
                direct.0 += env.radiance(d) * s;
                direct.1 += s;
            }
        }
        let (a, b) = (baked.0 / baked.1, direct.0 / direct.1);
        for c in 0..3 {
            assert!((a[c] / b[c] - 1.0).abs() < 0.02, "channel {c}: {a} vs {b}");
        }
    }
}
