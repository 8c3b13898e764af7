//! Each light's intensity in camera units, from photos of a matte white
//! card of known reflectance at a known pose (a `matscan-white/1` bundle),
//! and the camera's response checked for linearity on it.
//!
//! The physics: a card pixel lit by a point light (a flash, or the
//! projector showing uniform white) reads `exposure x f(wo, wi) cos x I_c /
//! d^2`, where `f` is the card's BSDF (the Principled BSDF with the card's
//! albedo and roughness, the model the estimator itself uses, so a card's
//! faint sheen counts too), `d` the distance and `cos` the incidence on the
//! card, all known from the calibrated camera, the light's calibrated
//! position and the card's pose. Each card pixel's lit-minus-ambient value
//! divided by that prediction is one reading of `I_c`; the median over the
//! card (its edges left out) is the light's intensity per channel, and the
//! largest channel is the manifest's `intensity` with the channels' ratios
//! its `color`. The backlight panel is seen directly around the card: its
//! value over the exposure is its radiance.
//!
//! Linearity: a light photographed at several exposures must give the same
//! value per second of exposure; a camera that delivers gamma-encoded or
//! tone-mapped photos does not, and every intensity it gives would be
//! wrong in a way no later step can see.

use crate::camera::{check_size, read_shot};
use crate::detect::{luminance, percentile};
use crate::error::RigcalError;
use glam::{DVec2, DVec3, Vec3};
use matscan_bsdf::{Bsdf, Material};
use matscan_scan::camera::{Intrinsics, PinholeCamera};
use matscan_scan::lights_bundle::{BACKLIGHT, CLIPPED_LEVEL};
use matscan_scan::raster::RgbRaster;
use matscan_scan::white_bundle::{WhiteManifest, WhitePhoto};
use matscan_scan::{LightKind, Manifest};
use std::path::{Path, PathBuf};

/// The share of the card's smaller side left out along its edges: the
/// card's outline blurs into the background there, and a pose error moves
/// it most.
const EDGE_MARGIN: f64 = 0.08;
/// Fewest card pixels a light must light for its intensity.
const MIN_PIXELS: usize = 200;
/// A card pixel reading less than this share of the card's median counts
/// as shadowed.
const SHADOWED: f64 = 0.5;
/// The share of shadowed card pixels at which the card counts as in
/// shadow.
const MAX_SHADOWED_SHARE: f64 = 0.1;
/// Lit-minus-ambient luma below which a pixel says nothing (noise).
const MIN_SIGNAL: f64 = 0.01;
/// Largest departure of one exposure's value per second from the median
/// of all exposures' before the camera counts as nonlinear.
pub const MAX_NONLINEARITY: f64 = 0.02;

/// One light's measured intensity.
#[derive(Debug, Clone, PartialEq)]
pub struct LightLevel {
    pub name: String,
    /// The largest channel's intensity (W/sr in camera units; radiance for
    /// the backlight).
    pub intensity: f64,
    /// Each channel over the largest.
    pub color: [f64; 3],
    /// Pixels measured.
    pub pixels: usize,
    /// Half the interquartile range of the pixels' readings over their
    /// median: how evenly the card agrees with the model.
    pub spread: f64,
    /// The photo the intensity comes from.
    pub file: PathBuf,
}

/// One light's value per second of exposure, at each exposure it was
/// photographed at.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearity {
    pub light: String,
    /// (exposure, value per second over the median of all exposures').
    pub readings: Vec<(f64, f64)>,
}

impl Linearity {
    /// The largest departure from linear, a fraction.
    pub fn worst(&self) -> f64 {
        self.readings
            .iter()
            .map(|(_, r)| (r - 1.0).abs())
            .fold(0.0, f64::max)
    }
}

/// What the card measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Radiometry {
    pub lights: Vec<LightLevel>,
    pub linearity: Vec<Linearity>,
}

/// A light as the card sees it: a point (flash, projector) or the panel.
enum Source {
    Point {
        world: DVec3,
        /// The projector's image, to keep pixels inside its field.
        field: Option<Box<PinholeCamera>>,
    },
    Panel,
}

/// Measures every light photographed in the bundle in `dir` (`manifest`)
/// with the camera, poses and light positions of `rig` (the rig file
/// `matscan calib rig` and `calib lights` wrote).
pub fn calibrate_radiometry(
    dir: &Path,
    manifest: &WhiteManifest,
    rig: &Manifest,
) -> Result<Radiometry, RigcalError> {
    let manifest_path = dir.join(matscan_scan::white_bundle::WHITE_MANIFEST);
    let position =
        rig.position(&manifest.position)
            .ok_or_else(|| RigcalError::UnknownPosition {
                path: manifest_path.clone(),
                position: manifest.position.clone(),
            })?;
    let camera = PinholeCamera::new(rig.camera, position.camera_to_world);
    let card = CardView::new(manifest, &camera, &manifest_path)?;
    let mut readings: Vec<(String, Vec<(f64, LightLevel)>)> = Vec::new();
    // Several lights share one ambient photo: each is read once.
    let mut ambients = Ambients::default();
    for photo in manifest.photos.iter().filter(|p| p.lights.len() == 1) {
        let name = &photo.lights[0];
        let kind = match position.light(name) {
            Some(light) => &light.kind,
            None if name == BACKLIGHT => &LightKind::Backlight,
            None => {
                return Err(RigcalError::WhiteCard {
                    path: dir.join(&photo.file),
                    reason: format!(
                        "the rig file has no light `{name}` at position {}; locate it first \
                         (`matscan calib rig`, `calib lights`)",
                        position.name
                    ),
                })
            }
        };
        let source = match kind {
            LightKind::Point { position } => Source::Point {
                world: *position,
                field: None,
            },
            LightKind::Projector {
                projector_to_world,
                intrinsics,
            } => Source::Point {
                world: projector_to_world.transform_point3(DVec3::ZERO),
                field: Some(Box::new(PinholeCamera::new(
                    *intrinsics,
                    *projector_to_world,
                ))),
            },
            LightKind::Backlight => Source::Panel,
        };
        let level = measure(dir, manifest, photo, &mut ambients, &card, &camera, &source)?;
        match readings.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => v.push((photo.exposure_s, level)),
            None => readings.push((name.clone(), vec![(photo.exposure_s, level)])),
        }
    }
    let mut lights = Vec::new();
    let mut linearity = Vec::new();
    for (name, mut levels) in readings {
        levels.sort_by(|a, b| a.0.total_cmp(&b.0));
        if levels.len() > 1 {
            let values: Vec<f64> = levels.iter().map(|(_, l)| l.intensity).collect();
            let mid = median(&values);
            let l = Linearity {
                light: name.clone(),
                readings: levels
                    .iter()
                    .map(|(e, l)| (*e, l.intensity / mid))
                    .collect(),
            };
            if l.worst() > MAX_NONLINEARITY {
                return Err(RigcalError::Nonlinear {
                    path: manifest_path.clone(),
                    light: name,
                    readings: l
                        .readings
                        .iter()
                        .map(|(e, r)| format!("{r:.3} at {e} s"))
                        .collect::<Vec<_>>()
                        .join(", "),
                    limit: MAX_NONLINEARITY,
                });
            }
            linearity.push(l);
        }
        // The longest exposure: the most signal over the sensor's noise.
        if let Some((_, level)) = levels.pop() {
            lights.push(level);
        }
    }
    if lights.is_empty() {
        return Err(RigcalError::WhiteCard {
            path: manifest_path,
            reason: "no photo with one light on; photograph each light alone".into(),
        });
    }
    Ok(Radiometry { lights, linearity })
}

/// The card as the camera sees it: per pixel inside its margin, the world
/// point and the card's normal.
struct CardView {
    pixels: Vec<(usize, DVec3)>,
    /// Pixels whose ray misses the card and its margin: the background.
    background: Vec<usize>,
    normal: DVec3,
    material: Material,
}

impl CardView {
    fn new(
        manifest: &WhiteManifest,
        camera: &PinholeCamera,
        path: &Path,
    ) -> Result<CardView, RigcalError> {
        let card = &manifest.card;
        let to_world = card.card_to_world;
        let origin = to_world.transform_point3(DVec3::ZERO);
        let (ex, ey) = (
            to_world.transform_vector3(DVec3::X),
            to_world.transform_vector3(DVec3::Y),
        );
        // The reflecting side faces the card's -z.
        let normal = -to_world.transform_vector3(DVec3::Z).normalize();
        let eye = camera.center();
        if normal.dot(eye - origin) <= 0.0 {
            return Err(RigcalError::WhiteCard {
                path: path.to_path_buf(),
                reason: "card.card_to_world turns the card's white side away from the camera"
                    .into(),
            });
        }
        let margin = EDGE_MARGIN * card.size[0].min(card.size[1]);
        let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
        let mut pixels = Vec::new();
        let mut background = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let d = camera
                    .camera_to_world
                    .transform_vector3(
                        camera
                            .intrinsics
                            .ray_direction(DVec2::new(f64::from(i) + 0.5, f64::from(j) + 0.5)),
                    )
                    .normalize();
                let denom = d.dot(normal);
                let t = (origin - eye).dot(normal) / denom;
                let index = (j * w + i) as usize;
                if !(denom.abs() > 1e-9 && t.is_finite() && t > 0.0) {
                    background.push(index);
                    continue;
                }
                let x = eye + d * t;
                let (u, v) = ((x - origin).dot(ex), (x - origin).dot(ey));
                let inside =
                    |m: f64| u >= m && v >= m && u <= card.size[0] - m && v <= card.size[1] - m;
                if inside(margin) {
                    pixels.push((index, x));
                } else if !inside(-margin) {
                    background.push(index);
                }
            }
        }
        if pixels.len() < MIN_PIXELS {
            return Err(RigcalError::WhiteCard {
                path: path.to_path_buf(),
                reason: format!(
                    "the card covers {} pixels inside its edges as card.card_to_world places \
                     it (at least {MIN_PIXELS} needed): move it nearer, or check its pose",
                    pixels.len()
                ),
            });
        }
        let albedo = card.albedo as f32;
        Ok(CardView {
            pixels,
            background,
            normal,
            material: Material {
                basecolor: Vec3::splat(albedo),
                roughness: card.roughness as f32,
                ..Material::WHITE_DIFFUSE
            },
        })
    }
}

/// Ambient photos by file, each read and size-checked once, on first use.
#[derive(Default)]
struct Ambients(Vec<(PathBuf, RgbRaster)>);

impl Ambients {
    /// The photo at `path`, read on first use and checked to be
    /// `camera`'s size.
    fn get(&mut self, path: &Path, camera: &Intrinsics) -> Result<&RgbRaster, RigcalError> {
        let k = match self.0.iter().position(|(p, _)| p == path) {
            Some(k) => k,
            None => {
                let photo = read_shot(path)?;
                check_size(&photo, camera, path)?;
                self.0.push((path.to_path_buf(), photo));
                self.0.len() - 1
            }
        };
        Ok(&self.0[k].1)
    }
}

/// One light's intensity from one photo and its ambient.
fn measure(
    dir: &Path,
    manifest: &WhiteManifest,
    photo: &WhitePhoto,
    ambients: &mut Ambients,
    card: &CardView,
    camera: &PinholeCamera,
    source: &Source,
) -> Result<LightLevel, RigcalError> {
    let path = dir.join(&photo.file);
    let name = &photo.lights[0];
    let ambient_photo = manifest
        .ambient_of(photo)
        .ok_or_else(|| RigcalError::WhiteCard {
            path: path.clone(),
            reason: "no ambient photo to read it against".into(),
        })?;
    let lit = read_shot(&path)?;
    check_size(&lit, &camera.intrinsics, &path)?;
    let ambient = ambients.get(&dir.join(&ambient_photo.file), &camera.intrinsics)?;
    let signal = |index: usize| -> Option<[f64; 3]> {
        let (l, a) = (lit.data[index], ambient.data[index]);
        if l.iter().any(|&c| c >= CLIPPED_LEVEL) {
            return None;
        }
        Some([0, 1, 2].map(|c| f64::from(l[c] - a[c])))
    };
    let exposure = photo.exposure_s;
    let (ratios, clipped) = match source {
        Source::Panel => panel_readings(card, &signal, exposure),
        Source::Point { world, field } => {
            let eye = camera.center();
            let bsdf = Bsdf::new(&card.material, card.normal.as_vec3(), card.normal.as_vec3());
            let mut ratios = Vec::with_capacity(card.pixels.len());
            let mut clipped = 0usize;
            for &(index, x) in &card.pixels {
                if let Some(f) = field {
                    let inside = f.project(x).is_some_and(|p| {
                        let k = &f.intrinsics;
                        p.x >= 2.0
                            && p.y >= 2.0
                            && p.x <= f64::from(k.width) - 2.0
                            && p.y <= f64::from(k.height) - 2.0
                    });
                    if !inside {
                        continue;
                    }
                }
                let Some(s) = signal(index) else {
                    clipped += 1;
                    continue;
                };
                let to_light = *world - x;
                let d2 = to_light.length_squared();
                let wi = to_light.normalize();
                let wo = (eye - x).normalize();
                if wi.dot(card.normal) <= 0.0 {
                    continue;
                }
                let f = bsdf.eval(wo.as_vec3(), wi.as_vec3()).value;
                let predicted = [f.x, f.y, f.z].map(|c| exposure * f64::from(c) / d2);
                if predicted.iter().all(|p| p.is_finite() && *p > 0.0) {
                    ratios.push([0, 1, 2].map(|c| s[c] / predicted[c]));
                }
            }
            (ratios, clipped)
        }
    };
    // Half the card clipped, or (the panel) more of the background clipped
    // than the panel shows unclipped.
    let clip_limit = match source {
        Source::Panel => ratios.len(),
        Source::Point { .. } => card.pixels.len() / 2,
    };
    if clipped > clip_limit {
        return Err(RigcalError::WhiteCard {
            path,
            reason: format!("`{name}` clips {clipped} pixels; photograph it at a shorter exposure"),
        });
    }
    let lumas: Vec<f64> = ratios.iter().map(luma).collect();
    let mid = median(&lumas);
    let signal_floor = match source {
        Source::Panel => MIN_SIGNAL / exposure,
        Source::Point { .. } => 0.0,
    };
    if ratios.len() < MIN_PIXELS || !(mid.is_finite() && mid > signal_floor) {
        return Err(RigcalError::WhiteCard {
            path,
            reason: format!(
                "the card reads no light from `{name}` ({} usable pixels): it is in shadow, \
                 outside the light's reach, or the light did not fire",
                ratios.len()
            ),
        });
    }
    let shadowed = lumas.iter().filter(|&&r| r < SHADOWED * mid).count();
    if matches!(source, Source::Point { .. })
        && shadowed as f64 > MAX_SHADOWED_SHARE * lumas.len() as f64
    {
        return Err(RigcalError::WhiteCard {
            path,
            reason: format!(
                "{:.0} % of the card reads under half the rest under `{name}`: part of it is \
                 in shadow; clear the line from the light to the card",
                100.0 * shadowed as f64 / lumas.len() as f64
            ),
        });
    }
    // The pixels the median stands for: a shadowed minority left out.
    let kept: Vec<[f64; 3]> = ratios
        .iter()
        .zip(&lumas)
        .filter(|(_, &l)| l >= SHADOWED * mid)
        .map(|(r, _)| *r)
        .collect();
    let per_channel = [0, 1, 2].map(|c| median(&kept.iter().map(|r| r[c]).collect::<Vec<_>>()));
    let peak = per_channel.iter().copied().fold(0.0, f64::max);
    if !(peak.is_finite() && peak > 0.0 && per_channel.iter().all(|c| *c >= 0.0)) {
        return Err(RigcalError::WhiteCard {
            path,
            reason: format!("`{name}` gives no usable reading on the card"),
        });
    }
    let kept_lumas: Vec<f64> = kept.iter().map(luma).collect();
    let spread = (percentile(&kept_lumas, 0.75) - percentile(&kept_lumas, 0.25)) / (2.0 * mid);
    Ok(LightLevel {
        name: name.clone(),
        intensity: peak,
        color: per_channel.map(|c| c / peak),
        pixels: kept.len(),
        spread,
        file: photo.file.clone(),
    })
}

/// The backlight panel's readings: background pixels within 10 % of the
/// brightest (the panel, its blurred edges left out), value per second;
/// and how many background pixels clip.
fn panel_readings(
    card: &CardView,
    signal: &dyn Fn(usize) -> Option<[f64; 3]>,
    exposure: f64,
) -> (Vec<[f64; 3]>, usize) {
    let values: Vec<[f64; 3]> = card.background.iter().filter_map(|&i| signal(i)).collect();
    let clipped = card.background.len() - values.len();
    let top = percentile(&values.iter().map(luma).collect::<Vec<_>>(), 0.99);
    let readings = values
        .into_iter()
        .filter(|v| luma(v) >= 0.9 * top)
        .map(|v| v.map(|c| c / exposure))
        .collect();
    (readings, clipped)
}

/// The luminance of an RGB reading, as the detector weighs a photo.
fn luma(c: &[f64; 3]) -> f64 {
    f64::from(luminance(&c.map(|x| x as f32)))
}

fn median(v: &[f64]) -> f64 {
    percentile(v, 0.5)
}

/// `rig` with every position's lights given the intensities and colours
/// `radiometry` measured (the head's lights are the same at every
/// position); the backlight panel is added where the rig file lacks it.
pub fn intensities_in_rig(rig: &Manifest, radiometry: &Radiometry) -> Manifest {
    let mut out = rig.clone();
    for position in &mut out.positions {
        let panel = radiometry.lights.iter().find(|l| l.name == BACKLIGHT);
        if panel.is_some() && !position.lights.iter().any(|l| l.name == BACKLIGHT) {
            position.lights.push(matscan_scan::Light {
                name: BACKLIGHT.to_string(),
                kind: LightKind::Backlight,
                color: [1.0; 3],
                intensity: None,
            });
        }
        for light in &mut position.lights {
            if let Some(level) = radiometry.lights.iter().find(|l| l.name == light.name) {
                light.intensity = Some(level.intensity);
                light.color = level.color;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use matscan_scan::image_io::write_rgb_exr;
    use matscan_scan::raster::RgbRaster;
    use matscan_scan::white_bundle::{WhiteCard, WHITE_MANIFEST};
    use matscan_scan::{Pattern, Precision};
    use matscan_sim::calib_target::{board_for, reference_placement, truth_rig, INNER_CORNERS};
    use matscan_sim::render::{CaptureSpec, RenderOptions, Renderer};
    use matscan_sim::scene::{random_rig, RigOptions};
    use matscan_sim::white_target::{empty_mount_scene, white_card_scene};
    use rand::SeedableRng;

    /// The simulated rig's white card under each light, flash0 also at
    /// half the exposure, and the backlight panel with the mount empty,
    /// written as a bundle; with the true rig. `shade` darkens the given
    /// share of the card's rows in flash1's photo (an object between the
    /// light and the card).
    fn bundle(dir: &Path, seed: u64, shade: f32) -> (WhiteManifest, Manifest) {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let rig = random_rig(
            &mut rng,
            RigOptions {
                width: 200,
                height: 150,
                positions: 1,
            },
        );
        let board = board_for(&rig, INNER_CORNERS);
        let card = WhiteCard::on_board(&board, reference_placement(&board, &rig), 0.9, 1.0);
        let options = RenderOptions {
            samples: 8,
            seed,
            ..RenderOptions::default()
        };
        let render = |scene: &matscan_sim::scene::Scene, captures: &[CaptureSpec]| {
            Renderer::new(scene)
                .unwrap()
                .render_position(0, captures, &options)
                .unwrap()
                .photos
        };
        let card_captures = [
            CaptureSpec::new("ambient", &[], None),
            CaptureSpec::new("flash0", &["flash0"], None),
            CaptureSpec::new("flash1", &["flash1"], None),
            CaptureSpec::new(
                "projector",
                &["projector"],
                Some(Pattern::Uniform { level: 1.0 }),
            ),
        ];
        let photos = render(&white_card_scene(&card, &rig), &card_captures);
        let panel_captures = [
            CaptureSpec::new("ambient-panel", &[], None),
            CaptureSpec::new("backlight", &["backlight"], None),
        ];
        let panel = render(&empty_mount_scene(&rig, 0), &panel_captures);
        let exposure = f64::from(rig.positions[0].exposure_s);
        std::fs::create_dir_all(dir.join("p0")).unwrap();
        let mut entries = Vec::new();
        let mut write = |name: &str, raster: &RgbRaster, e: f64, lit: &[&str], ambient: &str| {
            let file = PathBuf::from("p0").join(format!("{name}.exr"));
            write_rgb_exr(&dir.join(&file), raster, Precision::Half).unwrap();
            entries.push(WhitePhoto {
                file,
                exposure_s: e,
                lights: lit.iter().map(|s| s.to_string()).collect(),
                ambient: (!lit.is_empty())
                    .then(|| PathBuf::from("p0").join(format!("{ambient}.exr"))),
            });
        };
        for (spec, photo) in card_captures.iter().zip(&photos) {
            let mut photo = photo.clone();
            if spec.name == "flash1" {
                let rows = (shade * photo.height as f32) as usize * photo.width as usize;
                let ambient = &photos[0].data;
                for (p, a) in photo.data.iter_mut().zip(ambient).take(rows) {
                    *p = *a;
                }
            }
            let lit: Vec<&str> = spec.lights.iter().map(String::as_str).collect();
            write(&spec.name, &photo, exposure, &lit, "ambient");
        }
        write("ambient-panel", &panel[0], exposure, &[], "");
        write(
            "backlight",
            &panel[1],
            exposure,
            &["backlight"],
            "ambient-panel",
        );
        // Half the exposure: the renderer is linear, as a raw camera is.
        let half = |r: &RgbRaster| r.map(|p| p.map(|c| 0.5 * c));
        write("ambient-half", &half(&photos[0]), 0.5 * exposure, &[], "");
        let half_flash = half(&photos[1]);
        write(
            "flash0-half",
            &half_flash,
            0.5 * exposure,
            &["flash0"],
            "ambient-half",
        );
        let manifest = WhiteManifest {
            units: "m".into(),
            position: "p0".into(),
            card,
            photos: entries,
        };
        std::fs::write(dir.join(WHITE_MANIFEST), manifest.to_toml()).unwrap();
        (manifest, truth_rig(&rig))
    }

    /// Every light's intensity and colour from the rendered card, against
    /// the intensities the simulator lit it with, the backlight panel's
    /// too though the rig file lacks it; flash0's two exposures agree.
    #[test]
    fn the_simulated_white_card_gives_each_lights_intensity() {
        let dir = tempfile::tempdir().unwrap();
        let (manifest, truth) = bundle(dir.path(), 5, 0.0);
        let read = WhiteManifest::read(dir.path()).unwrap();
        assert_eq!(read, manifest);
        let mut board_only = truth.clone();
        board_only.positions[0]
            .lights
            .retain(|l| l.name != BACKLIGHT);
        let r = calibrate_radiometry(dir.path(), &manifest, &board_only).unwrap();
        assert_eq!(r.lights.len(), 4);
        for level in &r.lights {
            let light = truth.positions[0]
                .lights
                .iter()
                .find(|l| l.name == level.name)
                .unwrap();
            let want = light.intensity.unwrap();
            let error = level.intensity / want - 1.0;
            assert!(
                error.abs() < 0.02,
                "{}: {error:+.4} ({level:?})",
                level.name
            );
            for c in 0..3 {
                assert!(
                    (level.color[c] - light.color[c]).abs() < 0.02,
                    "{}: colour {:?} against {:?}",
                    level.name,
                    level.color,
                    light.color
                );
            }
        }
        assert_eq!(r.linearity.len(), 1);
        assert!(r.linearity[0].worst() < 0.005, "{:?}", r.linearity);
        let rig = intensities_in_rig(&board_only, &r);
        let flash = rig.positions[0].lights.iter().find(|l| l.name == "flash1");
        assert!(flash.is_some_and(|l| l.intensity.is_some()));
        let panel = rig.positions[0].lights.iter().find(|l| l.name == BACKLIGHT);
        assert!(panel.is_some_and(|l| l.kind == LightKind::Backlight && l.intensity.is_some()));
    }

    /// A card half in shadow of one flash, and a camera whose photos are
    /// gamma-encoded, are refused with the photo and the light named.
    #[test]
    fn a_shadowed_card_and_a_nonlinear_camera_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let (manifest, truth) = bundle(dir.path(), 6, 0.5);
        let e = calibrate_radiometry(dir.path(), &manifest, &truth)
            .unwrap_err()
            .to_string();
        assert!(e.contains("flash1.exr") && e.contains("shadow"), "{e}");

        let dir = tempfile::tempdir().unwrap();
        let (manifest, truth) = bundle(dir.path(), 6, 0.0);
        // A camera that encodes with a gamma: the half exposure reads
        // 0.5^(1/2.2) of the full one, not half.
        for name in ["ambient-half", "flash0-half"] {
            let path = dir.path().join("p0").join(format!("{name}.exr"));
            let r = read_shot(&path).unwrap();
            let g = 0.5f32.powf(1.0 / 2.2) / 0.5;
            write_rgb_exr(&path, &r.map(|p| p.map(|c| c * g)), Precision::Half).unwrap();
        }
        let e = calibrate_radiometry(dir.path(), &manifest, &truth)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not linear") && e.contains("flash0"), "{e}");
    }
}
