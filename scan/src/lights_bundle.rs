//! The light-calibration bundle, format `matscan-lights/1`: photos of a
//! glossy sphere of known radius, from which the rig's flashes are located
//! (each flash's highlight on the sphere is a reflected ray; the flash is
//! where the rays of several placements meet).
//!
//! A folder with `lights.toml` and the photos it lists:
//!
//! ```toml
//! format = "matscan-lights/1"
//! units = "m"
//!
//! [sphere]
//! radius = 0.04                 # in `units`
//!
//! [[placement]]
//! position = "p0"               # the rig position whose camera took it
//! folder = "p0/sphere-00"       # ambient.exr, backlight.exr, one
//!                               # <light>.exr per flash (flash0.exr, ...)
//!                               # and, on a rig with a projector,
//!                               # projector.exr
//! ```
//!
//! `ambient` has every rig light off, `backlight` the backlight panel alone
//! behind the sphere (its silhouette), each flash photo that flash alone,
//! `projector` the projector alone showing uniform white.
//!
//! Boundaries: the format only; finding the sphere and the lights is
//! `matscan-rigcal`'s.

use crate::error::ScanError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format name in `lights.toml`.
pub const LIGHTS_FORMAT: &str = "matscan-lights/1";
/// The manifest's file name in a light-calibration bundle.
pub const LIGHTS_MANIFEST: &str = "lights.toml";
/// The photo of a placement with every rig light off.
pub const AMBIENT_PHOTO: &str = "ambient.exr";
/// The photo of a placement with the backlight panel alone.
pub const BACKLIGHT_PHOTO: &str = "backlight.exr";
/// The photo of a placement with the projector alone, uniformly white
/// (optional): its highlight, from a calibrated projector, centres the
/// sphere better than its outline does.
pub const PROJECTOR_PHOTO: &str = "projector.exr";
/// A photo's level (linear, 1 = sensor white) at or above which a pixel is
/// clipped: a highlight with such a pixel has lost its shape. Every photo
/// of one placement is taken at one exposure, short enough that no flash's
/// highlight clips.
pub const CLIPPED_LEVEL: f32 = 0.995;
/// The flashes a placement photographs, by their rig names.
pub const FLASHES: [&str; 2] = ["flash0", "flash1"];
/// The backlight panel's rig name: a light without a position (the panel
/// is seen directly), so a rig file from the board alone lacks it.
pub const BACKLIGHT: &str = "backlight";

/// The file of `light`'s photo in a placement's folder.
pub fn light_photo(light: &str) -> String {
    format!("{light}.exr")
}

/// One placement of the sphere, photographed from one rig position.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    pub position: String,
    /// Relative to the bundle folder.
    pub folder: PathBuf,
}

/// A validated `lights.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct LightsManifest {
    pub units: String,
    /// The sphere's radius, in `units`.
    pub radius: f64,
    pub placements: Vec<Placement>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    format: String,
    #[serde(default = "default_units")]
    units: String,
    sphere: RawSphere,
    #[serde(rename = "placement", default)]
    placements: Vec<RawPlacement>,
}

fn default_units() -> String {
    "m".into()
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    radius: f64,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlacement {
    position: String,
    folder: PathBuf,
}

impl LightsManifest {
    /// Reads and validates `lights.toml` in `dir`.
    pub fn read(dir: &Path) -> Result<LightsManifest, ScanError> {
        let (text, path) = crate::calib_bundle::read_manifest(dir, LIGHTS_MANIFEST)?;
        Self::parse(&text, &path)
    }

    /// Parses `lights.toml` text; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<LightsManifest, ScanError> {
        let raw: RawManifest =
            crate::calib_bundle::parse_manifest(text, path, LIGHTS_FORMAT, |r: &RawManifest| {
                &r.format
            })?;
        let invalid = crate::calib_bundle::invalid_key(path);
        if !(raw.sphere.radius.is_finite() && raw.sphere.radius > 0.0) {
            return Err(invalid("sphere.radius", "expected a positive length"));
        }
        if raw.placements.len() < 2 {
            return Err(invalid(
                "placement",
                "expected at least two [[placement]]s: a flash is where the rays of two or \
                 more sphere placements meet",
            ));
        }
        for (k, p) in raw.placements.iter().enumerate() {
            if p.position.is_empty() {
                return Err(invalid(
                    &format!("placement[{k}].position"),
                    "expected a rig position's name",
                ));
            }
            if !crate::calib_bundle::inside_bundle(&p.folder) {
                return Err(invalid(
                    &format!("placement[{k}].folder"),
                    "expected a folder inside the bundle folder",
                ));
            }
        }
        Ok(LightsManifest {
            units: raw.units,
            radius: raw.sphere.radius,
            placements: raw
                .placements
                .into_iter()
                .map(|p| Placement {
                    position: p.position,
                    folder: p.folder,
                })
                .collect(),
        })
    }

    /// The manifest as `lights.toml` text.
    pub fn to_toml(&self) -> String {
        let raw = RawManifest {
            format: LIGHTS_FORMAT.into(),
            units: self.units.clone(),
            sphere: RawSphere {
                radius: self.radius,
            },
            placements: self
                .placements
                .iter()
                .map(|p| RawPlacement {
                    position: p.position.clone(),
                    folder: p.folder.clone(),
                })
                .collect(),
        };
        // Plain data with string keys: serializing cannot fail.
        toml::to_string(&raw).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
format = "matscan-lights/1"
[sphere]
radius = 0.04
[[placement]]
position = "p0"
folder = "p0/sphere-00"
[[placement]]
position = "p0"
folder = "p0/sphere-01"
"#;

    #[test]
    fn a_lights_manifest_reads_back_what_it_writes() {
        let m = LightsManifest::parse(GOOD, Path::new("lights.toml")).unwrap();
        assert_eq!(m.radius, 0.04);
        assert_eq!(m.units, "m");
        assert_eq!(m.placements[1].folder, PathBuf::from("p0/sphere-01"));
        let again = LightsManifest::parse(&m.to_toml(), Path::new("lights.toml")).unwrap();
        assert_eq!(again, m);
        assert_eq!(light_photo("flash1"), "flash1.exr");
    }

    #[test]
    fn bad_lights_manifests_name_the_key() {
        let cases = [
            (GOOD.replace("0.04", "-1"), "sphere.radius"),
            (
                GOOD.replace("\"p0/sphere-01\"", "\"../x\""),
                "placement[1].folder",
            ),
            (
                GOOD.split("[[placement]]")
                    .take(2)
                    .collect::<Vec<_>>()
                    .join("[[placement]]"),
                "at least two",
            ),
            (GOOD.replace("lights/1", "lights/9"), "format"),
        ];
        for (text, want) in cases {
            let e = LightsManifest::parse(&text, Path::new("lights.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want) && e.contains("lights.toml"), "{e}");
        }
    }
}
