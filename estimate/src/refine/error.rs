//! How the refinement fails.

use matscan_calib::CalibError;
use matscan_scan::ScanError;

/// The refinement could not run.
#[derive(Debug, thiserror::Error)]
pub enum RefineError {
    /// Reading the manifest failed.
    #[error(transparent)]
    Scan(#[from] ScanError),
    /// Warping a light map failed.
    #[error(transparent)]
    Calib(#[from] CalibError),
    /// Calibration has no light maps for a view.
    #[error("refinement: calibration has no light maps for view {0}")]
    MissingMaps(String),
    /// A start map does not have one value per reference pixel.
    #[error(
        "refinement: the {what} map has {found} values, the reference image {expected} pixels"
    )]
    Size {
        /// Which map.
        what: &'static str,
        /// Its length.
        found: usize,
        /// Pixels of the reference image.
        expected: usize,
    },
}
