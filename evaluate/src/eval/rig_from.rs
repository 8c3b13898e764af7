//! A scan estimated with a calibrated rig file in place of the rig its
//! manifest gives (`matscan eval --rig-from`): the end-to-end test of rig
//! calibration, where a simulated scan's true rig is swapped for the one
//! recovered from simulated calibration photos of it, so that each
//! parameter's MAD shows what the calibration's errors cost.

use matscan_scan::Manifest;
use std::path::{Path, PathBuf};

/// The rig file for `scan` under `rig_from`: the file itself, or (a
/// folder) `rig_from/<scan folder name>/rig.toml`, as `matscan calib rig
/// --out rig_from/<scan folder name>` writes it.
pub fn rig_file_for(rig_from: &Path, scan: &Path) -> PathBuf {
    if rig_from.is_dir() {
        let name = scan.file_name().unwrap_or(scan.as_os_str());
        rig_from.join(name).join("rig.toml")
    } else {
        rig_from.to_path_buf()
    }
}

/// `manifest` with the camera (scaled to the scan's photo size), each
/// position's pose and each light's placement, colour and intensity taken
/// from `rig` by name; an error names a position or light the rig file
/// lacks.
pub fn apply_rig(manifest: &mut Manifest, rig: &Manifest) -> Result<(), String> {
    manifest.camera = rig
        .camera
        .scaled_to(manifest.camera.width, manifest.camera.height);
    for position in &mut manifest.positions {
        let from = rig
            .positions
            .iter()
            .find(|p| p.name == position.name)
            .ok_or_else(|| format!("the rig file has no position `{}`", position.name))?;
        position.camera_to_world = from.camera_to_world;
        for light in &mut position.lights {
            let l = from
                .lights
                .iter()
                .find(|l| l.name == light.name)
                .ok_or_else(|| {
                    format!(
                        "the rig file has no light `{}` at position `{}`",
                        light.name, position.name
                    )
                })?;
            light.kind = l.kind.clone();
            light.color = l.color;
            light.intensity = l.intensity;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DVec3};
    use matscan_scan::{Intrinsics, Light, LightKind, Position};

    fn manifest(size: u32, x: f64, intensity: f64) -> Manifest {
        Manifest {
            units: "m".into(),
            name: "rig".into(),
            created: String::new(),
            camera: Intrinsics {
                width: size,
                height: size,
                fx: size as f64,
                fy: size as f64,
                cx: size as f64 / 2.0,
                cy: size as f64 / 2.0,
                distortion: [0.0; 5],
            },
            positions: vec![Position {
                name: "p0".into(),
                camera_to_world: DMat4::from_translation(DVec3::new(x, 0.0, -1.5)),
                lights: vec![Light {
                    name: "flash0".into(),
                    kind: LightKind::Point {
                        position: DVec3::new(x, 0.0, -1.5),
                    },
                    color: [1.0; 3],
                    intensity: Some(intensity),
                }],
                captures: Vec::new(),
                white_reference_mask: None,
            }],
        }
    }

    #[test]
    fn a_rig_file_replaces_the_camera_poses_and_lights_at_the_scans_size() {
        let mut scan = manifest(256, 0.0, 10.0);
        let rig = manifest(1024, 0.001, 10.2);
        apply_rig(&mut scan, &rig).unwrap();
        assert_eq!(scan.camera.width, 256);
        assert!((scan.camera.fx - 256.0).abs() < 1e-9);
        assert_eq!(
            scan.positions[0].camera_to_world,
            rig.positions[0].camera_to_world
        );
        assert_eq!(scan.positions[0].lights, rig.positions[0].lights);
        let mut other = rig.clone();
        other.positions[0].name = "p1".into();
        let e = apply_rig(&mut scan, &other).unwrap_err();
        assert!(e.contains("p0"), "{e}");
        assert_eq!(
            rig_file_for(Path::new("/no/such/rig.toml"), Path::new("/d/scene-1")),
            PathBuf::from("/no/such/rig.toml")
        );
    }
}
