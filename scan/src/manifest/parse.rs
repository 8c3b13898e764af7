//! Validation of a parsed `scan.toml` into the typed [`Manifest`]: every
//! rule of the contract, each failure naming the file, the key path and
//! what was expected (see `docs/scan-format.md` for the list of rules).

use super::fields::{describe, Fields};
use super::{Capture, Encoding, GrayAxis, Light, LightKind, Manifest, Pattern, Position, FORMAT};
use crate::camera::{mat4_from_row_major, Intrinsics};
use crate::error::ScanError;
use glam::{DMat3, DMat4, DVec3};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use toml::{Table, Value};

/// What a manifest must contain beyond its geometry.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Captures {
    /// A scan: every position has an ambient capture.
    Required,
    /// A rig calibration: geometry and lights only; captures, where
    /// present, are still validated.
    Optional,
}

pub(super) fn parse(
    text: &str,
    path: &Path,
    rule: Captures,
) -> Result<(Manifest, Vec<String>), ScanError> {
    let table: Table = text
        .parse()
        .map_err(|e: toml::de::Error| ScanError::format(path, format!("not valid TOML: {e}")))?;
    let mut warnings = Vec::new();
    let mut top = Fields::new(path, &table, String::new());
    check_format(&mut top)?;

    let units = top.opt_string("units")?.unwrap_or_else(|| "m".to_string());
    if units.trim().is_empty() {
        return Err(top.error(
            "units",
            "expected a length unit such as \"m\", found an empty string",
        ));
    }
    let name = top.opt_string("name")?.unwrap_or_default();
    let created = match top.get("created") {
        None => String::new(),
        Some(Value::String(s)) => s.clone(),
        // A bare TOML datetime is what a hand-written RFC 3339 value parses as.
        Some(Value::Datetime(d)) => d.to_string(),
        Some(other) => {
            return Err(top.error(
                "created",
                format!(
                    "expected an RFC 3339 timestamp string, found {}",
                    describe(other)
                ),
            ))
        }
    };

    let mut camera_fields = top.table("camera")?;
    let camera = intrinsics(&mut camera_fields, true)?;
    camera_fields.finish(&mut warnings);

    let position_fields = top.array_of_tables("position")?;
    if position_fields.is_empty() {
        return Err(top.error("position", "missing; expected at least one [[position]]"));
    }
    let mut positions: Vec<Position> = Vec::with_capacity(position_fields.len());
    for mut fields in position_fields {
        let position = position(&mut fields, &mut warnings, rule)?;
        if positions.iter().any(|p| p.name == position.name) {
            return Err(fields.error(
                "name",
                format!(
                    "expected a unique position name; {:?} is used twice",
                    position.name
                ),
            ));
        }
        fields.finish(&mut warnings);
        positions.push(position);
    }
    top.finish(&mut warnings);

    for w in &warnings {
        tracing::warn!("{w}");
    }
    Ok((
        Manifest {
            units,
            name,
            created,
            camera,
            positions,
        },
        warnings,
    ))
}

fn check_format(top: &mut Fields<'_>) -> Result<(), ScanError> {
    let expected = format!("format = {FORMAT:?}");
    match top.get("format") {
        None => Err(top.error(
            "format",
            format!("missing; expected {expected} (is this a matscan scan.toml?)"),
        )),
        Some(Value::String(s)) if s == FORMAT => Ok(()),
        Some(Value::String(s)) if s.starts_with("matscan-scan/") => Err(top.error(
            "format",
            format!("this reader reads {FORMAT}, found {s:?} (written by a later matscan?)"),
        )),
        Some(other) => Err(top.error(
            "format",
            format!("expected {expected}, found {}", describe(other)),
        )),
    }
}

fn intrinsics(f: &mut Fields<'_>, with_distortion: bool) -> Result<Intrinsics, ScanError> {
    let width = f.pixels("width")?;
    let height = f.pixels("height")?;
    let fx = f.positive("fx", " (focal length in pixels)")?;
    let fy = f.positive("fy", " (focal length in pixels)")?;
    let cx = f.number("cx")?;
    let cy = f.number("cy")?;
    let distortion = if with_distortion {
        f.opt_numbers::<5>("distortion")?.unwrap_or([0.0; 5])
    } else {
        [0.0; 5]
    };
    Ok(Intrinsics {
        width,
        height,
        fx,
        fy,
        cx,
        cy,
        distortion,
    })
}

/// A 4x4 row-major affine transform that can be inverted.
fn matrix(f: &mut Fields<'_>, name: &'static str) -> Result<DMat4, ScanError> {
    let m = f.numbers::<16>(name)?;
    // Tolerant of the rounding of exporters that compute poses by products.
    let last_row_ok = m[12..]
        .iter()
        .zip([0.0, 0.0, 0.0, 1.0])
        .all(|(a, b)| (a - b).abs() <= 1e-9);
    if !last_row_ok {
        return Err(f.error(
            name,
            format!(
                "expected an affine transform whose last row is 0 0 0 1, found {} {} {} {}",
                m[12], m[13], m[14], m[15]
            ),
        ));
    }
    let linear = DMat3::from_cols_array(&[m[0], m[4], m[8], m[1], m[5], m[9], m[2], m[6], m[10]]);
    let scale = linear
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, &b| a.max(b.abs()));
    // Scale-free test: the determinant of a well-conditioned pose is about
    // scale^3, a singular one is 0 up to rounding.
    if scale == 0.0 || linear.determinant().abs() <= 1e-9 * scale.powi(3) {
        return Err(f.error(
            name,
            "expected an invertible transform; its 3x3 part is singular",
        ));
    }
    Ok(mat4_from_row_major(&m))
}

fn position(
    f: &mut Fields<'_>,
    warnings: &mut Vec<String>,
    rule: Captures,
) -> Result<Position, ScanError> {
    let name = f.string("name")?;
    check_folder_name(f, "name", &name, "position")?;
    let camera_to_world = matrix(f, "camera_to_world")?;

    let mut lights: Vec<Light> = Vec::new();
    for mut lf in f.array_of_tables("light")? {
        let l = light(&mut lf)?;
        if lights.iter().any(|o| o.name == l.name) {
            return Err(lf.error(
                "name",
                format!(
                    "expected a unique light name in position {name:?}; {:?} is used twice",
                    l.name
                ),
            ));
        }
        lf.finish(warnings);
        lights.push(l);
    }

    let mut captures: Vec<Capture> = Vec::new();
    for mut cf in f.array_of_tables("capture")? {
        let c = capture(&mut cf, &name, &lights, warnings)?;
        if captures.iter().any(|o| o.name == c.name) {
            return Err(cf.error(
                "name",
                format!(
                    "expected a unique capture name in position {name:?}; {:?} is used twice",
                    c.name
                ),
            ));
        }
        cf.finish(warnings);
        captures.push(c);
    }
    if rule == Captures::Required && !captures.iter().any(|c| c.lights.is_empty()) {
        return Err(f.error(
            "capture",
            "expected an ambient capture (lights = [], no pattern): every position needs one",
        ));
    }

    let white_reference_mask = match f.opt_table("white_reference")? {
        None => None,
        Some(mut wf) => {
            let mask = wf.string("mask")?;
            let mask = relative_file(&wf, "mask", &mask, &["png"])?;
            wf.finish(warnings);
            Some(mask)
        }
    };

    Ok(Position {
        name,
        camera_to_world,
        lights,
        captures,
        white_reference_mask,
    })
}

fn light(f: &mut Fields<'_>) -> Result<Light, ScanError> {
    let name = f.string("name")?;
    if name.is_empty() {
        return Err(f.error("name", "expected a non-empty light name"));
    }
    let color = match f.opt_numbers::<3>("color")? {
        None => [1.0; 3],
        Some(c) if c.iter().all(|&x| x >= 0.0) => c,
        Some(c) => {
            return Err(f.error(
                "color",
                format!(
                    "expected 3 non-negative numbers (relative linear RGB), found [{}, {}, {}]",
                    c[0], c[1], c[2]
                ),
            ))
        }
    };
    let intensity = match f.opt_number("intensity")? {
        Some(x) if x <= 0.0 => {
            return Err(f.error(
                "intensity",
                format!("expected a positive number, found {x}"),
            ))
        }
        other => other,
    };
    let kind = match f.string("kind")?.as_str() {
        "point" => LightKind::Point {
            position: DVec3::from_array(f.numbers::<3>("position")?),
        },
        "projector" => LightKind::Projector {
            projector_to_world: matrix(f, "projector_to_world")?,
            intrinsics: intrinsics(f, false)?,
        },
        "backlight" => LightKind::Backlight,
        other => {
            return Err(f.error(
                "kind",
                format!("expected \"point\", \"projector\" or \"backlight\", found {other:?}"),
            ))
        }
    };
    Ok(Light {
        name,
        kind,
        color,
        intensity,
    })
}

fn capture(
    f: &mut Fields<'_>,
    position: &str,
    lights: &[Light],
    warnings: &mut Vec<String>,
) -> Result<Capture, ScanError> {
    let name = f.string("name")?;
    check_folder_name(f, "name", &name, "capture")?;
    let file = f.string("file")?;
    let file = relative_file(f, "file", &file, &["exr", "png"])?;
    let exposure_s = f.positive("exposure_s", " (seconds)")?;

    let used = f.strings(
        "lights",
        "a list of light names (use [] for the ambient capture)",
    )?;
    let mut seen = BTreeSet::new();
    for l in &used {
        if !lights.iter().any(|k| &k.name == l) {
            let have: Vec<&str> = lights.iter().map(|k| k.name.as_str()).collect();
            let have = if have.is_empty() {
                "it has no lights".to_string()
            } else {
                format!("it has {}", have.join(", "))
            };
            return Err(f.error(
                "lights",
                format!("names light `{l}`, which position {position:?} does not have ({have})"),
            ));
        }
        if !seen.insert(l.as_str()) {
            return Err(f.error("lights", format!("names light `{l}` twice")));
        }
    }

    let pattern = match f.opt_table("pattern")? {
        None => None,
        Some(mut pf) => {
            let p = pattern(&mut pf)?;
            pf.finish(warnings);
            let projector = used.iter().any(|l| {
                lights
                    .iter()
                    .any(|k| &k.name == l && matches!(k.kind, LightKind::Projector { .. }))
            });
            if !projector {
                return Err(f.error(
                    "pattern",
                    "expected no pattern: a pattern is shown by a projector and `lights` names none",
                ));
            }
            Some(p)
        }
    };

    let is_png = has_extension(&file, "png");
    let encoding = match (f.opt_string("encoding")?.as_deref(), is_png) {
        (Some("linear"), true) => Some(Encoding::Linear),
        (Some("srgb"), true) => Some(Encoding::Srgb),
        (None, true) => {
            return Err(f.error(
                "encoding",
                "missing; expected \"linear\" or \"srgb\": a PNG photo must declare how it encodes radiance",
            ))
        }
        (Some("linear"), false) | (None, false) => None,
        (Some("srgb"), false) => {
            return Err(f.error(
                "encoding",
                "expected \"linear\" or nothing: EXR photos are always linear",
            ))
        }
        (Some(other), _) => {
            return Err(f.error(
                "encoding",
                format!("expected \"linear\" or \"srgb\", found {other:?}"),
            ))
        }
    };

    Ok(Capture {
        name,
        file,
        exposure_s,
        lights: used,
        pattern,
        encoding,
    })
}

fn pattern(f: &mut Fields<'_>) -> Result<Pattern, ScanError> {
    match f.string("kind")?.as_str() {
        "uniform" => Ok(Pattern::Uniform {
            level: f.unit_interval("level", None)?,
        }),
        "checker" => Ok(Pattern::Checker {
            period_px: f.positive("period_px", " (projector pixels)")?,
            phase_px: f.opt_numbers::<2>("phase_px")?.unwrap_or([0.0; 2]),
            low: f.unit_interval("low", Some(0.0))?,
            high: f.unit_interval("high", Some(1.0))?,
        }),
        "graycode" => Ok(Pattern::GrayCode {
            axis: match f.string("axis")?.as_str() {
                "columns" => GrayAxis::Columns,
                "rows" => GrayAxis::Rows,
                other => {
                    return Err(f.error(
                        "axis",
                        format!("expected \"columns\" or \"rows\", found {other:?}"),
                    ))
                }
            },
            bit: {
                let bit = f.number("bit")?;
                if !(bit.fract() == 0.0 && (0.0..32.0).contains(&bit)) {
                    return Err(f.error("bit", "expected an integer from 0 to 31"));
                }
                bit as u32
            },
            inverted: match f.get("inverted") {
                None => false,
                Some(v) => v
                    .as_bool()
                    .ok_or_else(|| f.error("inverted", "expected true or false"))?,
            },
        }),
        other => Err(f.error(
            "kind",
            format!("expected \"uniform\", \"checker\" or \"graycode\", found {other:?}"),
        )),
    }
}

/// Position and capture names become folder and file names
/// (`truth/<position>/illum_<capture>.exr`), so they must be safe as one.
fn check_folder_name(f: &Fields<'_>, key: &str, name: &str, what: &str) -> Result<(), ScanError> {
    let bad = name.is_empty()
        || name == "."
        || name == ".."
        || name
            .chars()
            .any(|c| c == '/' || c == '\\' || c.is_control());
    if bad {
        return Err(f.error(
            key,
            format!(
                "expected a {what} name usable as a file name (non-empty, no / or \\, \
                 not . or ..), found {name:?}"
            ),
        ));
    }
    Ok(())
}

/// A path inside the bundle: relative, `/`-separated, no `.`/`..` segments,
/// with one of `extensions` (compared without case).
fn relative_file(
    f: &Fields<'_>,
    key: &str,
    value: &str,
    extensions: &[&str],
) -> Result<PathBuf, ScanError> {
    let wanted = extensions
        .iter()
        .map(|e| format!(".{e}"))
        .collect::<Vec<_>>()
        .join(" or ");
    let fail = |why: &str| {
        f.error(
            key,
            format!(
                "expected a {wanted} file path relative to the bundle folder{why}, found {value:?}"
            ),
        )
    };
    if value.contains('\\') {
        return Err(fail(", with / as separator"));
    }
    let drive = value.len() >= 2 && value.as_bytes()[1] == b':';
    if value.starts_with('/') || drive || Path::new(value).is_absolute() {
        return Err(fail(" (not absolute)"));
    }
    if value
        .split('/')
        .any(|s| s.is_empty() || s == "." || s == ".." || s.chars().any(char::is_control))
    {
        return Err(fail(" (no empty, . or .. segments)"));
    }
    let path = PathBuf::from(value);
    if !extensions.iter().any(|e| has_extension(&path, e)) {
        return Err(fail(""));
    }
    Ok(path)
}

pub(crate) fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_test_accepts_poses_at_any_scale_and_rejects_singular_ones() {
        let path = Path::new("scan.toml");
        let check = |m: &str| {
            let t: Table = format!("m = {m}").parse().unwrap();
            let mut f = Fields::new(path, &t, String::new());
            matrix(&mut f, "m").map(|_| ())
        };
        assert!(check("[1e-3,0,0,5e2, 0,1e-3,0,0, 0,0,1e-3,0, 0,0,0,1]").is_ok());
        assert!(check("[1e3,0,0,-1e3, 0,0,1e3,0, 0,-1e3,0,0, 0,0,0,1]").is_ok());
        let err = check("[1,0,0,0, 2,0,0,0, 0,0,1,0, 0,0,0,1]").unwrap_err();
        assert!(err.to_string().contains("singular"), "{err}");
        let err = check("[0,0,0,0, 0,0,0,0, 0,0,0,0, 0,0,0,1]").unwrap_err();
        assert!(err.to_string().contains("singular"), "{err}");
    }
}
