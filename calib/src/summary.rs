//! A serializable summary of a calibration: what the estimator's report
//! and the command line need to say about it (light responses, bad-light
//! verdicts, how much of each position the others see), without the maps.

use crate::bad_light::BadLight;
use crate::calibrate::ScanCalibration;
use crate::white_reference::WhiteReference;
use serde::Serialize;

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibSummary {
    pub positions: Vec<PositionSummary>,
    pub correspondences: Vec<CorrespondenceSummary>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PositionSummary {
    pub position: String,
    /// Pixels where the camera sees the mesh.
    pub object_pixels: usize,
    /// The white reference's responses, when there are any.
    pub light_response: Option<WhiteReference>,
    /// Why there is no light response, when there is none.
    pub light_response_error: Option<String>,
    pub bad_light: BadLight,
    /// Why estimation leaves this position out, if it does.
    pub left_out: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CorrespondenceSummary {
    pub reference: String,
    pub other: String,
    pub valid_pixels: usize,
    /// `valid_pixels` over the reference's object pixels (the thesis keeps
    /// a matchmap when this is at least 10%).
    pub valid_fraction: f64,
}

impl ScanCalibration {
    pub fn summary(&self) -> CalibSummary {
        let positions = self
            .positions
            .iter()
            .map(|p| PositionSummary {
                position: p.maps.position.clone(),
                object_pixels: p.maps.geometry.object_pixels(),
                light_response: p.light_response.as_ref().ok().cloned(),
                light_response_error: p.light_response.as_ref().err().map(|e| e.to_string()),
                bad_light: p.bad_light.clone(),
                left_out: p.bad_light.reason(),
            })
            .collect();
        let correspondences = self
            .correspondences
            .iter()
            .map(|c| {
                let object = self
                    .position(&c.reference)
                    .map_or(0, |p| p.maps.geometry.object_pixels());
                let valid = c.valid_pixels();
                CorrespondenceSummary {
                    reference: c.reference.clone(),
                    other: c.other.clone(),
                    valid_pixels: valid,
                    valid_fraction: if object > 0 {
                        valid as f64 / object as f64
                    } else {
                        0.0
                    },
                }
            })
            .collect();
        CalibSummary {
            positions,
            correspondences,
        }
    }
}
