//! Shared fixtures of the integration tests: a valid manifest exercising
//! every feature of the format, and helpers to derive broken ones.
#![allow(dead_code)]

use matscan_scan::{Manifest, ScanError};
use std::path::Path;

/// A valid manifest: the contract's example (8x6 camera so bundles stay
/// tiny) plus a white reference, a uniform projector capture, a backlit
/// capture, an sRGB PNG photo and a second, minimal position.
pub const VALID: &str = r#"
format = "matscan-scan/1"
units = "m"
name = "ape-2mat-0007"
created = "2026-11-23T08:40:00Z"

[camera]
width = 8
height = 6
fx = 355.6
fy = 355.6
cx = 4.0
cy = 3.0
distortion = [0.01, -0.002, 0.0, 0.0, 0.0]

[[position]]
name = "p0"
camera_to_world = [1,0,0,0, 0,1,0,0, 0,0,1,-1.5, 0,0,0,1]

  [position.white_reference]
  mask = "views/p0/white.png"

  [[position.light]]
  name = "flash0"
  kind = "point"
  position = [0.0, 0.0, -1.5]
  color = [1.0, 0.98, 0.9]

  [[position.light]]
  name = "flash1"
  kind = "point"
  position = [0.3, 0.0, -1.5]
  intensity = 2.5

  [[position.light]]
  name = "projector"
  kind = "projector"
  projector_to_world = [1,0,0,0.2, 0,1,0,0, 0,0,1,-1.5, 0,0,0,1]
  width = 1280
  height = 800
  fx = 1500.0
  fy = 1500.0
  cx = 640.0
  cy = 400.0

  [[position.light]]
  name = "backlight"
  kind = "backlight"

  [[position.capture]]
  name = "ambient"
  file = "views/p0/ambient.exr"
  exposure_s = 0.02
  lights = []

  [[position.capture]]
  name = "flash0"
  file = "views/p0/flash0.exr"
  exposure_s = 0.02
  lights = ["flash0"]

  [[position.capture]]
  name = "phone"
  file = "views/p0/phone.png"
  exposure_s = 0.01
  lights = ["flash1"]
  encoding = "srgb"

  [[position.capture]]
  name = "uniform"
  file = "views/p0/uniform.exr"
  exposure_s = 0.02
  lights = ["projector"]
  pattern = { kind = "uniform", level = 0.5 }

  [[position.capture]]
  name = "backlit"
  file = "views/p0/backlit.exr"
  exposure_s = 0.04
  lights = ["backlight"]

  [[position.capture]]
  name = "checker_8"
  file = "views/p0/checker_8.exr"
  exposure_s = 0.02
  lights = ["projector"]
  pattern = { kind = "checker", period_px = 8, phase_px = [0, 0], low = 0.0, high = 1.0 }

[[position]]
name = "p1"
camera_to_world = [0,0,1,-1.5, 0,1,0,0, -1,0,0,0, 0,0,0,1]

  [[position.light]]
  name = "flash0"
  kind = "point"
  position = [-1.5, 0.0, 0.0]

  [[position.capture]]
  name = "ambient"
  file = "views/p1/ambient.exr"
  exposure_s = 0.02
  lights = []

  [[position.capture]]
  name = "flash0"
  file = "views/p1/flash0.exr"
  exposure_s = 0.02
  lights = ["flash0"]
"#;

/// `VALID` with the one occurrence of `from` replaced by `to` (panics if
/// `from` is not there exactly once, so a fixture edit cannot silently make
/// a test vacuous).
pub fn edit(from: &str, to: &str) -> String {
    assert_eq!(
        VALID.matches(from).count(),
        1,
        "fixture must contain {from:?} once"
    );
    VALID.replacen(from, to, 1)
}

pub fn parse(text: &str) -> Result<(Manifest, Vec<String>), ScanError> {
    Manifest::parse(text, Path::new("scan.toml"))
}

/// The error message of a manifest that must be rejected.
pub fn error_of(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("manifest was accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts the message names the file, the key and the expectation.
pub fn assert_rejected(text: &str, key: &str, expectation: &str) {
    let msg = error_of(text);
    assert!(msg.starts_with("scan.toml: "), "no file in: {msg}");
    assert!(
        msg.contains(&format!("key `{key}`")),
        "no key `{key}` in: {msg}"
    );
    assert!(msg.contains(expectation), "no {expectation:?} in: {msg}");
}
