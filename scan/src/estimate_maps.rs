//! The parameter maps of a scan's `estimate/` folder (docs/scan-format.md):
//! per position, `<position>/<param>.exr` (float; basecolor RGB, the
//! others one channel) with an 8-bit `<param>.png` preview, and where a fit
//! measured it `<param>_confidence.exr` (and `.png`). The estimator writes
//! them, the baker and the evaluation read them, all through this module.
//!
//! Out of scope: `result.toml` (the estimator's record of how the maps were
//! made) and publishing the folder atomically (the estimator stages the
//! whole folder and renames it).

use crate::error::ScanError;
use crate::image_io::{
    read_rgb_exr, read_scalar_exr, write_preview_png, write_rgb_exr, write_scalar_exr,
    write_scalar_preview_png, Precision,
};
use crate::param::Param;
use crate::raster::{RgbRaster, ScalarRaster};
use std::path::Path;

/// The estimate's folder in a scan.
pub const ESTIMATE_DIR: &str = "estimate";

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

    /// The values pixel-major (RGB interleaved) and the channels per pixel.
    pub fn flat(&self) -> (&[f32], usize) {
        match self {
            MapValues::Rgb(r) => (r.data.as_flattened(), 3),
            MapValues::Scalar(r) => (&r.data, 1),
        }
    }
}

/// A map that breaks the rules of its parameter.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapError {
    /// Basecolor given one channel, or another parameter three.
    #[error("{param}: {message}")]
    WrongParam { param: Param, message: String },
    /// A confidence map of another size than its values.
    #[error("{param}_confidence is {found_width}x{found_height}; its map is {expected_width}x{expected_height}")]
    SizeMismatch {
        param: Param,
        expected_width: u32,
        expected_height: u32,
        found_width: u32,
        found_height: u32,
    },
}

/// One parameter's map in a camera image, with its optional confidence
/// (`[0, 1]`, 1 = the data pin the value down; absent: not measured).
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
    pub fn scalar(param: Param, values: ScalarRaster) -> Result<Self, MapError> {
        if param == Param::Basecolor {
            return Err(MapError::WrongParam {
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

    /// `param`'s map of `values`: RGB for basecolor, one channel for the
    /// others.
    pub fn new(param: Param, values: MapValues) -> Result<Self, MapError> {
        match values {
            MapValues::Rgb(r) if param == Param::Basecolor => Ok(Self::basecolor(r)),
            MapValues::Rgb(_) => Err(MapError::WrongParam {
                param,
                message: "only basecolor has three channels".into(),
            }),
            MapValues::Scalar(r) => Self::scalar(param, r),
        }
    }

    /// Adds a confidence map; it must have the values' size.
    pub fn with_confidence(mut self, confidence: ScalarRaster) -> Result<Self, MapError> {
        if (confidence.width, confidence.height) != (self.values.width(), self.values.height()) {
            return Err(MapError::SizeMismatch {
                param: self.param,
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

/// The maps of one position, in that position's camera image.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PositionMaps {
    /// The position's name in the manifest (and its folder's name).
    pub position: String,
    /// At most one map per parameter.
    pub maps: Vec<ParamMap>,
}

impl PositionMaps {
    /// The map of `param`, if there is one.
    pub fn get(&self, param: Param) -> Option<&ParamMap> {
        self.maps.iter().find(|m| m.param() == param)
    }
}

/// Writes `maps` into `dir` (the position's folder, created).
pub fn write_position_maps(dir: &Path, maps: &PositionMaps) -> Result<(), ScanError> {
    std::fs::create_dir_all(dir).map_err(|source| ScanError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for map in &maps.maps {
        let name = map.param().name();
        let exr = dir.join(format!("{name}.exr"));
        let png = dir.join(format!("{name}.png"));
        match map.values() {
            MapValues::Scalar(r) => {
                write_scalar_exr(&exr, r, Precision::Float)?;
                write_scalar_preview_png(&png, r)?;
            }
            MapValues::Rgb(r) => {
                write_rgb_exr(&exr, r, Precision::Float)?;
                write_preview_png(&png, r)?;
            }
        }
        if let Some(c) = map.confidence() {
            write_scalar_exr(
                &dir.join(format!("{name}_confidence.exr")),
                c,
                Precision::Float,
            )?;
            write_scalar_preview_png(&dir.join(format!("{name}_confidence.png")), c)?;
        }
    }
    Ok(())
}

/// Reads the maps of `position` from the estimate folder `estimate_dir`;
/// `None` when its folder holds no parameter map.
pub fn read_position_maps(
    estimate_dir: &Path,
    position: &str,
) -> Result<Option<PositionMaps>, ScanError> {
    let dir = estimate_dir.join(position);
    let mut maps = Vec::new();
    for param in Param::ALL {
        let path = dir.join(format!("{}.exr", param.name()));
        if !path.is_file() {
            continue;
        }
        let bad = |e: MapError| ScanError::Format {
            path: path.clone(),
            message: e.to_string(),
        };
        let map = if param == Param::Basecolor {
            ParamMap::basecolor(read_rgb_exr(&path)?)
        } else {
            ParamMap::scalar(param, read_scalar_exr(&path)?).map_err(bad)?
        };
        let conf_path = dir.join(format!("{}_confidence.exr", param.name()));
        let map = if conf_path.is_file() {
            map.with_confidence(read_scalar_exr(&conf_path)?)
                .map_err(|e| ScanError::Format {
                    path: conf_path.clone(),
                    message: e.to_string(),
                })?
        } else {
            map
        };
        maps.push(map);
    }
    Ok((!maps.is_empty()).then(|| PositionMaps {
        position: position.to_string(),
        maps,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_and_confidences_read_back_as_written() {
        let dir = tempfile::tempdir().unwrap();
        let rough = ParamMap::scalar(Param::Roughness, ScalarRaster::filled(4, 3, 0.25))
            .unwrap()
            .with_confidence(ScalarRaster::filled(4, 3, 0.5))
            .unwrap();
        let base = ParamMap::basecolor(RgbRaster::filled(4, 3, [0.1, 0.2, 0.3]));
        let maps = PositionMaps {
            position: "p0".into(),
            maps: vec![base, rough],
        };
        write_position_maps(&dir.path().join("p0"), &maps).unwrap();
        assert!(dir.path().join("p0/roughness.png").is_file());
        assert!(dir.path().join("p0/roughness_confidence.exr").is_file());
        let back = read_position_maps(dir.path(), "p0").unwrap().unwrap();
        assert_eq!(back, maps);
        assert_eq!(
            back.get(Param::Roughness).and_then(|m| m.confidence()),
            Some(&ScalarRaster::filled(4, 3, 0.5))
        );
        assert_eq!(read_position_maps(dir.path(), "p1").unwrap(), None);
    }

    #[test]
    fn a_map_keeps_its_parameter_and_size_rules() {
        let e = ParamMap::scalar(Param::Basecolor, ScalarRaster::filled(2, 2, 0.0)).unwrap_err();
        assert!(matches!(e, MapError::WrongParam { .. }));
        let e = ParamMap::scalar(Param::Metallic, ScalarRaster::filled(2, 2, 0.0))
            .unwrap()
            .with_confidence(ScalarRaster::filled(3, 2, 1.0))
            .unwrap_err();
        assert!(e.to_string().contains("metallic_confidence is 3x2"), "{e}");
    }
}
