//! What the development probes under `examples/` share. Each probe
//! compiles this module on its own and uses a part of it.
#![allow(dead_code)]

use matscan_calib::{calibrate_bundle, CalibOptions, ScanCalibration};
use matscan_estimate::pipeline::inputs::SceneInputs;
use matscan_estimate::pipeline::views::{select_views, ViewFilter};
use matscan_scan::{Bundle, Param};
use std::path::Path;

pub type Error = Box<dyn std::error::Error>;

/// A scan folder's name (empty where it has none).
pub fn scan_name(scan: &Path) -> String {
    scan.file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default()
}

/// The median of `v` (the upper one of an even count); NaN when empty.
pub fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return f32::NAN;
    }
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

/// A scan as the estimator reads it: its bundle, its calibration and the
/// inputs of every usable view at the reference position.
pub struct Scan {
    pub bundle: Bundle,
    pub calibration: ScanCalibration,
    pub inputs: SceneInputs,
}

/// Opens the scan folder `dir` with the default calibration and views.
pub fn open(dir: &Path) -> Result<Scan, Error> {
    let bundle = Bundle::open(dir)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())?;
    let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default())?;
    let inputs = SceneInputs::assemble(&bundle, &calibration, &set)?;
    Ok(Scan {
        bundle,
        calibration,
        inputs,
    })
}

impl Scan {
    /// The truth map of `kind` at the reference position, flat (RGB
    /// interleaved for basecolor).
    pub fn truth(&self, kind: Param) -> Result<Vec<f32>, Error> {
        Ok(self
            .bundle
            .truth_param(&self.inputs.reference, kind)?
            .ok_or("no truth")?
            .flat()
            .0
            .to_vec())
    }
}
