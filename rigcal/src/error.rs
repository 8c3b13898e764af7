//! Errors of rig calibration: each names the photo, shot or file at fault
//! and what was expected, so a user knows what to retake.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum RigcalError {
    /// Reading the bundle or writing a result failed.
    #[error(transparent)]
    Scan(#[from] matscan_scan::ScanError),
    /// The detector found no complete board in a photo.
    #[error(
        "{}: {reason}; retake it with the whole board in view, evenly lit and in focus",
        path.display()
    )]
    BoardNotFound { path: PathBuf, reason: String },
    /// Photos of one bundle must come from one camera.
    #[error(
        "{}: {found_width}x{found_height} pixels, but the bundle's first photo is \
         {width}x{height}; every shot must come from the same camera",
        path.display()
    )]
    SizeMismatch {
        path: PathBuf,
        width: u32,
        height: u32,
        found_width: u32,
        found_height: u32,
    },
    /// Too few shots to separate focal length from distance.
    #[error(
        "{found} board shots in all; at least {needed} are needed, the board tilted \
         differently in each (add shots to calib.toml)"
    )]
    TooFewShots { found: usize, needed: usize },
    /// Too few Gray-code poses to calibrate the projector.
    #[error(
        "{found} shots with Gray codes; the projector needs at least {needed} board poses \
         with Gray codes, tilted differently (add `graycode` shots to calib.toml)"
    )]
    TooFewGrayCodeShots { found: usize, needed: usize },
    /// A shot seeing the board nearly edge-on: its corners constrain little
    /// and locate badly.
    #[error(
        "{}: the board is seen {tilt_deg:.0} degrees from head-on (at most {limit_deg:.0}); \
         retake it turned further towards the camera",
        path.display()
    )]
    EdgeOn {
        path: PathBuf,
        tilt_deg: f64,
        limit_deg: f64,
    },
    /// A shot's Gray codes cannot be read.
    #[error("{}: Gray codes: {reason}", path.display())]
    GrayCode { path: PathBuf, reason: String },
    /// No sphere silhouette in a light-calibration photo.
    #[error(
        "{}: sphere not found: {reason}",
        path.display()
    )]
    SphereNotFound { path: PathBuf, reason: String },
    /// A flash's highlight on the sphere is missing or unusable.
    #[error("{}: {reason}", path.display())]
    Highlight { path: PathBuf, reason: String },
    /// A placement names a position the rig file does not have.
    #[error(
        "{}: position `{position}` is not in the rig file; photograph the sphere from one \
         of its positions",
        path.display()
    )]
    UnknownPosition { path: PathBuf, position: String },
    /// The white card cannot be measured: out of view, in shadow, clipped.
    #[error("{}: white card: {reason}", path.display())]
    WhiteCard { path: PathBuf, reason: String },
    /// A light's value per second of exposure changes with the exposure:
    /// the camera does not deliver linear photos.
    #[error(
        "{}: the camera's response is not linear: `{light}` reads {readings} of its median \
         value per second of exposure (at most {limit} off); deliver linear (raw) photos, \
         or declare the photos' encoding",
        path.display()
    )]
    Nonlinear {
        path: PathBuf,
        light: String,
        readings: String,
        limit: f64,
    },
    /// The shots do not determine the camera (all boards parallel, say).
    #[error("the shots do not determine the camera: {0}")]
    Degenerate(String),
}
