//! The calibration bundle, format `matscan-calib/1`: the photos a rig takes
//! of a printed board so that its cameras can be calibrated from them.
//!
//! A folder with `calib.toml` and the photos it lists:
//!
//! ```toml
//! format = "matscan-calib/1"
//! units = "m"
//!
//! [board]                       # a printed chessboard
//! kind = "chessboard"
//! inner_corners = [9, 6]        # corners where four squares meet: columns, rows
//! square = 0.06                 # edge of one square, in `units`
//! # where the board lies in world space in its reference placement (board
//! # frame: origin at inner corner (0, 0), x along the columns, y along the
//! # rows, z = x cross y into the board); row-major 4x4
//! reference_to_world = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]
//!
//! [[position]]
//! name = "p0"
//!   [[position.shot]]
//!   file = "p0/board-00.exr"    # linear RGB, as scan photos
//!   reference = true            # the board at its reference placement
//!   [[position.shot]]
//!   file = "p0/board-01.exr"
//!   seat = "turned"             # the board resting on a further seat
//!   [[position.shot]]
//!   file = "p0/board-02.exr"    # the board anywhere else in view
//! ```
//!
//! A shot may also carry the projector's Gray codes on the same board
//! (`graycode = "p0/projector-00"`: a folder with `columns-BB.exr`,
//! `columns-BB-inv.exr`, `rows-BB.exr` and `rows-BB-inv.exr` for every bit
//! `BB` of the projector's columns and rows, 00 the finest), which makes the
//! projector calibratable as an inverse camera; the projector's size is then
//! given once:
//!
//! ```toml
//! [projector]
//! width = 1024
//! height = 768
//! ```
//!
//! The projector is taken to be fixed to the camera (one scan head), so
//! Gray-code shots at any position calibrate it for every position.
//!
//! Every position needs a reference shot: the board resting at the same
//! place for every position (more than one photo of it averages the
//! camera's noise), which ties the camera's pose at each position
//! to the world frame. A shot with `seat = "NAME"` shows the board resting
//! on a further seat of the mount, the same for every position that names
//! it; where that seat holds the board need not be known (the calibration
//! finds it), only that it holds it the same way each time. Together with
//! the reference it is a target with depth, which fixes each position's
//! camera better than the reference alone. The other shots only constrain
//! the intrinsics, so the board may be held anywhere for them.
//!
//! Boundaries: the format only; detection and solving are the rig
//! calibration crate's.

use crate::error::ScanError;
use crate::manifest::GrayAxis;
use glam::{DMat4, DVec3};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format string of `calib.toml`.
pub const CALIB_FORMAT: &str = "matscan-calib/1";
/// The manifest's file name inside a calibration bundle.
pub const CALIB_MANIFEST: &str = "calib.toml";

/// A printed chessboard: its inner corners and square size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chessboard {
    /// Inner corners along a row (columns) and along a column (rows); each
    /// at least 3, and different, so the board's orientation is unambiguous
    /// up to a half turn.
    pub cols: u32,
    pub rows: u32,
    /// Edge of one square, in the bundle's units.
    pub square: f64,
}

impl Chessboard {
    /// The board-frame position of inner corner (`i` along the columns,
    /// `j` along the rows).
    pub fn corner(&self, i: u32, j: u32) -> DVec3 {
        DVec3::new(f64::from(i) * self.square, f64::from(j) * self.square, 0.0)
    }

    pub fn corner_count(&self) -> usize {
        self.cols as usize * self.rows as usize
    }

    /// Squares along a row and along a column (one more than the corners).
    pub fn squares(&self) -> (u32, u32) {
        (self.cols + 1, self.rows + 1)
    }
}

/// The name a capture gives the mount's further seat.
pub const SEAT: &str = "seat-2";

/// Frames a capture averages into each photo of a board, by where the
/// board is: averaging takes the camera's noise off the corners by the
/// root of the count, and the board must hold still for it (half a second
/// of video at 16 frames).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoardFrames {
    /// Each photo of a resting board (the reference and the seats), which a
    /// position's camera pose rests on.
    pub resting: usize,
    /// Each photo of a held board (the hand-held poses and the Gray-code
    /// poses' flash-lit photo), which the intrinsics rest on: propped on a
    /// stand, the board holds still; held by hand, 1.
    pub held: usize,
}

impl BoardFrames {
    /// 16 frames for every photo: against 4 resting frames and single held
    /// photos they take about two fifths and then another third off the
    /// camera's position error (docs/results.md).
    pub const DEFAULT: BoardFrames = BoardFrames {
        resting: 16,
        held: 16,
    };

    /// Most frames a capture averages into one photo.
    pub const MAX: usize = 64;

    /// An error naming `key` and saying what is expected unless `frames`
    /// is 1 to [`BoardFrames::MAX`].
    pub fn check(key: &str, frames: usize) -> Result<(), String> {
        if (1..=Self::MAX).contains(&frames) {
            return Ok(());
        }
        Err(format!(
            "{key} = {frames}: expected 1 to {} frames per photo of the board",
            Self::MAX
        ))
    }

    /// The frames averaged into a photo of the board at `placement`.
    pub fn for_placement(&self, placement: &BoardPlacement) -> usize {
        match placement {
            BoardPlacement::Held => self.held,
            BoardPlacement::Reference | BoardPlacement::Seat(_) => self.resting,
        }
    }
}

impl Default for BoardFrames {
    fn default() -> Self {
        BoardFrames::DEFAULT
    }
}

/// Where a shot's board was.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BoardPlacement {
    /// Held anywhere in view: the shot constrains the intrinsics only.
    Held,
    /// Resting at the reference placement, which defines the world.
    Reference,
    /// Resting on the named further seat of the mount.
    Seat(String),
}

/// One photo of the board.
#[derive(Debug, Clone, PartialEq)]
pub struct Shot {
    /// Relative to the bundle folder.
    pub file: PathBuf,
    pub placement: BoardPlacement,
    /// Folder of the projector's Gray-code photos of this board pose.
    pub graycode: Option<PathBuf>,
}

/// The projector's image size, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProjectorSize {
    pub width: u32,
    pub height: u32,
}

impl ProjectorSize {
    /// Gray-code bits along `axis`: enough to number every column or row.
    pub fn bits(&self, axis: GrayAxis) -> u32 {
        let n = match axis {
            GrayAxis::Columns => self.width,
            GrayAxis::Rows => self.height,
        };
        u32::BITS - n.max(2).saturating_sub(1).leading_zeros()
    }
}

/// The file of one Gray-code photo inside a shot's `graycode` folder.
pub fn graycode_file(axis: GrayAxis, bit: u32, inverted: bool) -> String {
    format!(
        "{}-{bit:02}{}.exr",
        axis.name(),
        if inverted { "-inv" } else { "" }
    )
}

#[derive(Debug, Clone, PartialEq)]
pub struct CalibPosition {
    pub name: String,
    pub shots: Vec<Shot>,
}

/// A validated `calib.toml`.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibManifest {
    pub units: String,
    pub board: Chessboard,
    /// Board frame to world at the reference placement.
    pub reference_to_world: DMat4,
    pub positions: Vec<CalibPosition>,
    /// Present when some shot has Gray codes.
    pub projector: Option<ProjectorSize>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    format: String,
    #[serde(default = "default_units")]
    units: String,
    board: RawBoard,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    projector: Option<RawProjector>,
    #[serde(rename = "position", default)]
    positions: Vec<RawPosition>,
}

fn default_units() -> String {
    "m".into()
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBoard {
    kind: String,
    inner_corners: [u32; 2],
    square: f64,
    reference_to_world: [f64; 16],
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawProjector {
    width: u32,
    height: u32,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPosition {
    name: String,
    #[serde(rename = "shot", default)]
    shots: Vec<RawShot>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShot {
    file: PathBuf,
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    reference: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    seat: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    graycode: Option<PathBuf>,
}

impl CalibManifest {
    /// Reads and validates `calib.toml` in `dir`.
    pub fn read(dir: &Path) -> Result<CalibManifest, ScanError> {
        let (text, path) = read_manifest(dir, CALIB_MANIFEST)?;
        Self::parse(&text, &path)
    }

    /// Parses `calib.toml` text; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<CalibManifest, ScanError> {
        let raw: RawManifest =
            parse_manifest(text, path, CALIB_FORMAT, |r: &RawManifest| &r.format)?;
        let invalid = invalid_key(path);
        if raw.board.kind != "chessboard" {
            return Err(invalid(
                "board.kind",
                "expected \"chessboard\" (the only board this version reads)",
            ));
        }
        let [cols, rows] = raw.board.inner_corners;
        if cols < 3 || rows < 3 || cols == rows {
            return Err(invalid(
                "board.inner_corners",
                "expected two different counts of at least 3 (columns, rows), so the \
                 board's orientation can be told",
            ));
        }
        if !(raw.board.square.is_finite() && raw.board.square > 0.0) {
            return Err(invalid("board.square", "expected a positive length"));
        }
        let reference_to_world = crate::camera::mat4_from_row_major(&raw.board.reference_to_world);
        if !is_rigid(&reference_to_world) {
            return Err(invalid(
                "board.reference_to_world",
                "expected a rigid transform (rotation and translation, last row 0 0 0 1)",
            ));
        }
        if let Some(p) = &raw.projector {
            if p.width < 2 || p.height < 2 {
                return Err(invalid(
                    "projector",
                    "expected a width and height of at least 2 pixels",
                ));
            }
        }
        if raw.positions.is_empty() {
            return Err(invalid("position", "expected at least one [[position]]"));
        }
        let mut positions = Vec::with_capacity(raw.positions.len());
        for (k, p) in raw.positions.into_iter().enumerate() {
            if p.name.is_empty() || positions.iter().any(|q: &CalibPosition| q.name == p.name) {
                return Err(invalid(
                    &format!("position[{k}].name"),
                    "expected a unique, non-empty name",
                ));
            }
            if !p.shots.iter().any(|s| s.reference) {
                return Err(invalid(
                    &format!("position[{k}].shot"),
                    &format!(
                        "expected a shot with `reference = true` at position {}: the board \
                         at its reference placement",
                        p.name
                    ),
                ));
            }
            for (s, shot) in p.shots.iter().enumerate() {
                match &shot.seat {
                    Some(seat) if seat.is_empty() || shot.reference => {
                        return Err(invalid(
                            &format!("position[{k}].shot[{s}].seat"),
                            "expected a non-empty seat name on a shot without \
                             `reference = true` (a board rests in one place at a time)",
                        ));
                    }
                    _ => {}
                }
                let inside = inside_bundle;
                if !inside(&shot.file) {
                    return Err(invalid(
                        &format!("position[{k}].shot[{s}].file"),
                        "expected a path inside the bundle folder",
                    ));
                }
                if let Some(g) = &shot.graycode {
                    if !inside(g) {
                        return Err(invalid(
                            &format!("position[{k}].shot[{s}].graycode"),
                            "expected a folder inside the bundle folder",
                        ));
                    }
                    if raw.projector.is_none() {
                        return Err(invalid(
                            "projector",
                            "expected [projector] width and height: a shot has Gray codes",
                        ));
                    }
                }
            }
            positions.push(CalibPosition {
                name: p.name,
                shots: p
                    .shots
                    .into_iter()
                    .map(|s| Shot {
                        file: s.file,
                        placement: match (s.reference, s.seat) {
                            (true, _) => BoardPlacement::Reference,
                            (false, Some(seat)) => BoardPlacement::Seat(seat),
                            (false, None) => BoardPlacement::Held,
                        },
                        graycode: s.graycode,
                    })
                    .collect(),
            });
        }
        Ok(CalibManifest {
            units: raw.units,
            board: Chessboard {
                cols,
                rows,
                square: raw.board.square,
            },
            reference_to_world,
            positions,
            projector: raw.projector.map(|p| ProjectorSize {
                width: p.width,
                height: p.height,
            }),
        })
    }

    /// The manifest as `calib.toml` text.
    pub fn to_toml(&self) -> String {
        let raw = RawManifest {
            format: CALIB_FORMAT.into(),
            units: self.units.clone(),
            board: RawBoard {
                kind: "chessboard".into(),
                inner_corners: [self.board.cols, self.board.rows],
                square: self.board.square,
                reference_to_world: crate::camera::mat4_to_row_major(&self.reference_to_world),
            },
            projector: self.projector.map(|p| RawProjector {
                width: p.width,
                height: p.height,
            }),
            positions: self
                .positions
                .iter()
                .map(|p| RawPosition {
                    name: p.name.clone(),
                    shots: p
                        .shots
                        .iter()
                        .map(|s| RawShot {
                            file: s.file.clone(),
                            reference: s.placement == BoardPlacement::Reference,
                            seat: match &s.placement {
                                BoardPlacement::Seat(seat) => Some(seat.clone()),
                                _ => None,
                            },
                            graycode: s.graycode.clone(),
                        })
                        .collect(),
                })
                .collect(),
        };
        // Plain data with string keys: serializing cannot fail.
        toml::to_string(&raw).unwrap_or_default()
    }
}

/// Whether `path` stays inside a bundle's folder: relative, and never up.
/// Reads the manifest `file` of the bundle in `dir`: its text and path.
pub(crate) fn read_manifest(dir: &Path, file: &str) -> Result<(String, PathBuf), ScanError> {
    let path = dir.join(file);
    let text = std::fs::read_to_string(&path).map_err(|e| ScanError::io(&path, e))?;
    Ok((text, path))
}

/// Manifest `text` (at `path`, which errors name) as `T`, its `format`
/// key (`format_of`) checked to be `want`.
pub(crate) fn parse_manifest<T: serde::de::DeserializeOwned>(
    text: &str,
    path: &Path,
    want: &str,
    format_of: impl Fn(&T) -> &str,
) -> Result<T, ScanError> {
    let raw: T = toml::from_str(text).map_err(|e| ScanError::format(path, e.to_string()))?;
    if format_of(&raw) != want {
        return Err(invalid_key(path)("format", &format!("expected \"{want}\"")));
    }
    Ok(raw)
}

/// The error of key `key` of the manifest at `path`, saying what was
/// expected.
pub(crate) fn invalid_key(path: &Path) -> impl Fn(&str, &str) -> ScanError + '_ {
    move |key: &str, expected: &str| ScanError::Invalid {
        path: path.to_path_buf(),
        key: key.into(),
        expected: expected.into(),
    }
}

pub(crate) fn inside_bundle(path: &Path) -> bool {
    !path.is_absolute()
        && !path
            .components()
            .any(|c| matches!(c, std::path::Component::ParentDir))
}

/// A finite transform whose upper 3x3 is a rotation and whose last row is
/// `0 0 0 1`.
pub fn is_rigid(m: &DMat4) -> bool {
    let r = glam::DMat3::from_mat4(*m);
    let last = m.row(3);
    m.to_cols_array().iter().all(|v| v.is_finite())
        && (last - glam::DVec4::new(0.0, 0.0, 0.0, 1.0))
            .abs()
            .max_element()
            < 1e-9
        && (r.transpose() * r - glam::DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|v| v.abs() < 1e-6)
        && r.determinant() > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
format = "matscan-calib/1"
[board]
kind = "chessboard"
inner_corners = [9, 6]
square = 0.05
reference_to_world = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]
[[position]]
name = "p0"
  [[position.shot]]
  file = "p0/board-00.exr"
  reference = true
  [[position.shot]]
  file = "p0/board-01.exr"
  [[position.shot]]
  file = "p0/board-02.exr"
  seat = "turned"
"#;

    #[test]
    fn a_written_manifest_reads_back_the_same() {
        let m = CalibManifest::parse(GOOD, Path::new("calib.toml")).unwrap();
        assert_eq!(m.board.cols, 9);
        assert_eq!(m.board.corner(2, 1), DVec3::new(0.1, 0.05, 0.0));
        let placements: Vec<&BoardPlacement> =
            m.positions[0].shots.iter().map(|s| &s.placement).collect();
        assert_eq!(
            placements,
            [
                &BoardPlacement::Reference,
                &BoardPlacement::Held,
                &BoardPlacement::Seat("turned".into())
            ]
        );
        let again = CalibManifest::parse(&m.to_toml(), Path::new("calib.toml")).unwrap();
        assert_eq!(again, m);
    }

    fn error_of(text: &str) -> String {
        CalibManifest::parse(text, Path::new("/x/calib.toml"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn gray_code_shots_need_the_projectors_size() {
        let with_codes = GOOD.replace(
            "file = \"p0/board-01.exr\"",
            "file = \"p0/board-01.exr\"\ngraycode = \"p0/projector-01\"",
        );
        let e = error_of(&with_codes);
        assert!(e.contains("projector"), "{e}");
        let sized = with_codes.replace(
            "[[position]]",
            "[projector]\nwidth = 1024\nheight = 768\n[[position]]",
        );
        let m = CalibManifest::parse(&sized, Path::new("calib.toml")).unwrap();
        let size = m.projector.unwrap();
        assert_eq!(
            (size.bits(GrayAxis::Columns), size.bits(GrayAxis::Rows)),
            (10, 10)
        );
        assert_eq!(
            m.positions[0].shots[1].graycode,
            Some(PathBuf::from("p0/projector-01"))
        );
        assert_eq!(
            CalibManifest::parse(&m.to_toml(), Path::new("c")).unwrap(),
            m
        );
        assert_eq!(graycode_file(GrayAxis::Rows, 3, true), "rows-03-inv.exr");
        assert_eq!(
            ProjectorSize {
                width: 1025,
                height: 2
            }
            .bits(GrayAxis::Columns),
            11
        );
    }

    #[test]
    fn a_square_board_is_refused_as_ambiguous() {
        let e = error_of(&GOOD.replace("[9, 6]", "[6, 6]"));
        assert!(e.contains("board.inner_corners"), "{e}");
    }

    #[test]
    fn a_seat_on_the_reference_shot_or_without_a_name_is_refused() {
        let both = GOOD.replace("reference = true", "reference = true\n  seat = \"turned\"");
        let e = error_of(&both);
        assert!(e.contains("position[0].shot[0].seat"), "{e}");
        let e = error_of(&GOOD.replace("seat = \"turned\"", "seat = \"\""));
        assert!(e.contains("position[0].shot[2].seat"), "{e}");
    }

    #[test]
    fn a_position_without_one_reference_shot_is_named() {
        let e = error_of(&GOOD.replace("reference = true", ""));
        assert!(e.contains("position[0].shot") && e.contains("p0"), "{e}");
    }

    #[test]
    fn a_non_rigid_reference_pose_is_refused() {
        let e = error_of(&GOOD.replace("[1,0,0,0,", "[2,0,0,0,"));
        assert!(e.contains("reference_to_world"), "{e}");
    }

    #[test]
    fn a_shot_outside_the_folder_is_refused() {
        let e = error_of(&GOOD.replace("p0/board-01.exr", "../board.exr"));
        assert!(e.contains("shot[1].file"), "{e}");
    }

    #[test]
    fn an_unknown_key_is_named() {
        let e = error_of(&GOOD.replace("square = 0.05", "square = 0.05\nsquares = 3"));
        assert!(e.contains("squares"), "{e}");
    }
}
