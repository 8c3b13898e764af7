//! Writing a [`Manifest`] as `scan.toml` text, laid out like the contract's
//! example (matrices four numbers to a line) so the file stays readable.
//!
//! Numbers are written in Rust's shortest round-trip form, so parsing the
//! text gives back exactly the same manifest.

use super::{Capture, Encoding, Light, LightKind, Manifest, Pattern, Position, FORMAT};
use crate::camera::{mat4_to_row_major, Intrinsics};
use glam::DMat4;
use std::fmt::Write;

pub(super) fn to_toml(m: &Manifest) -> String {
    let mut out = String::new();
    line(&mut out, "format", &string(FORMAT));
    line(&mut out, "units", &string(&m.units));
    line(&mut out, "name", &string(&m.name));
    line(&mut out, "created", &string(&m.created));
    out.push_str("\n[camera]\n");
    intrinsics(&mut out, &m.camera, true);
    for p in &m.positions {
        position(&mut out, p);
    }
    out
}

fn position(out: &mut String, p: &Position) {
    out.push_str("\n[[position]]\n");
    line(out, "name", &string(&p.name));
    line(out, "camera_to_world", &matrix(&p.camera_to_world));
    if let Some(mask) = &p.white_reference_mask {
        out.push_str("\n[position.white_reference]\n");
        line(out, "mask", &string(&path(mask)));
    }
    for l in &p.lights {
        light(out, l);
    }
    for c in &p.captures {
        capture(out, c);
    }
}

fn light(out: &mut String, l: &Light) {
    out.push_str("\n[[position.light]]\n");
    line(out, "name", &string(&l.name));
    match &l.kind {
        LightKind::Point { position } => {
            line(out, "kind", &string("point"));
            line(out, "position", &numbers(&position.to_array()));
        }
        LightKind::Projector {
            projector_to_world,
            intrinsics: k,
        } => {
            line(out, "kind", &string("projector"));
            line(out, "projector_to_world", &matrix(projector_to_world));
            intrinsics(out, k, false);
        }
        LightKind::Backlight => line(out, "kind", &string("backlight")),
    }
    if l.color != [1.0; 3] {
        line(out, "color", &numbers(&l.color));
    }
    if let Some(i) = l.intensity {
        line(out, "intensity", &number(i));
    }
}

fn capture(out: &mut String, c: &Capture) {
    out.push_str("\n[[position.capture]]\n");
    line(out, "name", &string(&c.name));
    line(out, "file", &string(&path(&c.file)));
    line(out, "exposure_s", &number(c.exposure_s));
    let lights: Vec<String> = c.lights.iter().map(|l| string(l)).collect();
    line(out, "lights", &format!("[{}]", lights.join(", ")));
    if let Some(p) = &c.pattern {
        line(out, "pattern", &pattern(p));
    }
    match c.encoding {
        Some(Encoding::Linear) => line(out, "encoding", &string("linear")),
        Some(Encoding::Srgb) => line(out, "encoding", &string("srgb")),
        None => {}
    }
}

fn pattern(p: &Pattern) -> String {
    match *p {
        Pattern::Uniform { level } => {
            format!("{{ kind = \"uniform\", level = {} }}", number(level))
        }
        Pattern::Checker {
            period_px,
            phase_px,
            low,
            high,
        } => format!(
            "{{ kind = \"checker\", period_px = {}, phase_px = {}, low = {}, high = {} }}",
            number(period_px),
            numbers(&phase_px),
            number(low),
            number(high)
        ),
        Pattern::GrayCode {
            axis,
            bit,
            inverted,
        } => format!(
            "{{ kind = \"graycode\", axis = \"{}\", bit = {bit}, inverted = {inverted} }}",
            axis.name()
        ),
    }
}

fn intrinsics(out: &mut String, k: &Intrinsics, with_distortion: bool) {
    line(out, "width", &k.width.to_string());
    line(out, "height", &k.height.to_string());
    line(out, "fx", &number(k.fx));
    line(out, "fy", &number(k.fy));
    line(out, "cx", &number(k.cx));
    line(out, "cy", &number(k.cy));
    if with_distortion && k.has_distortion() {
        line(out, "distortion", &numbers(&k.distortion));
    }
}

fn line(out: &mut String, key: &str, value: &str) {
    // Writing to a String cannot fail.
    let _ = writeln!(out, "{key} = {value}");
}

fn matrix(m: &DMat4) -> String {
    let rows = mat4_to_row_major(m);
    let rows: Vec<String> = rows
        .chunks(4)
        .map(|r| r.iter().map(|&x| number(x)).collect::<Vec<_>>().join(", "))
        .collect();
    format!("[\n  {},\n]", rows.join(",\n  "))
}

fn numbers(xs: &[f64]) -> String {
    let xs: Vec<String> = xs.iter().map(|&x| number(x)).collect();
    format!("[{}]", xs.join(", "))
}

/// A TOML float that parses back to exactly `x`. `Debug` is Rust's shortest
/// round-trip form and always has a `.` or an exponent for finite values;
/// non-finite values (which a validated manifest never holds) are written as
/// TOML's `nan`/`inf` so that reading them fails with a clear message.
fn number(x: f64) -> String {
    if x.is_nan() {
        "nan".to_string()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_string()
    } else {
        let s = format!("{x:?}");
        if s.contains(['.', 'e', 'E']) {
            s
        } else {
            format!("{s}.0")
        }
    }
}

fn string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// Manifest paths always use `/`, whatever the host system.
fn path(p: &std::path::Path) -> String {
    p.components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/")
}

#[cfg(test)]
mod tests {
    use super::number;

    #[test]
    fn numbers_parse_back_exactly() {
        for x in [
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-300,
            1e300,
            1e20,
            123456789.0,
            -2.5e-7,
            355.6,
            5e-324,
        ] {
            let text = format!("x = {}", number(x));
            let t: toml::Table = text.parse().unwrap();
            assert_eq!(t["x"].as_float().unwrap().to_bits(), x.to_bits(), "{text}");
        }
    }
}
