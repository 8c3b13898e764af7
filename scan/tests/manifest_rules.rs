//! Every validation rule of `scan.toml`: each broken manifest is rejected
//! with a message naming the file, the key path and what was expected;
//! unknown keys only warn; valid manifests round-trip exactly.

use crate::common;

use common::{assert_rejected, edit, error_of, parse, VALID};
use glam::{DMat4, DVec3};
use matscan_scan::manifest::{CaptureRole, Encoding, GrayAxis, LightKind, Pattern};
use matscan_scan::Manifest;
use matscan_scan::{gray_code, gray_decode};
use std::path::{Path, PathBuf};

#[test]
fn valid_manifest_parses_into_the_expected_values_without_warnings() {
    let (m, warnings) = parse(VALID).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(m.units, "m");
    assert_eq!(m.name, "ape-2mat-0007");
    assert_eq!(m.created, "2026-11-23T08:40:00Z");
    assert_eq!((m.camera.width, m.camera.height), (8, 6));
    assert_eq!(m.camera.distortion, [0.01, -0.002, 0.0, 0.0, 0.0]);
    let p0 = &m.positions[0];
    // Row-major in the file: the translation is the last column.
    assert_eq!(
        p0.camera_to_world.transform_point3(DVec3::ZERO),
        DVec3::new(0.0, 0.0, -1.5)
    );
    assert_eq!(
        p0.white_reference_mask.as_deref(),
        Some(Path::new("views/p0/white.png"))
    );
    assert_eq!(p0.light("flash0").unwrap().color, [1.0, 0.98, 0.9]);
    assert_eq!(p0.light("flash1").unwrap().color, [1.0, 1.0, 1.0]);
    assert_eq!(p0.light("flash1").unwrap().intensity, Some(2.5));
    match &p0.light("projector").unwrap().kind {
        LightKind::Projector {
            projector_to_world,
            intrinsics,
        } => {
            assert_eq!(projector_to_world.w_axis.x, 0.2);
            assert_eq!((intrinsics.width, intrinsics.height), (1280, 800));
            assert_eq!(intrinsics.distortion, [0.0; 5]);
        }
        other => panic!("projector parsed as {other:?}"),
    }
    assert_eq!(p0.light("backlight").unwrap().kind, LightKind::Backlight);
    let phone = p0.capture("phone").unwrap();
    assert_eq!(phone.encoding, Some(Encoding::Srgb));
    assert_eq!(phone.file, PathBuf::from("views/p0/phone.png"));
    assert_eq!(p0.capture("flash0").unwrap().encoding, None);
    assert_eq!(
        p0.capture("checker_8").unwrap().pattern,
        Some(Pattern::Checker {
            period_px: 8.0,
            phase_px: [0.0, 0.0],
            low: 0.0,
            high: 1.0
        })
    );
    assert_eq!(m.positions[1].name, "p1");
}

#[test]
fn roles_come_from_lights_and_pattern() {
    let (m, _) = parse(VALID).unwrap();
    let p0 = &m.positions[0];
    let roles: Vec<(String, CaptureRole)> = p0
        .captures_with_role()
        .map(|(c, r)| (c.name.clone(), r))
        .collect();
    let lit = |l: &str| CaptureRole::Lit {
        light: l.to_string(),
    };
    assert_eq!(
        roles,
        vec![
            ("ambient".to_string(), CaptureRole::Ambient),
            ("flash0".to_string(), lit("flash0")),
            ("phone".to_string(), lit("flash1")),
            ("uniform".to_string(), lit("projector")),
            ("backlit".to_string(), CaptureRole::Backlit),
            (
                "checker_8".to_string(),
                CaptureRole::Pattern {
                    light: "projector".to_string()
                }
            ),
        ]
    );
    let views: Vec<&str> = p0.lit_captures().map(|(c, _)| c.name.as_str()).collect();
    assert_eq!(views, ["flash0", "phone", "uniform"]);
    assert_eq!(p0.backlit().unwrap().name, "backlit");
    assert_eq!(p0.pattern_captures().count(), 1);
    assert_eq!(p0.ambient().unwrap().name, "ambient");
}

#[test]
fn to_toml_round_trips_exactly() {
    let (m, _) = parse(VALID).unwrap();
    let text = m.to_toml();
    let (back, warnings) = parse(&text).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(back, m);
    assert_eq!(back.to_toml(), text);
}

#[test]
fn to_toml_round_trips_awkward_numbers_and_strings() {
    let (mut m, _) = parse(VALID).unwrap();
    m.name = "quote \" backslash \\ newline \n tab \t unicode é".to_string();
    m.camera.fx = 0.1 + 0.2;
    m.camera.cx = -1e-300;
    let pose =
        DMat4::from_rotation_y(0.3) * DMat4::from_translation(DVec3::new(1e3, -1e-3, 1.0 / 3.0));
    m.positions[1].camera_to_world = pose;
    m.positions[0].captures[1].exposure_s = 1e-9;
    let (back, _) = parse(&m.to_toml()).unwrap();
    assert_eq!(back, m);
}

#[test]
fn defaults_apply_when_optional_keys_are_absent() {
    let text = edit("units = \"m\"\n", "")
        .replacen("name = \"ape-2mat-0007\"\n", "", 1)
        .replacen("distortion = [0.01, -0.002, 0.0, 0.0, 0.0]\n", "", 1)
        .replacen(", phase_px = [0, 0], low = 0.0, high = 1.0", "", 1);
    let (m, _) = parse(&text).unwrap();
    assert_eq!(m.units, "m");
    assert_eq!(m.name, "");
    assert_eq!(m.camera.distortion, [0.0; 5]);
    assert_eq!(
        m.positions[0].capture("checker_8").unwrap().pattern,
        Some(Pattern::Checker {
            period_px: 8.0,
            phase_px: [0.0, 0.0],
            low: 0.0,
            high: 1.0
        })
    );
}

#[test]
fn bare_toml_datetime_is_accepted_as_created() {
    let text = edit(
        "created = \"2026-11-23T08:40:00Z\"",
        "created = 2026-11-23T08:40:00Z",
    );
    let (m, _) = parse(&text).unwrap();
    assert_eq!(m.created, "2026-11-23T08:40:00Z");
}

#[test]
fn unknown_keys_warn_with_their_key_path_and_never_fail() {
    let text = edit("units = \"m\"", "units = \"m\"\nrig = \"v2\"")
        .replacen("cy = 3.0", "cy = 3.0\nmodel = \"imx\"", 1)
        .replacen("name = \"p1\"", "name = \"p1\"\nturntable_deg = 90", 1)
        .replacen(
            "kind = \"backlight\"",
            "kind = \"backlight\"\nsize_m = 0.3",
            1,
        )
        .replacen(
            "lights = [\"backlight\"]",
            "lights = [\"backlight\"]\niso = 100",
            1,
        )
        .replacen("level = 0.5 }", "level = 0.5, gamma = 2.2 }", 1)
        .replacen(
            "mask = \"views/p0/white.png\"",
            "mask = \"views/p0/white.png\"\nalbedo = 0.9",
            1,
        );
    let (m, warnings) = parse(&text).unwrap();
    assert_eq!(m, parse(VALID).unwrap().0);
    let expected = [
        "key `rig`",
        "key `camera.model`",
        "key `position \"p1\".turntable_deg`",
        "key `position \"p0\".light \"backlight\".size_m`",
        "key `position \"p0\".capture \"backlit\".iso`",
        "key `position \"p0\".capture \"uniform\".pattern.gamma`",
        "key `position \"p0\".white_reference.albedo`",
    ];
    assert_eq!(warnings.len(), expected.len(), "{warnings:?}");
    for key in expected {
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with("scan.toml: ") && w.contains(key) && w.contains("ignored")),
            "no warning for {key}: {warnings:?}"
        );
    }
}

#[test]
fn integers_are_accepted_where_numbers_are_expected() {
    let text = edit("fx = 355.6", "fx = 355");
    let (m, _) = parse(&text).unwrap();
    assert_eq!(m.camera.fx, 355.0);
}

#[test]
fn invalid_toml_is_reported_with_its_line() {
    let msg = error_of(&edit("units = \"m\"", "units = \"m"));
    assert!(msg.starts_with("scan.toml: not valid TOML"), "{msg}");
    assert!(msg.contains("line 3"), "{msg}");
}

#[test]
fn format_must_be_matscan_scan_1() {
    assert_rejected(
        &edit("format = \"matscan-scan/1\"\n", ""),
        "format",
        "missing; expected format = \"matscan-scan/1\"",
    );
    assert_rejected(
        &edit("format = \"matscan-scan/1\"", "format = \"matscan-scan/2\""),
        "format",
        "this reader reads matscan-scan/1, found \"matscan-scan/2\"",
    );
    assert_rejected(
        &edit("format = \"matscan-scan/1\"", "format = 1"),
        "format",
        "expected format = \"matscan-scan/1\", found 1",
    );
}

#[test]
fn units_and_created_must_have_the_right_type() {
    assert_rejected(
        &edit("units = \"m\"", "units = \"\""),
        "units",
        "expected a length unit",
    );
    assert_rejected(
        &edit("units = \"m\"", "units = 1"),
        "units",
        "expected a string, found 1",
    );
    assert_rejected(
        &edit("created = \"2026-11-23T08:40:00Z\"", "created = 2026"),
        "created",
        "expected an RFC 3339 timestamp string, found 2026",
    );
}

#[test]
fn camera_intrinsics_must_be_positive_and_finite() {
    let no_camera = VALID.replacen("[camera]", "[camera_x]", 1);
    assert_rejected(&no_camera, "camera", "missing; expected a table [camera]");
    assert_rejected(
        &edit("width = 8", "width = 0"),
        "camera.width",
        "expected a positive integer (pixels), found 0",
    );
    assert_rejected(
        &edit("height = 6", "height = \"6\""),
        "camera.height",
        "expected a positive integer (pixels), found the string \"6\"",
    );
    assert_rejected(
        &edit("height = 6", "height = 6.5"),
        "camera.height",
        "found 6.5",
    );
    assert_rejected(
        &edit("fx = 355.6", "fx = -355.6"),
        "camera.fx",
        "expected a positive number (focal length in pixels), found -355.6",
    );
    assert_rejected(
        &edit("fy = 355.6", "fy = 0"),
        "camera.fy",
        "expected a positive number (focal length in pixels), found 0",
    );
    assert_rejected(
        &edit("fy = 355.6", "fy = nan"),
        "camera.fy",
        "expected a finite number, found NaN",
    );
    assert_rejected(
        &edit("cx = 4.0\n", ""),
        "camera.cx",
        "missing; expected a number",
    );
    assert_rejected(
        &edit("cy = 3.0", "cy = inf"),
        "camera.cy",
        "expected a finite number, found inf",
    );
    assert_rejected(
        &edit(
            "distortion = [0.01, -0.002, 0.0, 0.0, 0.0]",
            "distortion = [0.01, -0.002, 0.0, 0.0]",
        ),
        "camera.distortion",
        "expected 5 numbers, found 4",
    );
    assert_rejected(
        &edit(
            "distortion = [0.01, -0.002, 0.0, 0.0, 0.0]",
            "distortion = [0.01, -0.002, 0.0, \"x\", 0.0]",
        ),
        "camera.distortion",
        "expected 5 finite numbers, item 3 is the string \"x\"",
    );
}

#[test]
fn positions_must_exist_with_unique_file_safe_names() {
    let none = VALID.split("[[position]]").next().unwrap().to_string();
    assert_rejected(
        &none,
        "position",
        "missing; expected at least one [[position]]",
    );
    assert_rejected(
        &edit("name = \"p1\"", "name = \"p0\""),
        "position \"p0\".name",
        "expected a unique position name; \"p0\" is used twice",
    );
    assert_rejected(
        &edit("name = \"p1\"", "name = \"a/b\""),
        "position \"a/b\".name",
        "expected a position name usable as a file name",
    );
    assert_rejected(
        &edit("name = \"p1\"", "name = \"..\""),
        "position \"..\".name",
        "usable as a file name",
    );
    assert_rejected(
        &edit("name = \"p1\"\n", ""),
        "position[1].name",
        "missing; expected a string",
    );
    assert_rejected(
        &edit("name = \"p1\"", "name = 7"),
        "position[1].name",
        "expected a string, found 7",
    );
    let table = "format = \"matscan-scan/1\"\n[camera]\nwidth = 1\nheight = 1\nfx = 1\nfy = 1\ncx = 0\ncy = 0\n[position]\nname = \"p0\"\n";
    assert_rejected(
        table,
        "position",
        "expected an array of tables ([[position]]), found a table",
    );
}

#[test]
fn pose_matrices_must_be_16_finite_numbers_affine_and_invertible() {
    let pose = "camera_to_world = [0,0,1,-1.5, 0,1,0,0, -1,0,0,0, 0,0,0,1]";
    let key = "position \"p1\".camera_to_world";
    assert_rejected(
        &edit(pose, "camera_to_world = [0,0,1,-1.5, 0,1,0,0, -1,0,0,0]"),
        key,
        "expected 16 numbers, found 12",
    );
    assert_rejected(
        &edit(
            pose,
            "camera_to_world = [0,0,1,-1.5, 0,1,0,0, -1,0,0,nan, 0,0,0,1]",
        ),
        key,
        "expected 16 finite numbers, item 11 is NaN",
    );
    assert_rejected(
        &edit(pose, "camera_to_world = \"identity\""),
        key,
        "expected 16 numbers, found the string \"identity\"",
    );
    assert_rejected(
        &edit(
            pose,
            "camera_to_world = [0,0,1,-1.5, 0,0,1,0, -1,0,0,0, 0,0,0,1]",
        ),
        key,
        "expected an invertible transform",
    );
    assert_rejected(
        &edit(
            pose,
            "camera_to_world = [0,0,1,-1.5, 0,1,0,0, -1,0,0,0, 0,0,1,1]",
        ),
        key,
        "last row is 0 0 0 1, found 0 0 1 1",
    );
    assert_rejected(
        &edit(&format!("{pose}\n"), "\n"),
        key,
        "missing; expected 16 numbers",
    );
    let proj = "projector_to_world = [1,0,0,0.2, 0,1,0,0, 0,0,1,-1.5, 0,0,0,1]";
    assert_rejected(
        &edit(
            proj,
            "projector_to_world = [0,0,0,0.2, 0,0,0,0, 0,0,0,-1.5, 0,0,0,1]",
        ),
        "position \"p0\".light \"projector\".projector_to_world",
        "expected an invertible transform",
    );
}

#[test]
fn lights_need_unique_names_a_known_kind_and_that_kind_s_fields() {
    assert_rejected(
        &edit("name = \"flash1\"", "name = \"flash0\""),
        "position \"p0\".light \"flash0\".name",
        "expected a unique light name in position \"p0\"; \"flash0\" is used twice",
    );
    assert_rejected(
        &edit("name = \"backlight\"", "name = \"\""),
        "position \"p0\".light \"\".name",
        "expected a non-empty light name",
    );
    assert_rejected(
        &edit("kind = \"backlight\"", "kind = \"spot\""),
        "position \"p0\".light \"backlight\".kind",
        "expected \"point\", \"projector\" or \"backlight\", found \"spot\"",
    );
    assert_rejected(
        &edit("kind = \"backlight\"\n", "\n"),
        "position \"p0\".light \"backlight\".kind",
        "missing; expected a string",
    );
    assert_rejected(
        &edit("position = [0.3, 0.0, -1.5]", "position = [0.3, 0.0]"),
        "position \"p0\".light \"flash1\".position",
        "expected 3 numbers, found 2",
    );
    assert_rejected(
        &edit("position = [-1.5, 0.0, 0.0]\n", "\n"),
        "position \"p1\".light \"flash0\".position",
        "missing; expected 3 numbers",
    );
    assert_rejected(
        &edit("fx = 1500.0", "fx = 0.0"),
        "position \"p0\".light \"projector\".fx",
        "expected a positive number (focal length in pixels), found 0",
    );
    assert_rejected(
        &edit("width = 1280\n", "\n"),
        "position \"p0\".light \"projector\".width",
        "missing; expected a positive integer (pixels)",
    );
}

#[test]
fn light_colors_and_intensities_must_be_non_negative_and_finite() {
    assert_rejected(
        &edit("color = [1.0, 0.98, 0.9]", "color = [1.0, -0.98, 0.9]"),
        "position \"p0\".light \"flash0\".color",
        "expected 3 non-negative numbers (relative linear RGB), found [1, -0.98, 0.9]",
    );
    assert_rejected(
        &edit("color = [1.0, 0.98, 0.9]", "color = [1.0, 0.98]"),
        "position \"p0\".light \"flash0\".color",
        "expected 3 numbers, found 2",
    );
    assert_rejected(
        &edit("color = [1.0, 0.98, 0.9]", "color = [1.0, 0.98, inf]"),
        "position \"p0\".light \"flash0\".color",
        "item 2 is inf",
    );
    assert_rejected(
        &edit("intensity = 2.5", "intensity = -2.5"),
        "position \"p0\".light \"flash1\".intensity",
        "expected a positive number, found -2.5",
    );
}

#[test]
fn capture_names_must_be_unique_and_file_safe() {
    assert_rejected(
        &edit("name = \"uniform\"", "name = \"flash0\""),
        "position \"p0\".capture \"flash0\".name",
        "expected a unique capture name in position \"p0\"; \"flash0\" is used twice",
    );
    assert_rejected(
        &edit("name = \"uniform\"", "name = \"a\\\\b\""),
        "position \"p0\".capture \"a\\\\b\".name",
        "expected a capture name usable as a file name",
    );
}

#[test]
fn capture_files_must_be_relative_exr_or_png_paths_inside_the_bundle() {
    let line = "file = \"views/p0/flash0.exr\"";
    let key = "position \"p0\".capture \"flash0\".file";
    assert_rejected(
        &edit(line, "file = \"/data/flash0.exr\""),
        key,
        "(not absolute), found \"/data/flash0.exr\"",
    );
    assert_rejected(
        &edit(line, "file = \"C:/data/flash0.exr\""),
        key,
        "(not absolute)",
    );
    assert_rejected(
        &edit(line, "file = \"views/../../flash0.exr\""),
        key,
        "(no empty, . or .. segments)",
    );
    assert_rejected(
        &edit(line, "file = \"views/./flash0.exr\""),
        key,
        "(no empty, . or .. segments)",
    );
    assert_rejected(
        &edit(line, "file = \"views//flash0.exr\""),
        key,
        "(no empty, . or .. segments)",
    );
    assert_rejected(
        &edit(line, "file = \"views\\\\p0\\\\flash0.exr\""),
        key,
        "with / as separator",
    );
    assert_rejected(&edit(line, "file = \"views/p0/flash0.jpg\""), key, "expected a .exr or .png file path relative to the bundle folder, found \"views/p0/flash0.jpg\"");
    assert_rejected(
        &edit(&format!("{line}\n"), "\n"),
        key,
        "missing; expected a string",
    );
    // Extensions compare without case.
    assert!(parse(&edit(line, "file = \"views/p0/flash0.EXR\"")).is_ok());
}

#[test]
fn png_captures_must_declare_a_known_encoding_and_exr_must_be_linear() {
    let key = "position \"p0\".capture \"phone\".encoding";
    assert_rejected(&edit("encoding = \"srgb\"\n", "\n"), key, "missing; expected \"linear\" or \"srgb\": a PNG photo must declare how it encodes radiance");
    assert_rejected(
        &edit("encoding = \"srgb\"", "encoding = \"gamma22\""),
        key,
        "expected \"linear\" or \"srgb\", found \"gamma22\"",
    );
    let exr_srgb = edit(
        "lights = [\"backlight\"]",
        "lights = [\"backlight\"]\nencoding = \"srgb\"",
    );
    assert_rejected(
        &exr_srgb,
        "position \"p0\".capture \"backlit\".encoding",
        "EXR photos are always linear",
    );
    let exr_linear = edit(
        "lights = [\"backlight\"]",
        "lights = [\"backlight\"]\nencoding = \"linear\"",
    );
    let (m, warnings) = parse(&exr_linear).unwrap();
    assert!(warnings.is_empty());
    assert_eq!(m.positions[0].capture("backlit").unwrap().encoding, None);
    let png_linear = edit("encoding = \"srgb\"", "encoding = \"linear\"");
    let (m, _) = parse(&png_linear).unwrap();
    assert_eq!(
        m.positions[0].capture("phone").unwrap().encoding,
        Some(Encoding::Linear)
    );
}

#[test]
fn exposure_must_be_positive_and_finite() {
    let line = "exposure_s = 0.04";
    let key = "position \"p0\".capture \"backlit\".exposure_s";
    assert_rejected(
        &edit(line, "exposure_s = 0"),
        key,
        "expected a positive number (seconds), found 0",
    );
    assert_rejected(
        &edit(line, "exposure_s = -inf"),
        key,
        "expected a finite number, found -inf",
    );
    assert_rejected(
        &edit(&format!("{line}\n"), "\n"),
        key,
        "missing; expected a number",
    );
}

#[test]
fn capture_lights_must_name_lights_of_their_position_once() {
    let msg = error_of(&edit("lights = [\"flash1\"]", "lights = [\"flash3\"]"));
    assert_eq!(
        msg,
        "scan.toml: key `position \"p0\".capture \"phone\".lights`: names light `flash3`, \
         which position \"p0\" does not have (it has flash0, flash1, projector, backlight)"
    );
    // p1 has only flash0: a capture there cannot use p0's projector.
    let p1_flash = "  [[position.capture]]\n  name = \"flash0\"\n  file = \"views/p1/flash0.exr\"\n  exposure_s = 0.02\n  lights = [\"flash0\"]";
    assert_rejected(
        &edit(
            p1_flash,
            &p1_flash.replace("[\"flash0\"]", "[\"projector\"]"),
        ),
        "position \"p1\".capture \"flash0\".lights",
        "names light `projector`, which position \"p1\" does not have (it has flash0)",
    );
    assert_rejected(
        &edit("lights = [\"flash1\"]", "lights = [\"flash1\", \"flash1\"]"),
        "position \"p0\".capture \"phone\".lights",
        "names light `flash1` twice",
    );
    assert_rejected(&edit("lights = [\"flash1\"]", "lights = \"flash1\""), "position \"p0\".capture \"phone\".lights", "expected a list of light names (use [] for the ambient capture), found the string \"flash1\"");
    assert_rejected(
        &edit("lights = [\"flash1\"]", "lights = [1]"),
        "position \"p0\".capture \"phone\".lights",
        "item 0 is 1",
    );
    assert_rejected(
        &edit("lights = [\"flash1\"]\n", "\n"),
        "position \"p0\".capture \"phone\".lights",
        "missing; expected a list of light names",
    );
}

#[test]
fn every_position_needs_an_ambient_capture() {
    let ambient_p1 = "  [[position.capture]]\n  name = \"ambient\"\n  file = \"views/p1/ambient.exr\"\n  exposure_s = 0.02\n  lights = []\n";
    assert_rejected(
        &edit(ambient_p1, ""),
        "position \"p1\".capture",
        "expected an ambient capture (lights = [], no pattern)",
    );
}

#[test]
fn gray_code_patterns_number_the_projector_columns_and_round_trip() {
    let checker =
        "pattern = { kind = \"checker\", period_px = 8, phase_px = [0, 0], low = 0.0, high = 1.0 }";
    let text = edit(
        checker,
        "pattern = { kind = \"graycode\", axis = \"columns\", bit = 1, inverted = true }",
    );
    let (m, _) = parse(&text).unwrap();
    let pattern = m.positions[0]
        .capture("checker_8")
        .unwrap()
        .pattern
        .unwrap();
    assert_eq!(
        pattern,
        Pattern::GrayCode {
            axis: GrayAxis::Columns,
            bit: 1,
            inverted: true
        }
    );
    // Gray codes of columns 0..4: 0, 1, 11, 10; bit 1 is set from column 2
    // on, so the inverted pattern is lit on columns 0 and 1 only.
    let lit: Vec<f64> = (0..4).map(|u| pattern.value_at(u, 7)).collect();
    assert_eq!(lit, vec![1.0, 1.0, 0.0, 0.0]);
    assert_eq!(parse(&m.to_toml()).unwrap().0, m);
    for x in [0u64, 1, 2, 3, 511, 1023, 70_000] {
        assert_eq!(gray_decode(gray_code(x)), x);
        assert_eq!((gray_code(x) ^ gray_code(x + 1)).count_ones(), 1);
    }
}

#[test]
fn patterns_need_the_projector_a_known_kind_and_valid_numbers() {
    let checker =
        "pattern = { kind = \"checker\", period_px = 8, phase_px = [0, 0], low = 0.0, high = 1.0 }";
    let key = "position \"p0\".capture \"checker_8\".pattern";
    let with = |p: &str| edit(checker, &format!("pattern = {{ {p} }}"));
    assert_rejected(
        &with("kind = \"checker\", period_px = 0"),
        &format!("{key}.period_px"),
        "expected a positive number (projector pixels), found 0",
    );
    assert_rejected(
        &with("kind = \"checker\""),
        &format!("{key}.period_px"),
        "missing; expected a number",
    );
    assert_rejected(
        &with("kind = \"checker\", period_px = 8, phase_px = [1]"),
        &format!("{key}.phase_px"),
        "expected 2 numbers, found 1",
    );
    assert_rejected(
        &with("kind = \"checker\", period_px = 8, high = 2.0"),
        &format!("{key}.high"),
        "expected a number from 0 to 1, found 2",
    );
    assert_rejected(
        &with("kind = \"checker\", period_px = 8, low = -0.5"),
        &format!("{key}.low"),
        "expected a number from 0 to 1, found -0.5",
    );
    assert_rejected(
        &with("kind = \"stripes\""),
        &format!("{key}.kind"),
        "expected \"uniform\", \"checker\" or \"graycode\", found \"stripes\"",
    );
    assert_rejected(
        &edit("level = 0.5", "level = 1.5"),
        "position \"p0\".capture \"uniform\".pattern.level",
        "expected a number from 0 to 1, found 1.5",
    );
    assert_rejected(
        &edit("level = 0.5", "lvl = 0.5"),
        "position \"p0\".capture \"uniform\".pattern.level",
        "missing; expected a number from 0 to 1",
    );
    assert_rejected(
        &edit(checker, "pattern = \"checker\""),
        key,
        "expected a table, found the string \"checker\"",
    );
    assert_rejected(
        &with("kind = \"graycode\", axis = \"diagonal\", bit = 2"),
        &format!("{key}.axis"),
        "expected \"columns\" or \"rows\", found \"diagonal\"",
    );
    assert_rejected(
        &with("kind = \"graycode\", axis = \"rows\", bit = 2.5"),
        &format!("{key}.bit"),
        "expected an integer from 0 to 31",
    );
    let flash_with_pattern = edit(
        "lights = [\"flash1\"]",
        "lights = [\"flash1\"]\npattern = { kind = \"uniform\", level = 1.0 }",
    );
    assert_rejected(
        &flash_with_pattern,
        "position \"p0\".capture \"phone\".pattern",
        "a pattern is shown by a projector and `lights` names none",
    );
}

#[test]
fn white_reference_mask_must_be_a_relative_png() {
    let line = "mask = \"views/p0/white.png\"";
    let key = "position \"p0\".white_reference.mask";
    assert_rejected(
        &edit(line, "mask = \"views/p0/white.exr\""),
        key,
        "expected a .png file path",
    );
    assert_rejected(
        &edit(line, "mask = \"../white.png\""),
        key,
        "(no empty, . or .. segments)",
    );
    assert_rejected(
        &edit(line, "msk = \"views/p0/white.png\""),
        key,
        "missing; expected a string",
    );
}

#[test]
fn read_names_the_file_it_could_not_open() {
    let path = Path::new("/nonexistent/scan.toml");
    let msg = Manifest::read(path).unwrap_err().to_string();
    assert!(msg.starts_with("/nonexistent/scan.toml: "), "{msg}");
}

#[test]
fn a_rig_calibration_needs_no_captures_but_a_scan_does() {
    let (m, _) = parse(VALID).unwrap();
    let mut rig = m.clone();
    for p in &mut rig.positions {
        p.captures.clear();
    }
    let text = rig.to_toml();
    let path = Path::new("rig.toml");
    let (parsed, warnings) = Manifest::parse_rig(&text, path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(parsed.positions.len(), m.positions.len());
    assert_eq!(parsed.positions[0].lights, m.positions[0].lights);
    assert!(parsed.positions.iter().all(|p| p.captures.is_empty()));
    let e = Manifest::parse(&text, path).unwrap_err().to_string();
    assert!(e.contains("expected an ambient capture"), "{e}");
    // Captures in a rig file are still checked.
    let (full, _) = Manifest::parse_rig(VALID, path).unwrap();
    assert_eq!(full, m);
}
