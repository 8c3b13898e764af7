//! The manifest (`scan.toml`) as validated, typed data.
//!
//! Parsing goes through a raw layer over `toml` (`fields`) that keeps
//! track of unknown keys so they can be warned about, then through
//! validation (`parse`) into these types. Once a [`Manifest`] exists it is
//! known to be consistent: matrices are finite, affine and invertible, every
//! capture names lights of its position, names are unique, sizes are
//! positive. [`Manifest::to_toml`] writes it back (`write`).
//!
//! Boundaries: text in, text out; whether the files a manifest names exist
//! is [`crate::bundle`]'s business.

mod fields;
mod parse;
mod write;

use crate::camera::{Intrinsics, PinholeCamera};
use crate::error::ScanError;
use glam::{DMat4, DVec3};
use std::path::{Path, PathBuf};

/// The format string this crate reads and writes.
pub const FORMAT: &str = "matscan-scan/1";

/// A validated `scan.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// Length unit of every world-space number (`"m"` by default).
    pub units: String,
    pub name: String,
    /// RFC 3339 timestamp, free text for readers.
    pub created: String,
    /// One intrinsic model shared by all positions.
    pub camera: crate::camera::Intrinsics,
    pub positions: Vec<Position>,
}

/// One pose of the scan head (or of the object on a turntable).
#[derive(Debug, Clone, PartialEq)]
pub struct Position {
    pub name: String,
    /// Maps camera-frame points (OpenCV: x right, y down, z forward) to world.
    pub camera_to_world: DMat4,
    pub lights: Vec<Light>,
    pub captures: Vec<Capture>,
    /// Relative path of an 8-bit mask of white diffuse reference pixels.
    pub white_reference_mask: Option<PathBuf>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    pub name: String,
    pub kind: LightKind,
    /// Relative linear RGB; white when the manifest gives none.
    pub color: [f64; 3],
    /// W/sr for point lights and the projector at full white, radiance for
    /// the backlight. Optional: the white reference measures what matters.
    pub intensity: Option<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub enum LightKind {
    Point {
        position: DVec3,
    },
    /// A pinhole projector; its frame follows the OpenCV camera convention.
    Projector {
        projector_to_world: DMat4,
        intrinsics: crate::camera::Intrinsics,
    },
    /// The diffuse panel behind the object; it has no pose.
    Backlight,
}

/// How a 16-bit PNG photo encodes radiance. EXR photos are always linear.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Linear,
    Srgb,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pattern {
    Uniform {
        level: f64,
    },
    /// `period_px` is the full period (one light plus one dark square).
    Checker {
        period_px: f64,
        phase_px: [f64; 2],
        low: f64,
        high: f64,
    },
    /// One bit of the binary-reflected Gray code of the projector's column
    /// (or row) index, full white where the bit is set (where it is clear
    /// when `inverted`): the structured light that calibrates a projector.
    /// Calibration bundles use it; scans need not.
    GrayCode {
        axis: GrayAxis,
        /// 0 is the finest stripes (one projector pixel wide).
        bit: u32,
        inverted: bool,
    },
}

/// Which projector index a Gray-code pattern encodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GrayAxis {
    Columns,
    Rows,
}

impl GrayAxis {
    pub fn name(self) -> &'static str {
        match self {
            GrayAxis::Columns => "columns",
            GrayAxis::Rows => "rows",
        }
    }
}

/// The binary-reflected Gray code of `x`.
pub fn gray_code(x: u64) -> u64 {
    x ^ (x >> 1)
}

/// The index whose Gray code is `g`.
pub fn gray_decode(mut g: u64) -> u64 {
    let mut shift = 1;
    while shift < 64 {
        g ^= g >> shift;
        shift <<= 1;
    }
    g
}

impl Pattern {
    /// The pattern value at integer projector pixel (column `u`, row `v`),
    /// exactly as the contract defines the checkerboard.
    pub fn value_at(&self, u: i64, v: i64) -> f64 {
        match *self {
            Pattern::Uniform { level } => level,
            Pattern::Checker {
                period_px,
                phase_px,
                low,
                high,
            } => {
                let half = period_px / 2.0;
                let i = ((u as f64 - phase_px[0]) / half).floor() as i64;
                let j = ((v as f64 - phase_px[1]) / half).floor() as i64;
                if (i + j).rem_euclid(2) == 0 {
                    high
                } else {
                    low
                }
            }
            Pattern::GrayCode {
                axis,
                bit,
                inverted,
            } => {
                let x = match axis {
                    GrayAxis::Columns => u,
                    GrayAxis::Rows => v,
                };
                let set = bit < 64 && (gray_code(x.max(0) as u64) >> bit) & 1 == 1;
                if set != inverted {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }
}

/// One photo taken at a position.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    pub name: String,
    /// Relative to the bundle folder.
    pub file: PathBuf,
    pub exposure_s: f64,
    /// Names of the rig lights switched on (all belong to the position).
    pub lights: Vec<String>,
    pub pattern: Option<Pattern>,
    /// Declared for PNG photos; `None` for EXR.
    pub encoding: Option<Encoding>,
}

/// What a capture is for, derived from its lights and pattern (the
/// contract's table), never from its name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CaptureRole {
    Ambient,
    /// One point light or the projector with a uniform pattern (or none).
    Lit {
        light: String,
    },
    Backlit,
    /// The projector showing a checkerboard.
    Pattern {
        light: String,
    },
    /// A combination the estimator has no use for (two flashes at once, ...).
    Other,
}

impl Capture {
    /// The role of this capture, given the lights of its position.
    pub fn role(&self, lights: &[Light]) -> CaptureRole {
        let kind_of = |n: &str| lights.iter().find(|l| l.name == n).map(|l| &l.kind);
        match self.lights.as_slice() {
            [] => CaptureRole::Ambient,
            [one] => match (kind_of(one), self.pattern) {
                (Some(LightKind::Backlight), None) => CaptureRole::Backlit,
                (Some(LightKind::Point { .. }), None) => CaptureRole::Lit { light: one.clone() },
                (Some(LightKind::Projector { .. }), None | Some(Pattern::Uniform { .. })) => {
                    CaptureRole::Lit { light: one.clone() }
                }
                (Some(LightKind::Projector { .. }), Some(Pattern::Checker { .. })) => {
                    CaptureRole::Pattern { light: one.clone() }
                }
                _ => CaptureRole::Other,
            },
            _ => CaptureRole::Other,
        }
    }

    /// The share of its light's full output that a capture without a
    /// pattern (1) or with a uniform one (its level, clamped to [0, 1])
    /// shows; `None` for a checker or a level that is not finite.
    pub fn uniform_level(&self) -> Option<f64> {
        match self.pattern {
            None => Some(1.0),
            Some(Pattern::Uniform { level }) if level.is_finite() => Some(level.clamp(0.0, 1.0)),
            Some(_) => None,
        }
    }
}

impl Position {
    pub fn light(&self, name: &str) -> Option<&Light> {
        self.lights.iter().find(|l| l.name == name)
    }

    pub fn capture(&self, name: &str) -> Option<&Capture> {
        self.captures.iter().find(|c| c.name == name)
    }

    /// The ambient capture (all rig lights off), if the position has one.
    pub fn ambient(&self) -> Option<&Capture> {
        self.captures
            .iter()
            .find(|c| c.role(&self.lights) == CaptureRole::Ambient)
    }
}

impl Position {
    /// Every capture with its role.
    pub fn captures_with_role(&self) -> impl Iterator<Item = (&Capture, CaptureRole)> {
        self.captures.iter().map(|c| (c, c.role(&self.lights)))
    }

    /// The lit captures (one point light, or the projector uniformly lit)
    /// with the name of their light: the views of this position.
    pub fn lit_captures(&self) -> impl Iterator<Item = (&Capture, String)> {
        self.captures_with_role().filter_map(|(c, r)| match r {
            CaptureRole::Lit { light } => Some((c, light)),
            _ => None,
        })
    }

    /// The first capture with only the backlight on, if any.
    pub fn backlit(&self) -> Option<&Capture> {
        self.captures_with_role()
            .find(|(_, r)| *r == CaptureRole::Backlit)
            .map(|(c, _)| c)
    }

    /// The projector checkerboard captures.
    pub fn pattern_captures(&self) -> impl Iterator<Item = &Capture> {
        self.captures_with_role()
            .filter(|(_, r)| matches!(r, CaptureRole::Pattern { .. }))
            .map(|(c, _)| c)
    }

    /// The camera of this position.
    pub fn pinhole(&self, intrinsics: Intrinsics) -> PinholeCamera {
        PinholeCamera::new(intrinsics, self.camera_to_world)
    }
}

impl Manifest {
    pub fn position(&self, name: &str) -> Option<&Position> {
        self.positions.iter().find(|p| p.name == name)
    }

    /// Parses and validates `scan.toml` text; `path` names the file in
    /// errors and warnings. Returns the manifest and one warning per key the
    /// format does not know (each also logged with `tracing::warn!`).
    pub fn parse(text: &str, path: &Path) -> Result<(Manifest, Vec<String>), ScanError> {
        parse::parse(text, path, parse::Captures::Required)
    }

    /// Parses a rig calibration file: the same format and rules, except
    /// that positions need no captures (the rig's geometry and lights,
    /// before any photo is taken).
    pub fn parse_rig(text: &str, path: &Path) -> Result<(Manifest, Vec<String>), ScanError> {
        parse::parse(text, path, parse::Captures::Optional)
    }

    /// This scan under the rig of the rig file `rig` (read from
    /// `rig_path`, which errors name): the camera (scaled to this scan's
    /// photo size), each position's pose, and each light's placement,
    /// colour and intensity, by name. An error names the position or light
    /// the rig file lacks; the manifest is then unchanged.
    pub fn adopt_rig(&mut self, rig: &Manifest, rig_path: &Path) -> Result<(), ScanError> {
        let mut out = self.clone();
        out.camera = rig.camera.scaled_to(self.camera.width, self.camera.height);
        for position in &mut out.positions {
            let missing = |key: &str, what: String| ScanError::Invalid {
                path: rig_path.to_path_buf(),
                key: key.into(),
                expected: what,
            };
            let from = rig.position(&position.name).ok_or_else(|| {
                missing(
                    "position",
                    format!("position `{}`, as the scan has", position.name),
                )
            })?;
            position.camera_to_world = from.camera_to_world;
            for light in &mut position.lights {
                let l = from.light(&light.name).ok_or_else(|| {
                    missing(
                        "position.light",
                        format!(
                            "light `{}` at position `{}`, as the scan has",
                            light.name, position.name
                        ),
                    )
                })?;
                light.kind = l.kind.clone();
                light.color = l.color;
                light.intensity = l.intensity;
            }
        }
        *self = out;
        Ok(())
    }

    /// Reads a rig calibration file (see [`Manifest::parse_rig`]).
    pub fn read_rig(path: &Path) -> Result<(Manifest, Vec<String>), ScanError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScanError::io(path, e))?;
        Self::parse_rig(&text, path)
    }

    /// Reads and validates a `scan.toml` file (see [`Manifest::parse`]).
    pub fn read(path: &Path) -> Result<(Manifest, Vec<String>), ScanError> {
        let text = std::fs::read_to_string(path).map_err(|e| ScanError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// The manifest as `scan.toml` text. For a manifest that passed
    /// validation, `Manifest::parse(&m.to_toml(), ..)` gives back exactly
    /// `m`; a hand-built manifest that breaks a rule produces text that
    /// fails to parse with the corresponding error.
    pub fn to_toml(&self) -> String {
        write::to_toml(self)
    }
}
