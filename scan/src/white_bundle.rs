//! The radiometric calibration bundle, format `matscan-white/1`: photos of
//! a matte white card of known reflectance at a known pose, from which each
//! light's intensity in camera units is measured (a photo's value is
//! `exposure x BSDF x cos x intensity / d^2`, so a card whose BSDF and
//! pose are known turns the value into the intensity), and the camera's
//! response checked for linearity (the same light at several exposures).
//!
//! A folder with `white.toml` and the photos it lists:
//!
//! ```toml
//! format = "matscan-white/1"
//! units = "m"
//! position = "p0"               # the rig position whose camera took them
//!
//! [card]
//! albedo = 0.9                  # diffuse reflectance, grey
//! roughness = 1.0               # as the Principled BSDF reads it
//! size = [0.42, 0.3]            # width (card x) and height (card y)
//! card_to_world = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]
//!
//! [[photo]]
//! file = "p0/ambient.exr"
//! exposure_s = 0.05
//! lights = []                   # every rig light off
//!
//! [[photo]]
//! file = "p0/flash0.exr"
//! exposure_s = 0.05
//! lights = ["flash0"]           # that light alone, full power; the
//!                               # projector shows uniform white
//! ambient = "p0/ambient.exr"    # the ambient photo it is read against
//! ```
//!
//! The card's frame: x and y along its edges from one corner, so the card
//! covers `[0, width] x [0, height]`, and its reflecting side faces -z
//! (the printed board's convention). Each lit photo names the ambient
//! photo of the same scene and exposure it is read against; a light
//! photographed at several exposures is the linearity check. The backlight
//! panel is photographed with the mount empty (the card would light the
//! panel back and brighten it), so its photo has an ambient of its own.
//!
//! Boundaries: the format only; the measurement is `matscan-rigcal`'s.

use crate::camera::{mat4_from_row_major, mat4_to_row_major};
use crate::error::ScanError;
use glam::DMat4;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format name in `white.toml`.
pub const WHITE_FORMAT: &str = "matscan-white/1";
/// The manifest's file name in a radiometric calibration bundle.
pub const WHITE_MANIFEST: &str = "white.toml";

/// The white card: its reflectance and where it stands.
#[derive(Debug, Clone, PartialEq)]
pub struct WhiteCard {
    /// Diffuse reflectance (grey), in (0, 1].
    pub albedo: f64,
    /// Roughness as the Principled BSDF reads it, in [0, 1].
    pub roughness: f64,
    /// Width and height, in the bundle's units.
    pub size: [f64; 2],
    pub card_to_world: DMat4,
}

impl WhiteCard {
    /// A card the size of `board`'s print (its squares and half a square
    /// of margin around them) standing where the board's reference
    /// placement stands (`reference_to_world`, board frame to world): the
    /// card sits on the board's mount, so its pose is known as the board's.
    pub fn on_board(
        board: &crate::calib_bundle::Chessboard,
        reference_to_world: DMat4,
        albedo: f64,
        roughness: f64,
    ) -> WhiteCard {
        let s = board.square;
        let (sq_x, sq_y) = board.squares();
        // The board frame's origin is its first inner corner: the print
        // starts a square and a half before it.
        let corner = glam::DVec3::new(-1.5 * s, -1.5 * s, 0.0);
        WhiteCard {
            albedo,
            roughness,
            size: [(f64::from(sq_x) + 1.0) * s, (f64::from(sq_y) + 1.0) * s],
            card_to_world: reference_to_world * DMat4::from_translation(corner),
        }
    }
}

/// One photo of the card.
#[derive(Debug, Clone, PartialEq)]
pub struct WhitePhoto {
    /// Relative to the bundle folder.
    pub file: PathBuf,
    pub exposure_s: f64,
    /// The rig lights on, by name (empty: ambient).
    pub lights: Vec<String>,
    /// A lit photo's ambient photo (its `file`); `None` for an ambient
    /// photo.
    pub ambient: Option<PathBuf>,
}

/// A validated `white.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct WhiteManifest {
    pub units: String,
    pub position: String,
    pub card: WhiteCard,
    pub photos: Vec<WhitePhoto>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    format: String,
    #[serde(default = "default_units")]
    units: String,
    position: String,
    card: RawCard,
    #[serde(rename = "photo", default)]
    photos: Vec<RawPhoto>,
}

fn default_units() -> String {
    "m".into()
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCard {
    albedo: f64,
    roughness: f64,
    size: [f64; 2],
    card_to_world: [f64; 16],
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPhoto {
    file: PathBuf,
    exposure_s: f64,
    lights: Vec<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    ambient: Option<PathBuf>,
}

impl WhiteManifest {
    /// Reads and validates `white.toml` in `dir`.
    pub fn read(dir: &Path) -> Result<WhiteManifest, ScanError> {
        let (text, path) = crate::calib_bundle::read_manifest(dir, WHITE_MANIFEST)?;
        Self::parse(&text, &path)
    }

    /// Parses `white.toml` text; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<WhiteManifest, ScanError> {
        let raw: RawManifest =
            crate::calib_bundle::parse_manifest(text, path, WHITE_FORMAT, |r: &RawManifest| {
                &r.format
            })?;
        let invalid = crate::calib_bundle::invalid_key(path);
        if raw.position.is_empty() {
            return Err(invalid("position", "expected a rig position's name"));
        }
        let c = &raw.card;
        if !(c.albedo.is_finite() && c.albedo > 0.0 && c.albedo <= 1.0) {
            return Err(invalid("card.albedo", "expected a reflectance in (0, 1]"));
        }
        if !(0.0..=1.0).contains(&c.roughness) {
            return Err(invalid("card.roughness", "expected a roughness in [0, 1]"));
        }
        if !c.size.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(invalid("card.size", "expected two positive lengths"));
        }
        let card_to_world = mat4_from_row_major(&c.card_to_world);
        if !crate::calib_bundle::is_rigid(&card_to_world) {
            return Err(invalid(
                "card.card_to_world",
                "expected a rigid transform (rotation and translation, last row 0 0 0 1)",
            ));
        }
        for (k, p) in raw.photos.iter().enumerate() {
            if !crate::calib_bundle::inside_bundle(&p.file) {
                return Err(invalid(
                    &format!("photo[{k}].file"),
                    "expected a file inside the bundle folder",
                ));
            }
            if !(p.exposure_s.is_finite() && p.exposure_s > 0.0) {
                return Err(invalid(
                    &format!("photo[{k}].exposure_s"),
                    "expected a positive exposure in seconds",
                ));
            }
            let ambient = p.ambient.as_ref().and_then(|file| {
                raw.photos
                    .iter()
                    .find(|a| &a.file == file && a.lights.is_empty())
            });
            match (p.lights.is_empty(), ambient) {
                (true, _) if p.ambient.is_some() => {
                    return Err(invalid(
                        &format!("photo[{k}].ambient"),
                        "no ambient for an ambient photo (lights = [])",
                    ))
                }
                (false, None) => {
                    return Err(invalid(
                        &format!("photo[{k}].ambient"),
                        "the file of an ambient photo (lights = []) listed in the bundle, \
                         to subtract",
                    ))
                }
                (false, Some(a)) if a.exposure_s != p.exposure_s => {
                    return Err(invalid(
                        &format!("photo[{k}].ambient"),
                        "an ambient photo at the same exposure_s",
                    ))
                }
                _ => {}
            }
        }
        if !raw.photos.iter().any(|p| !p.lights.is_empty()) {
            return Err(invalid(
                "photo",
                "expected at least one photo with a light on",
            ));
        }
        Ok(WhiteManifest {
            units: raw.units,
            position: raw.position,
            card: WhiteCard {
                albedo: c.albedo,
                roughness: c.roughness,
                size: c.size,
                card_to_world,
            },
            photos: raw
                .photos
                .into_iter()
                .map(|p| WhitePhoto {
                    file: p.file,
                    exposure_s: p.exposure_s,
                    lights: p.lights,
                    ambient: p.ambient,
                })
                .collect(),
        })
    }

    /// The ambient photo `photo` is read against, if it names one listed.
    pub fn ambient_of(&self, photo: &WhitePhoto) -> Option<&WhitePhoto> {
        let file = photo.ambient.as_ref()?;
        self.photos
            .iter()
            .find(|p| &p.file == file && p.lights.is_empty())
    }

    /// The manifest as `white.toml` text.
    pub fn to_toml(&self) -> String {
        let raw = RawManifest {
            format: WHITE_FORMAT.into(),
            units: self.units.clone(),
            position: self.position.clone(),
            card: RawCard {
                albedo: self.card.albedo,
                roughness: self.card.roughness,
                size: self.card.size,
                card_to_world: mat4_to_row_major(&self.card.card_to_world),
            },
            photos: self
                .photos
                .iter()
                .map(|p| RawPhoto {
                    file: p.file.clone(),
                    exposure_s: p.exposure_s,
                    lights: p.lights.clone(),
                    ambient: p.ambient.clone(),
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
format = "matscan-white/1"
position = "p0"
[card]
albedo = 0.9
roughness = 1.0
size = [0.4, 0.3]
card_to_world = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]
[[photo]]
file = "p0/ambient.exr"
exposure_s = 0.05
lights = []
[[photo]]
file = "p0/flash0.exr"
exposure_s = 0.05
lights = ["flash0"]
ambient = "p0/ambient.exr"
"#;

    #[test]
    fn a_white_manifest_reads_back_what_it_writes() {
        let m = WhiteManifest::parse(GOOD, Path::new("white.toml")).unwrap();
        assert_eq!(m.card.albedo, 0.9);
        assert_eq!(m.card.size, [0.4, 0.3]);
        assert_eq!(m.photos[1].lights, vec!["flash0".to_string()]);
        assert_eq!(
            m.ambient_of(&m.photos[1]).map(|p| p.file.clone()),
            Some(PathBuf::from("p0/ambient.exr"))
        );
        let again = WhiteManifest::parse(&m.to_toml(), Path::new("white.toml")).unwrap();
        assert_eq!(again, m);
    }

    #[test]
    fn bad_white_manifests_name_the_key() {
        let cases = [
            (GOOD.replace("albedo = 0.9", "albedo = 1.5"), "card.albedo"),
            (GOOD.replace("[0.4, 0.3]", "[0.4, 0.0]"), "card.size"),
            (
                GOOD.replace("0,0,1,0, 0,0,0,1]", "0,0,2,0, 0,0,0,1]"),
                "card.card_to_world",
            ),
            (
                GOOD.replace(
                    "exposure_s = 0.05\nlights = [\"",
                    "exposure_s = 0.1\nlights = [\"",
                ),
                "photo[1].ambient",
            ),
            (
                GOOD.replace("ambient = \"p0/ambient.exr\"", "ambient = \"p0/other.exr\""),
                "photo[1].ambient",
            ),
            (
                GOOD.replace("\"p0/flash0.exr\"", "\"/tmp/x.exr\""),
                "photo[1].file",
            ),
            (GOOD.replace("white/1", "white/2"), "format"),
        ];
        for (text, want) in cases {
            let e = WhiteManifest::parse(&text, Path::new("white.toml"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(want) && e.contains("white.toml"), "{want}: {e}");
        }
    }
}
