//! A deliberately wrong rig: the scan's calibration changed by a known
//! amount before it is estimated (`matscan eval --rig-error`), so the error
//! each parameter's MAD takes from it measures what precision the
//! estimator needs from a rig calibration.
//!
//! Light intensities are among them: the physical fit reads each light's
//! `intensity` from the manifest (`intensity x cos / d^2`), so a wrong
//! intensity scales every radiance it measures; the networks read the white
//! reference photographed in the scan instead.

use glam::{DMat4, DVec3};
use matscan_scan::{LightKind, Manifest};
use std::fmt;
use std::str::FromStr;

/// One calibration error, applied alike at every position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RigError {
    /// fx and fy scaled by 1 + percent / 100.
    FocalPercent(f64),
    /// The camera moved this many millimetres along its own x axis.
    CameraShiftMm(f64),
    /// The camera turned this many degrees about its own y axis.
    CameraTurnDeg(f64),
    /// Every point light moved this many millimetres along the camera's x
    /// axis.
    LightShiftMm(f64),
    /// Every light's intensity (flashes, projector, backlight) scaled by
    /// 1 + percent / 100.
    IntensityPercent(f64),
}

impl RigError {
    /// Changes `manifest` (units: metres) by this error.
    pub fn apply(&self, manifest: &mut Manifest) {
        match *self {
            RigError::FocalPercent(p) => {
                manifest.camera.fx *= 1.0 + p / 100.0;
                manifest.camera.fy *= 1.0 + p / 100.0;
            }
            RigError::CameraShiftMm(mm) => {
                for p in &mut manifest.positions {
                    p.camera_to_world *= DMat4::from_translation(DVec3::X * mm / 1000.0);
                }
            }
            RigError::CameraTurnDeg(deg) => {
                for p in &mut manifest.positions {
                    p.camera_to_world *= DMat4::from_rotation_y(deg.to_radians());
                }
            }
            RigError::LightShiftMm(mm) => {
                for p in &mut manifest.positions {
                    let shift = p.camera_to_world.transform_vector3(DVec3::X) * mm / 1000.0;
                    for l in &mut p.lights {
                        if let LightKind::Point { position } = &mut l.kind {
                            *position += shift;
                        }
                    }
                }
            }
            RigError::IntensityPercent(p) => {
                for l in manifest.positions.iter_mut().flat_map(|p| &mut p.lights) {
                    if let Some(i) = &mut l.intensity {
                        *i *= 1.0 + p / 100.0;
                    }
                }
            }
        }
    }
}

impl FromStr for RigError {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let expected =
            "expected focal=PERCENT, camera-shift=MM, camera-turn=DEG, light-shift=MM or \
             intensity=PERCENT";
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| format!("{s:?}: {expected}"))?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| format!("{s:?}: {value:?} is not a finite number"))?;
        match key.trim() {
            "focal" => Ok(RigError::FocalPercent(v)),
            "camera-shift" => Ok(RigError::CameraShiftMm(v)),
            "camera-turn" => Ok(RigError::CameraTurnDeg(v)),
            "light-shift" => Ok(RigError::LightShiftMm(v)),
            "intensity" => Ok(RigError::IntensityPercent(v)),
            _ => Err(format!("{s:?}: {expected}")),
        }
    }
}

impl fmt::Display for RigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RigError::FocalPercent(v) => write!(f, "focal={v}"),
            RigError::CameraShiftMm(v) => write!(f, "camera-shift={v}"),
            RigError::CameraTurnDeg(v) => write!(f, "camera-turn={v}"),
            RigError::LightShiftMm(v) => write!(f, "light-shift={v}"),
            RigError::IntensityPercent(v) => write!(f, "intensity={v}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_scan::{Intrinsics, Light, Position};

    fn rig() -> Manifest {
        Manifest {
            units: "m".into(),
            name: "rig".into(),
            created: "2026-12-05T00:00:00Z".into(),
            camera: Intrinsics {
                width: 256,
                height: 256,
                fx: 400.0,
                fy: 400.0,
                cx: 128.0,
                cy: 128.0,
                distortion: [0.0; 5],
            },
            positions: vec![Position {
                name: "p0".into(),
                camera_to_world: DMat4::from_rotation_y(0.5)
                    * DMat4::from_translation(DVec3::new(0.0, 0.0, -1.5)),
                lights: vec![Light {
                    name: "flash0".into(),
                    kind: LightKind::Point {
                        position: DVec3::new(0.1, 0.0, -1.5),
                    },
                    color: [1.0; 3],
                    intensity: Some(10.0),
                }],
                captures: Vec::new(),
                white_reference_mask: None,
            }],
        }
    }

    #[test]
    fn each_error_changes_its_quantity_by_the_amount_given() {
        let before = rig();
        let mut m = before.clone();
        "focal=0.5".parse::<RigError>().unwrap().apply(&mut m);
        assert!((m.camera.fx - 402.0).abs() < 1e-9);
        let mut m = before.clone();
        RigError::CameraShiftMm(2.0).apply(&mut m);
        let moved =
            m.positions[0].camera_to_world.w_axis - before.positions[0].camera_to_world.w_axis;
        assert!((moved.truncate().length() - 0.002).abs() < 1e-12);
        let mut m = before.clone();
        RigError::CameraTurnDeg(0.1).apply(&mut m);
        let (_, a, _) = m.positions[0]
            .camera_to_world
            .to_scale_rotation_translation();
        let (_, b, _) = before.positions[0]
            .camera_to_world
            .to_scale_rotation_translation();
        assert!((a.angle_between(b).to_degrees() - 0.1).abs() < 1e-6);
        let mut m = before.clone();
        RigError::LightShiftMm(10.0).apply(&mut m);
        let (LightKind::Point { position: p }, LightKind::Point { position: q }) = (
            &m.positions[0].lights[0].kind,
            &before.positions[0].lights[0].kind,
        ) else {
            panic!("point lights");
        };
        assert!(((*p - *q).length() - 0.01).abs() < 1e-12);
        let mut m = before.clone();
        "intensity=-2".parse::<RigError>().unwrap().apply(&mut m);
        let i = m.positions[0].lights[0].intensity.unwrap();
        assert!((i - 9.8).abs() < 1e-12, "{i}");
    }

    #[test]
    fn a_malformed_error_is_named() {
        for bad in ["focal", "focal=x", "zoom=2", "focal=inf"] {
            let e = bad.parse::<RigError>().unwrap_err();
            assert!(e.contains(bad), "{e}");
        }
        assert_eq!(
            "light-shift=5".parse::<RigError>().unwrap().to_string(),
            "light-shift=5"
        );
    }
}
