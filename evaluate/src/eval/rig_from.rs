//! A scan estimated with a calibrated rig file in place of the rig its
//! manifest gives (`matscan eval --rig-from`): the end-to-end test of rig
//! calibration, where a simulated scan's true rig is swapped for the one
//! recovered from simulated calibration photos of it, so that each
//! parameter's MAD shows what the calibration's errors cost. The swap is
//! [`matscan_scan::Manifest::adopt_rig`].

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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DVec3};
    use matscan_scan::{Intrinsics, Light, LightKind, Manifest, Position};

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
        scan.adopt_rig(&rig, Path::new("rig.toml")).unwrap();
        assert_eq!(scan.camera.width, 256);
        assert!((scan.camera.fx - 256.0).abs() < 1e-9);
        assert_eq!(
            scan.positions[0].camera_to_world,
            rig.positions[0].camera_to_world
        );
        assert_eq!(scan.positions[0].lights, rig.positions[0].lights);
        let mut other = rig.clone();
        other.positions[0].name = "p1".into();
        let before = scan.clone();
        let e = scan
            .adopt_rig(&other, Path::new("rig.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("p0") && e.contains("rig.toml"), "{e}");
        assert_eq!(scan, before, "unchanged on an error");
        assert_eq!(
            rig_file_for(Path::new("/no/such/rig.toml"), Path::new("/d/scene-1")),
            PathBuf::from("/no/such/rig.toml")
        );
    }
}
