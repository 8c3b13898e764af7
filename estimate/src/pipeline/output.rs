//! The `estimate/` folder: the maps of every position written through
//! `matscan_scan::estimate_maps` (the one reader and writer of them) and
//! `result.toml`, this crate's record of how they were made.
//!
//! The folder is written whole into a hidden sibling and renamed into
//! place, so a reader never sees a half-written estimate; an older
//! estimate is replaced only once the new one is complete (moved aside,
//! the new one renamed in, the old one deleted; should the rename fail
//! the old one is moved back).
//!
//! Out of scope: UV textures and glTF (the contract's `texture/` and
//! `material.gltf`), which need the mesh's UVs.

use crate::pipeline::metrics::ErrorMetrics;
use matscan_scan::atomic::PendingDir;
use matscan_scan::estimate_maps::{write_position_maps, PositionMaps};
use matscan_scan::{Param, ScanError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Value of `format` in `result.toml`.
pub const RESULT_FORMAT: &str = "matscan-estimate/1";
/// The estimate's folder in a scan (the contract's `estimate/`).
pub use matscan_scan::estimate_maps::ESTIMATE_DIR;
/// The estimate's record in its folder.
pub const RESULT_FILE: &str = "result.toml";

/// What happened to a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Its network ran.
    Estimated,
    /// The user passed it.
    Given,
    /// Neither; see the reason.
    Skipped,
}

/// One parameter's entry in `result.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamResult {
    /// Estimated, given or skipped.
    pub status: Status,
    /// Why it was skipped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// The given constant or file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// The value a skipped parameter fed its dependents.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub default: Option<f32>,
    /// The model id of an estimated parameter.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Views the network fused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub views: Option<usize>,
    /// Which estimator answered an estimated parameter: `networks`, `fit`
    /// or `hybrid` (the fit where the photos pinned the value, the
    /// networks elsewhere); under `fit-metallic`, `hybrid` for metallic
    /// and `networks` for basecolor and roughness; under `fit-specular`,
    /// `hybrid` for metallic and roughness and `networks` for basecolor;
    /// under `fit-dielectric`, `hybrid` for all three (basecolor's
    /// `constrained` share is then the share of the materials whose
    /// basecolor the photos answered or shaped: the opaque dielectrics'
    /// albedo, the metals' highlight colour, the texture both readings
    /// agree on of every other material with a pinned metallic); a
    /// parameter whose `constrained` share is 0 is the networks' answer
    /// everywhere and says `networks` (but under `fit`, which never falls
    /// back).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Share of the reference's object pixels whose value the photos
    /// pinned (the fit's methods only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constrained: Option<f32>,
    /// Seconds of the stages that answered an estimated parameter: its
    /// network's, plus the physical fit's where the fit answered. The fit
    /// serves several parameters at once, so these do not add up to
    /// `timings.total_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
}

impl ParamResult {
    /// Who answered, in one word: the method of an estimated parameter
    /// (`networks`, `fit`, `hybrid`), or `given` / `skipped`.
    pub fn answered_by(&self) -> &str {
        match self.status {
            Status::Estimated => self.method.as_deref().unwrap_or("networks"),
            Status::Given => "given",
            Status::Skipped => "skipped",
        }
    }
}

/// Seconds per stage.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Opening the bundle and reading given maps.
    pub load_s: f64,
    /// Calibration and view selection.
    pub calibration_s: f64,
    /// Reading and warping the views' photos into the reference image.
    pub inputs_s: f64,
    /// Loading the networks' weights.
    pub weights_s: f64,
    /// Error metrics against the truth.
    pub metrics_s: f64,
    /// Everything before writing.
    pub total_s: f64,
    /// Each network that ran, by name (assembling its inputs included).
    pub networks: BTreeMap<String, f64>,
    /// The refinement after the networks, every position together (0 when
    /// it did not run).
    #[serde(default)]
    pub refine_s: f64,
    /// The physical fit, every position together (0 when it did not run).
    #[serde(default)]
    pub fit_s: f64,
    /// Of `fit_s`, the backlight's transmission measurement.
    #[serde(default)]
    pub backlight_s: f64,
    /// Of `fit_s`, the checkers' scattering measurement (the mesh read,
    /// the flash photos averaged into cells, the renders).
    #[serde(default)]
    pub scattering_s: f64,
}

/// `result.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// [`RESULT_FORMAT`].
    pub format: String,
    /// The scan folder.
    pub scan: String,
    /// The position whose camera image the maps (and the metrics) are in.
    pub reference_position: String,
    /// Every position with maps in `<position>/`, the reference first (one
    /// entry unless the estimate ran with every position as reference).
    #[serde(default)]
    pub positions: Vec<String>,
    /// The views used, `position/capture`.
    pub views: Vec<String>,
    /// Positions left out, with the reason.
    pub left_out: Vec<String>,
    /// Anything else the user should know.
    pub warnings: Vec<String>,
    /// Per parameter.
    pub params: BTreeMap<String, ParamResult>,
    /// Model id of every network that ran, by network name.
    pub models: BTreeMap<String, String>,
    /// Stage timings.
    pub timings: Timings,
    /// Error metrics per parameter over the truth mask, when the scan has truth.
    pub metrics: BTreeMap<String, ErrorMetrics>,
    /// What the refinement after the networks did, when it ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refine: Option<crate::refine::RefineSummary>,
    /// What the physical fit found, when it ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitSummary>,
}

/// What `result.toml` records of the physical fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// `fit` or `hybrid`.
    pub method: crate::pipeline::method::Method,
    /// Where the lights' absolute scale came from.
    pub scale: String,
    /// The reference position's materials.
    pub materials: Vec<crate::fit::MaterialFit>,
    /// Views left out, pixels without observations.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

impl ResultFile {
    /// Parses `result.toml` text.
    pub fn parse(text: &str) -> Result<ResultFile, toml::de::Error> {
        toml::from_str(text)
    }

    /// The entry of `kind`.
    pub fn param(&self, kind: Param) -> Option<&ParamResult> {
        self.params.get(kind.name())
    }
}

/// Writing the estimate failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file or folder operation failed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// A file system operation failed.
    #[error("{path}: {source}")]
    Io {
        /// Where.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `result.toml` could not be serialized.
    #[error("cannot write result.toml: {0}")]
    Toml(#[from] toml::ser::Error),
    /// The target has no file name.
    #[error("{0} is not a folder path")]
    BadTarget(PathBuf),
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes the maps of every position and `result` as the folder `target`,
/// atomically, replacing an older one (and with it any textures baked from
/// the older maps).
pub fn write_estimate(
    target: &Path,
    positions: &[PositionMaps],
    result: &ResultFile,
) -> Result<(), OutputError> {
    let name = target
        .file_name()
        .and_then(|n| n.to_str())
        .ok_or_else(|| OutputError::BadTarget(target.to_path_buf()))?;
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let pid = std::process::id();
    let staged = parent.join(format!(".{name}.staged-{pid}"));
    if staged.exists() {
        // Left by a crashed run that had this process id.
        std::fs::remove_dir_all(&staged).map_err(io(&staged))?;
    }
    let pending = PendingDir::create(&staged)?;
    for position in positions {
        write_position_maps(&pending.path().join(&position.position), position)?;
    }
    let text = toml::to_string(result)?;
    let toml_path = pending.path().join(RESULT_FILE);
    std::fs::write(&toml_path, text).map_err(io(&toml_path))?;
    let staged = pending.publish()?;
    replace(&staged, target, &parent, name, pid)
}

/// Renames `staged` onto `target`, moving an existing `target` aside first.
fn replace(
    staged: &Path,
    target: &Path,
    parent: &Path,
    name: &str,
    pid: u32,
) -> Result<(), OutputError> {
    if !target.exists() {
        return std::fs::rename(staged, target).map_err(io(target));
    }
    let old = parent.join(format!(".{name}.old-{pid}"));
    if old.exists() {
        std::fs::remove_dir_all(&old).map_err(io(&old))?;
    }
    std::fs::rename(target, &old).map_err(io(target))?;
    if let Err(e) = std::fs::rename(staged, target) {
        // Put the old estimate back rather than leave none.
        if let Err(back) = std::fs::rename(&old, target) {
            tracing::error!(
                "could not restore {} from {}: {back}",
                target.display(),
                old.display()
            );
        }
        return Err(io(target)(e));
    }
    std::fs::remove_dir_all(&old).map_err(io(&old))
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_scan::estimate_maps::ParamMap;
    use matscan_scan::raster::ScalarRaster;

    fn result() -> ResultFile {
        let mut params = BTreeMap::new();
        params.insert(
            "transmission".to_string(),
            ParamResult {
                status: Status::Skipped,
                reason: Some("no backlit capture".to_string()),
                source: None,
                default: Some(0.0),
                model: None,
                views: None,
                method: None,
                constrained: None,
                seconds: None,
            },
        );
        ResultFile {
            format: RESULT_FORMAT.to_string(),
            scan: "scan".to_string(),
            reference_position: "p0".to_string(),
            positions: vec!["p0".to_string()],
            views: vec!["p0/flash0".to_string()],
            left_out: vec![],
            warnings: vec![],
            params,
            models: BTreeMap::new(),
            timings: Timings::default(),
            metrics: BTreeMap::new(),
            refine: None,
            fit: None,
        }
    }

    #[test]
    fn an_estimate_replaces_the_old_one_whole() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("estimate");
        let roughness = ParamMap::scalar(Param::Roughness, ScalarRaster::filled(4, 3, 0.25))
            .unwrap()
            .with_confidence(ScalarRaster::filled(4, 3, 0.5))
            .unwrap();
        std::fs::create_dir_all(target.join("old")).unwrap();
        let positions = [PositionMaps {
            position: "p0".to_string(),
            maps: vec![roughness],
        }];
        write_estimate(&target, &positions, &result()).unwrap();
        assert!(target.join("p0/roughness_confidence.exr").is_file());
        assert!(!target.join("old").exists());
        assert!(target.join("p0/roughness.exr").is_file());
        assert!(target.join("p0/roughness.png").is_file());
        let text = std::fs::read_to_string(target.join("result.toml")).unwrap();
        assert_eq!(ResultFile::parse(&text).unwrap(), result());
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(leftovers, vec![std::ffi::OsString::from("estimate")]);
    }
}
