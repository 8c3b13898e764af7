//! What the baker takes in: per position, parameter maps in that
//! position's camera image (an estimate's or a simulated scan's truth), an
//! optional mask and optional confidence maps.

use crate::error::BakeError;
use matscan_scan::raster::{MaskRaster, RgbRaster, ScalarRaster};
use matscan_scan::Param;

/// The values of one parameter map: RGB for basecolor, one channel for
/// the others (the constructors of [`ParamMap`] keep them apart).
#[derive(Debug, Clone, PartialEq)]
pub enum MapValues {
    Rgb(RgbRaster),
    Scalar(ScalarRaster),
}

impl MapValues {
    pub fn width(&self) -> u32 {
        match self {
            MapValues::Rgb(r) => r.width,
            MapValues::Scalar(r) => r.width,
        }
    }

    pub fn height(&self) -> u32 {
        match self {
            MapValues::Rgb(r) => r.height,
            MapValues::Scalar(r) => r.height,
        }
    }
}

/// One parameter's map in a camera image, with its optional confidence
/// (`[0, 1]`, 1 = the data pin the value down; 1 where absent).
#[derive(Debug, Clone, PartialEq)]
pub struct ParamMap {
    param: Param,
    values: MapValues,
    confidence: Option<ScalarRaster>,
}

impl ParamMap {
    /// A linear basecolor map.
    pub fn basecolor(values: RgbRaster) -> Self {
        Self {
            param: Param::Basecolor,
            values: MapValues::Rgb(values),
            confidence: None,
        }
    }

    /// A scalar parameter's map; refuses basecolor, which has three
    /// channels.
    pub fn scalar(param: Param, values: ScalarRaster) -> Result<Self, BakeError> {
        if param == Param::Basecolor {
            return Err(BakeError::WrongParam {
                param,
                message: "basecolor has three channels; use ParamMap::basecolor".into(),
            });
        }
        Ok(Self {
            param,
            values: MapValues::Scalar(values),
            confidence: None,
        })
    }

    /// Adds a confidence map; it must have the values' size.
    pub fn with_confidence(mut self, confidence: ScalarRaster) -> Result<Self, BakeError> {
        if (confidence.width, confidence.height) != (self.values.width(), self.values.height()) {
            return Err(BakeError::SizeMismatch {
                param: format!("{}_confidence", self.param),
                expected_width: self.values.width(),
                expected_height: self.values.height(),
                found_width: confidence.width,
                found_height: confidence.height,
            });
        }
        self.confidence = Some(confidence);
        Ok(self)
    }

    pub fn param(&self) -> Param {
        self.param
    }

    pub fn values(&self) -> &MapValues {
        &self.values
    }

    pub fn confidence(&self) -> Option<&ScalarRaster> {
        self.confidence.as_ref()
    }
}

/// The maps of one position of the scan.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionMaps {
    /// The position's name in the manifest (its camera and lights).
    pub position: String,
    /// Valid pixels of the maps; the baker also intersects it with the
    /// mesh's own silhouette in that camera. `None`: the silhouette alone.
    pub mask: Option<MaskRaster>,
    pub maps: Vec<ParamMap>,
}
