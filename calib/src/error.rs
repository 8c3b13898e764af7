//! Errors of calibration. Each names the position and capture (or file) it
//! is about and says what was expected, so a user can fix the bundle.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    #[error("the mesh has no triangles: nothing to ray-cast")]
    EmptyMesh,
    #[error("position `{position}`: capture `{capture}` is {found_w}x{found_h} pixels, the camera is {expected_w}x{expected_h}")]
    SizeMismatch {
        position: String,
        capture: String,
        expected_w: u32,
        expected_h: u32,
        found_w: u32,
        found_h: u32,
    },
    #[error("position `{position}`: no photo for capture `{capture}`")]
    MissingPhoto { position: String, capture: String },
    #[error("position `{position}`: no ambient capture (one with `lights = []` is required)")]
    NoAmbient { position: String },
    #[error("position `{position}`: no white-reference mask and no backlit capture to segment the backlight panel from")]
    NoWhiteReference { position: String },
    #[error("position `{position}`: capture `{capture}`: only {found} white-reference pixels, at least {needed} needed (check the white-reference mask or that the backlight panel is visible and lit)")]
    TooFewReferencePixels {
        position: String,
        capture: String,
        found: usize,
        needed: usize,
    },
    #[error("position `{position}` is not in the calibration")]
    UnknownPosition { position: String },
    #[error(transparent)]
    Scan(#[from] matscan_scan::ScanError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}
