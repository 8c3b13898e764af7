//! A whole simulated scan as a `matscan-scan/1` bundle: every capture of
//! the contract at every position, the truth maps, the mesh, and scene
//! metadata, published atomically (an interrupted run leaves nothing).
//!
//! Captures per position (all with the rig's `exposure_s`):
//! `ambient` (no rig light), one per flash (`flash0`, `flash1`),
//! `projector` (uniform level 0.5, the thesis's grey image), `backlight`,
//! and two checkerboards `checker_<period>`. Checker periods are chosen per
//! scene so that a square is about 3 camera pixels (small) and 12 camera
//! pixels (large) wide on the object: `period = 2 * round(3 / r)` and four
//! times that, where `r` is the size of a projector pixel in camera pixels
//! at the object's centre (focal lengths times the distance ratio). With
//! the rig's 1024 x 768 projector and a 256 x 256 camera that gives periods
//! of about 8 to 54 and 32 to 216.
//!
//! Truth (`truth/<position>/`): the five effective parameter maps, the
//! validity mask, and `illum_<capture>` for the lit captures (each flash
//! and `projector`). `truth/scene.toml` holds what the estimator may want
//! but the manifest has no key for: scene kind and name, seeds, samples,
//! the environment, and per position whether the environment drowns the
//! rig's lights (`super::drowned`), with the measured figures.
//!
//! Photos are half-float EXR (values clamped to the half range, which only
//! a direct view of the sun through a mirror could reach); truth is float.

use super::capture::{CaptureSpec, RenderOptions, Renderer, DEFAULT_MAX_DEPTH, DEFAULT_SAMPLES};
use super::drowned::{assess, DrownAssessment, LitImage};
use super::error::SimError;
use super::truth::TruthMaps;
use crate::scene::rig::rig_to_manifest_lights;
use crate::scene::{EnvSource, RigPosition, Scene};
use glam::Vec3;
use matscan_calib::bad_light::THESIS_THRESHOLD;
use matscan_scan::bundle::{BundleWriter, TruthMap};
use matscan_scan::capture_list::{position_captures, CaptureKind, UNIFORM_LEVEL};
use matscan_scan::image_io::Precision;
use matscan_scan::raster::RgbRaster;
use matscan_scan::{Bundle, Capture, Manifest, Param, Pattern, PinholeCamera, Position};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How to simulate a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimOptions {
    /// Paths per pixel.
    pub samples: u32,
    /// Seed of the renderer's random numbers (the scene has its own).
    pub seed: u64,
    pub max_depth: u32,
    /// Worker threads; `None` uses rayon's global pool (every core).
    pub threads: Option<usize>,
    /// Also write `views/<position>/white.png`, the pixels showing the
    /// panel, as the contract's preferred white reference. Off by default,
    /// so simulated scans exercise the thesis's segmentation like real ones.
    pub white_reference: bool,
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            samples: DEFAULT_SAMPLES,
            seed: 0,
            max_depth: DEFAULT_MAX_DEPTH,
            threads: None,
            white_reference: false,
        }
    }
}

/// Largest finite half-float value.
const HALF_MAX: f32 = 65504.0;
/// Target square widths of the two checkerboards, camera pixels.
const SMALL_SQUARE_PX: f64 = 3.0;
const LARGE_PERIOD_FACTOR: u32 = 4;

/// Renders `scene` and writes it as a bundle at `out_dir` (which must not
/// exist yet); returns the bundle as reopened and validated.
pub fn write_scan_bundle(
    scene: &Scene,
    opts: &SimOptions,
    out_dir: &Path,
) -> Result<Bundle, SimError> {
    if opts.samples == 0 {
        return Err(SimError::Options("samples must be at least 1".into()));
    }
    match opts.threads {
        Some(0) => Err(SimError::Options("threads must be at least 1".into())),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| SimError::Options(format!("cannot start {n} threads: {e}")))?
            .install(|| write_bundle(scene, opts, out_dir)),
        None => write_bundle(scene, opts, out_dir),
    }
}

/// One capture of the bundle: what to render and how the manifest lists it.
struct PlannedCapture {
    spec: CaptureSpec,
    /// A lit capture (flash or uniform projector): gets an `illum_` map.
    lit: bool,
}

fn write_bundle(scene: &Scene, opts: &SimOptions, out_dir: &Path) -> Result<Bundle, SimError> {
    let renderer = Renderer::new(scene)?;
    let ropts = RenderOptions {
        samples: opts.samples,
        seed: opts.seed,
        max_depth: opts.max_depth,
        ..RenderOptions::default()
    };
    let writer = BundleWriter::create(out_dir)?;
    writer.write_mesh(&scene.mesh)?;
    let periods = checker_periods(scene);
    let mut positions = Vec::new();
    let mut report = Vec::new();
    for (index, rig) in scene.rig.positions.iter().enumerate() {
        let planned = plan_captures(rig, periods);
        let specs: Vec<CaptureSpec> = planned.iter().map(|p| p.spec.clone()).collect();
        let images = renderer.render_position(index, &specs, &ropts)?;
        let truth = renderer.render_truth(index)?;
        let lit: Vec<CaptureSpec> = planned
            .iter()
            .filter(|p| p.lit)
            .map(|p| p.spec.clone())
            .collect();
        let illum = renderer.render_illum(index, &lit, &ropts)?;

        let name = rig.name.as_str();
        let mut captures = Vec::new();
        for (spec, photo) in specs.iter().zip(&images.photos) {
            let file = writer.write_photo(name, &spec.name, &half_range(photo), Precision::Half)?;
            captures.push(Capture {
                name: spec.name.clone(),
                file,
                exposure_s: rig.exposure_s as f64,
                lights: spec.lights.clone(),
                pattern: spec.pattern,
                encoding: None,
            });
        }
        write_truth(&writer, name, &truth)?;
        for (spec, image) in lit.iter().zip(&illum) {
            writer.write_truth_rgb(name, &TruthMap::Illum(spec.name.clone()), image)?;
        }
        let white_reference_mask = if opts.white_reference {
            let panel = renderer.panel_mask(index)?;
            Some(
                writer
                    .write_mask_at(PathBuf::from("views").join(name).join("white.png"), &panel)?,
            )
        } else {
            None
        };

        let lit_images: Vec<LitImage<'_>> = planned
            .iter()
            .zip(&images.light_only)
            .filter(|(p, _)| p.lit)
            .map(|(p, light_only)| LitImage {
                capture: &p.spec.name,
                light: p.spec.lights.first().map_or("", String::as_str),
                light_only,
            })
            .collect();
        let assessment = assess(name, &lit_images, &images.ambient, &truth.mask);
        report.push((name.to_string(), assessment, images.dropped_samples));
        positions.push(Position {
            name: name.to_string(),
            camera_to_world: rig.camera_to_world,
            lights: rig_to_manifest_lights(rig),
            captures,
            white_reference_mask,
        });
    }
    writer.write_file(
        Path::new("truth").join("scene.toml"),
        scene_toml(scene, opts, periods, &report).as_bytes(),
    )?;
    let manifest = Manifest {
        units: "m".into(),
        name: scene.name.clone(),
        created: matscan_scan::time::rfc3339_now(),
        camera: scene.rig.intrinsics,
        positions,
    };
    Ok(writer.finish(&manifest)?)
}

/// Writes position `name`'s object mask, its five parameter truth maps and
/// the truth mask: what the estimator's error metrics read. Also used by
/// the daemon's simulated rig, whose photos come from the drivers.
pub fn write_truth(writer: &BundleWriter, name: &str, truth: &TruthMaps) -> Result<(), SimError> {
    writer.write_mask(name, &truth.mask)?;
    writer.write_truth_rgb(name, &TruthMap::Param(Param::Basecolor), &truth.basecolor)?;
    for (param, map) in [
        (Param::Roughness, &truth.roughness),
        (Param::Metallic, &truth.metallic),
        (Param::Transmission, &truth.transmission),
        (Param::Subsurface, &truth.subsurface),
    ] {
        writer.write_truth_scalar(name, &TruthMap::Param(param), map)?;
    }
    writer.write_truth_mask(name, &truth.mask)?;
    Ok(())
}

/// The contract's captures for one position (`matscan_scan::capture_list`),
/// lit by this rig position's lights.
fn plan_captures(rig: &RigPosition, checkers: (u32, u32)) -> Vec<PlannedCapture> {
    let projector = rig.projector.name.as_str();
    position_captures(rig.flashes.len(), checkers)
        .into_iter()
        .map(|kind| {
            let name = kind.name();
            let spec = match kind {
                CaptureKind::Ambient => CaptureSpec::new(&name, &[], None),
                CaptureKind::Flash(i) => CaptureSpec::new(&name, &[&rig.flashes[i].name], None),
                CaptureKind::Uniform => CaptureSpec::new(
                    &name,
                    &[projector],
                    Some(Pattern::Uniform {
                        level: f64::from(UNIFORM_LEVEL),
                    }),
                ),
                CaptureKind::Backlit => CaptureSpec::new(&name, &[&rig.backlight.name], None),
                CaptureKind::Checker { period_px } => CaptureSpec::new(
                    &name,
                    &[projector],
                    Some(Pattern::Checker {
                        period_px: f64::from(period_px),
                        phase_px: [0.0, 0.0],
                        low: 0.0,
                        high: 1.0,
                    }),
                ),
            };
            PlannedCapture {
                spec,
                lit: kind.is_view(),
            }
        })
        .collect()
}

/// The two checker periods (projector pixels, even) of a scene; see the
/// module docs.
pub fn checker_periods(scene: &Scene) -> (u32, u32) {
    let centre = scene
        .mesh
        .bounds()
        .map_or(Vec3::ZERO, |(lo, hi)| (lo + hi) * 0.5)
        .as_dvec3();
    let ratio = scene.rig.positions.first().map_or(1.0, |rig| {
        let camera = PinholeCamera::new(scene.rig.intrinsics, rig.camera_to_world);
        let projector =
            PinholeCamera::new(rig.projector.intrinsics, rig.projector.projector_to_world);
        let d_cam = (camera.center() - centre).length();
        let d_proj = (projector.center() - centre).length();
        scene.rig.intrinsics.fx / rig.projector.intrinsics.fx * d_proj / d_cam
    });
    let ratio = if ratio.is_finite() && ratio > 0.0 {
        ratio
    } else {
        1.0
    };
    let half = (SMALL_SQUARE_PX / ratio).round().clamp(1.0, 1e6) as u32;
    (2 * half, 2 * half * LARGE_PERIOD_FACTOR)
}

fn half_range(image: &RgbRaster) -> RgbRaster {
    image.map(|p| {
        p.map(|v| {
            if v.is_finite() {
                v.clamp(0.0, HALF_MAX)
            } else {
                0.0
            }
        })
    })
}

/// `truth/scene.toml`.
fn scene_toml(
    scene: &Scene,
    opts: &SimOptions,
    (small, large): (u32, u32),
    report: &[(String, DrownAssessment, u64)],
) -> String {
    let mut s = String::new();
    let env = match &scene.environment.source {
        EnvSource::None => "none".to_string(),
        EnvSource::Procedural { seed } => format!("procedural {seed}"),
        EnvSource::Map(path) => format!("map {}", path.display()),
    };
    let _ = writeln!(s, "# Simulation metadata (not part of the scan format).");
    let _ = writeln!(s, "name = {}", toml_string(&scene.name));
    let _ = writeln!(s, "kind = {}", toml_string(&scene.kind));
    let _ = writeln!(s, "render_seed = {}", opts.seed);
    let _ = writeln!(s, "samples = {}", opts.samples);
    let _ = writeln!(s, "max_depth = {}", opts.max_depth);
    let _ = writeln!(s, "environment = {}", toml_string(&env));
    let _ = writeln!(
        s,
        "environment_strength = {}",
        toml_float(scene.environment.strength)
    );
    let _ = writeln!(
        s,
        "environment_rotation = {}",
        toml_float(scene.environment.rotation)
    );
    let _ = writeln!(s, "checker_periods_px = [{small}, {large}]");
    let _ = writeln!(s, "drowned_threshold = {}", toml_float(THESIS_THRESHOLD));
    for (name, a, dropped) in report {
        let _ = writeln!(s, "\n[[position]]");
        let _ = writeln!(s, "name = {}", toml_string(name));
        let _ = writeln!(s, "drowned = {}", a.drowned());
        let differences: Vec<String> = a
            .verdict
            .captures
            .iter()
            .map(|c| {
                format!(
                    "{} = {}",
                    toml_string(&c.capture),
                    toml_float(c.max_difference)
                )
            })
            .collect();
        let _ = writeln!(s, "max_light_difference = {{ {} }}", differences.join(", "));
        if let Some(r) = a.light_to_ambient {
            let _ = writeln!(s, "light_to_ambient = {}", toml_float(r));
        }
        let _ = writeln!(s, "dropped_samples = {dropped}");
    }
    s
}

fn toml_float(v: f32) -> String {
    if v.is_finite() {
        format!("{v:?}")
    } else {
        "nan".into()
    }
}

/// A TOML basic string.
fn toml_string(v: &str) -> String {
    let mut out = String::from("\"");
    for c in v.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_strings_are_escaped() {
        assert_eq!(toml_string("a\"b\\c\n"), "\"a\\\"b\\\\c\\u000A\"");
    }
}
