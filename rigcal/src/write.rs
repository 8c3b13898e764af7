//! Publishing a calibration: the rig file the daemon reads (`rig.toml`, a
//! scan manifest without captures) and `calib-report.toml`, each written
//! atomically. A refused calibration writes its report only, so a rig file
//! on disk is always one that passed.

use crate::camera::{CameraCalibration, CameraReport};
use crate::error::RigcalError;
use crate::projector::{ProjectorCalibration, ProjectorReport};
use matscan_scan::atomic::write_atomic;
use matscan_scan::{Light, LightKind, Manifest, Position};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// File names inside the output folder.
pub const RIG_FILE: &str = "rig.toml";
pub const REPORT_FILE: &str = "calib-report.toml";

/// The report file: the camera's figures and what the rig file lacks.
#[derive(Debug, Serialize)]
struct ReportFile<'a> {
    format: &'static str,
    /// What the rig file does not hold from this calibration: lights kept
    /// from another file are named with it, lights neither measured nor
    /// kept are missing.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    missing: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lights_from: Option<PathBuf>,
    camera: &'a CameraReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    projector: Option<&'a ProjectorReport>,
}

/// The rig file for `calibration`: the measured camera and poses, and the
/// measured projector where there is one; each position's other lights
/// from `lights_from` (a rig file whose positions have the same names), or
/// none. The projector keeps its colour and intensity from `lights_from`.
pub fn rig_manifest(
    calibration: &CameraCalibration,
    projector: Option<&ProjectorCalibration>,
    lights_from: Option<&Manifest>,
    name: &str,
) -> Manifest {
    Manifest {
        units: "m".into(),
        name: name.into(),
        created: matscan_scan::time::rfc3339_now(),
        camera: calibration.camera,
        positions: calibration
            .camera_to_world
            .iter()
            .enumerate()
            .map(|(k, (position, camera_to_world))| {
                let mut lights: Vec<Light> = lights_from
                    .and_then(|m| m.position(position))
                    .map(|p| p.lights.clone())
                    .unwrap_or_default();
                if let Some(pc) = projector {
                    let measured = LightKind::Projector {
                        projector_to_world: pc.projector_to_world[k].1,
                        intrinsics: pc.intrinsics,
                    };
                    match lights
                        .iter_mut()
                        .find(|l| matches!(l.kind, LightKind::Projector { .. }))
                    {
                        Some(light) => light.kind = measured,
                        None => lights.push(Light {
                            name: "projector".into(),
                            kind: measured,
                            color: [1.0; 3],
                            intensity: None,
                        }),
                    }
                }
                Position {
                    name: position.clone(),
                    camera_to_world: *camera_to_world,
                    lights,
                    captures: Vec::new(),
                    white_reference_mask: None,
                }
            })
            .collect(),
    }
}

/// A rig file written: where, and what it holds (so the next step needs
/// not read it back).
#[derive(Debug, Clone, PartialEq)]
pub struct WrittenRig {
    pub path: PathBuf,
    pub rig: Manifest,
}

/// Writes the report and, when the calibration was accepted, the rig file
/// into `out_dir`; returns the rig file, or `None` when refused.
pub fn write_calibration(
    out_dir: &Path,
    calibration: &CameraCalibration,
    projector: Option<&ProjectorCalibration>,
    lights_from: Option<(&Path, &Manifest)>,
) -> Result<Option<WrittenRig>, RigcalError> {
    std::fs::create_dir_all(out_dir).map_err(|e| {
        RigcalError::Scan(matscan_scan::ScanError::Io {
            path: out_dir.to_path_buf(),
            source: e,
        })
    })?;
    let mut missing = Vec::new();
    if lights_from.is_none() {
        missing.push("lights".to_string());
    }
    if projector.is_none() {
        missing.push("projector".to_string());
    }
    let report = ReportFile {
        format: "matscan-calib-report/1",
        missing,
        lights_from: lights_from.map(|(p, _)| p.to_path_buf()),
        camera: &calibration.report,
        projector: projector.map(|p| &p.report),
    };
    let text = toml::to_string(&report).unwrap_or_default();
    write_atomic(&out_dir.join(REPORT_FILE), text.as_bytes())?;
    if !calibration.report.accepted {
        return Ok(None);
    }
    let rig = rig_manifest(
        calibration,
        projector,
        lights_from.map(|(_, m)| m),
        "rig calibrated from photos",
    );
    let path = out_dir.join(RIG_FILE);
    write_atomic(&path, rig.to_toml().as_bytes())?;
    Ok(Some(WrittenRig { path, rig }))
}

/// The light calibration's report file.
pub const LIGHTS_REPORT_FILE: &str = "lights-report.toml";

/// Writes `rig` with its flashes where `lights` found them as `rig.toml`
/// in `out_dir`, and `lights-report.toml` beside it (each atomically);
/// `rig_path` names the rig file it came from. Returns the rig file.
pub fn write_lights(
    out_dir: &Path,
    rig: &Manifest,
    lights: &crate::lights::LightCalibration,
    rig_path: &Path,
) -> Result<WrittenRig, RigcalError> {
    #[derive(serde::Serialize)]
    struct Flash {
        name: String,
        /// Camera frame, bundle units.
        position: [f64; 3],
        rays: usize,
        ray_rms: f64,
        spread_deg: f64,
    }
    #[derive(serde::Serialize)]
    struct Sphere {
        folder: PathBuf,
        centre: [f64; 3],
        radius_px: f64,
        edge_points: usize,
        edge_rms_px: f64,
        /// `projector`: moved to where the projector's highlight puts it;
        /// `outline`: the silhouette's.
        centred_by: &'static str,
    }
    #[derive(serde::Serialize)]
    struct Report {
        format: &'static str,
        rig_from: PathBuf,
        flash: Vec<Flash>,
        sphere: Vec<Sphere>,
    }
    let report = Report {
        format: "matscan-lights-report/1",
        rig_from: rig_path.to_path_buf(),
        flash: lights
            .flashes
            .iter()
            .map(|f| Flash {
                name: f.name.clone(),
                position: f.position.to_array(),
                rays: f.rays,
                ray_rms: f.ray_rms,
                spread_deg: f.spread_deg,
            })
            .collect(),
        sphere: lights
            .spheres
            .iter()
            .map(|(folder, s)| Sphere {
                folder: folder.clone(),
                centre: s.centre.to_array(),
                radius_px: s.radius_px,
                edge_points: s.edge_points,
                edge_rms_px: s.edge_rms_px,
                centred_by: if s.centred_by_projector {
                    "projector"
                } else {
                    "outline"
                },
            })
            .collect(),
    };
    let moved = crate::lights::flashes_in_world(rig, lights);
    publish(out_dir, LIGHTS_REPORT_FILE, &report, moved)
}

/// Writes `report` as `out_dir/report_file` and `rig` as `out_dir/rig.toml`
/// (each atomically, the folder made if missing); returns the rig file.
fn publish(
    out_dir: &Path,
    report_file: &str,
    report: &impl Serialize,
    rig: Manifest,
) -> Result<WrittenRig, RigcalError> {
    std::fs::create_dir_all(out_dir).map_err(|e| {
        RigcalError::Scan(matscan_scan::ScanError::Io {
            path: out_dir.to_path_buf(),
            source: e,
        })
    })?;
    // Plain data with string keys: serializing cannot fail.
    let text = toml::to_string(report).unwrap_or_default();
    write_atomic(&out_dir.join(report_file), text.as_bytes())?;
    let path = out_dir.join(RIG_FILE);
    write_atomic(&path, rig.to_toml().as_bytes())?;
    Ok(WrittenRig { path, rig })
}

/// The radiometric calibration's report file in the output folder.
pub const WHITE_REPORT_FILE: &str = "white-report.toml";

/// Writes `rig` with every light's intensity and colour from `radiometry`
/// as `out_dir/rig.toml`, and `white-report.toml` beside it (each light's
/// figures and the linearity readings, and the rig file it started from).
/// Returns the rig file.
pub fn write_radiometry(
    out_dir: &Path,
    rig: &Manifest,
    radiometry: &crate::radiometry::Radiometry,
    rig_path: &Path,
) -> Result<WrittenRig, RigcalError> {
    #[derive(serde::Serialize)]
    struct Level {
        name: String,
        intensity: f64,
        color: [f64; 3],
        pixels: usize,
        spread: f64,
        file: PathBuf,
    }
    #[derive(serde::Serialize)]
    struct Linearity {
        light: String,
        /// Each exposure, seconds.
        exposure_s: Vec<f64>,
        /// The value per second of exposure at each, over their median.
        relative: Vec<f64>,
    }
    #[derive(serde::Serialize)]
    struct Report {
        format: &'static str,
        rig_from: PathBuf,
        light: Vec<Level>,
        linearity: Vec<Linearity>,
    }
    let report = Report {
        format: "matscan-white-report/1",
        rig_from: rig_path.to_path_buf(),
        light: radiometry
            .lights
            .iter()
            .map(|l| Level {
                name: l.name.clone(),
                intensity: l.intensity,
                color: l.color,
                pixels: l.pixels,
                spread: l.spread,
                file: l.file.clone(),
            })
            .collect(),
        linearity: radiometry
            .linearity
            .iter()
            .map(|l| Linearity {
                light: l.light.clone(),
                exposure_s: l.readings.iter().map(|r| r.0).collect(),
                relative: l.readings.iter().map(|r| r.1).collect(),
            })
            .collect(),
    };
    let measured = crate::radiometry::intensities_in_rig(rig, radiometry);
    publish(out_dir, WHITE_REPORT_FILE, &report, measured)
}
