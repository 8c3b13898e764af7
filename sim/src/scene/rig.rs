//! The simulated scan head and its randomization (thesis sections 3.1.1 and
//! 3.1.4), and its description as manifest lights.
//!
//! World frame: +Y up; the object sits in the unit box around the origin;
//! the scan head starts on the -Z side looking towards +Z. Camera and
//! projector poses use the OpenCV frame (x right, y down, z forward).
//!
//! Base pose (position `p0`), all random values R uniform in [0, 1]:
//! - the baseline centre starts at (0, 0, -1.5) and moves by
//!   (0.1 Rx, 0.1 Ry, -0.1 Rz) (away from the object, so the camera stays at
//!   least 1.5 units from the origin);
//! - the baseline length is uniform in 0.2..0.4 units (the thesis gives no
//!   range); it runs along the image's x axis;
//! - flash0 and flash1 sit at its two ends, each moved by up to +-0.1 x
//!   baseline along it and +-0.05 x baseline across it; the camera sits at
//!   flash0 (the thesis tracks it there);
//! - the projector sits on the baseline within +-0.5 x baseline of its centre
//!   and +-0.05 x baseline across it;
//! - camera and projector look at the focus centre (0.1 Rx, 0.1 Ry, 0.5 Rz);
//! - the backlight is a 2.4 x 2.4 panel 1.0..1.2 units behind the origin on
//!   the camera's line of sight to the focus centre, facing the camera, tilted
//!   by up to +-0.1 rad about its two edges (thesis: "slight individual random
//!   rotations"). Its emitting side is `half_u x half_v`, which points towards
//!   the camera. It is larger than the thesis's so that the object's
//!   silhouette lies on it for every focal length.
//!
//! Camera: focal length from [`FOCAL_LENGTHS_MM`], a 36 mm sensor fitted to
//! the larger image side (Blender's "Auto" sensor fit), square pixels,
//! principal point at the image centre, no distortion. Projector: 1024 x 768
//! with a random horizontal half field of view (tangent 0.4..0.6), the
//! thesis's "random size of the illuminated area".
//!
//! Light: flash intensities follow thesis eq. 3.1, I = I0 (1 + 0.5 Rs +
//! 0.05 Rs Ri) with Rs shared and Ri per flash. I0 makes a white diffuse
//! surface at the origin, lit head-on, reach radiance [`FLASH_WHITE_RADIANCE`];
//! the procedural environment (the renderer normalizes it to mean radiance 1)
//! gets a strength of 0.25..1, so the flash signal is comparable to or
//! brighter than the ambient light. The projector at full white is twice a
//! flash (a uniform 0.5 image is like a flash) and the backlight panel emits
//! [`BACKLIGHT_RADIANCE`]; both get the thesis's up to +50 % increment.
//! Colours: flashes share a warm (HSV hue 0.1666, the thesis's phone flash)
//! or, with chance 0.3, cold (hue 0.58) tint with saturation around the
//! thesis's 0.1 (shared 0.05..0.15 plus +-0.02 each); the projector is white;
//! the backlight gets its own slight warm or cold tint (saturation 0..0.1).
//! When off, the panel is white diffuse with albedo 0.85 plus a random
//! 0..0.1 (the thesis adds this per channel; the renderer's panel albedo is
//! grey, so one value is drawn).
//!
//! Exposure: the same for every capture of a scene, chosen so that white
//! under flash0 plus an environment of [`NOMINAL_ENV_STRENGTH`] reads 0.5.
//!
//! Positions: `p0` is the base pose; `p1`, `p2`, ... rotate the whole head
//! (camera, flashes, projector, backlight) about the origin by up to +-36
//! degrees about the x and y axes relative to `p0`.
//!
//! Drowned positions (thesis 3.1.6) are judged after rendering, by calib's
//! bad-light rule (`crate::render::drowned`), since only the renders show
//! them.

use super::color::hsv_to_rgb;
use super::model::{Backlight, PointLight, Projector, Rig, RigPosition};
use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use matscan_scan::camera::{look_at, Intrinsics, PinholeCamera};
use matscan_scan::{Light, LightKind, Manifest};
use rand::Rng;
use rand_pcg::Pcg64;

/// The thesis's focal lengths, mm (36 mm sensor).
pub const FOCAL_LENGTHS_MM: [f64; 6] = [20.0, 30.0, 30.99, 40.0, 50.0, 60.0];
pub const SENSOR_WIDTH_MM: f64 = 36.0;
/// Largest rotation of a further position about x and about y, degrees.
pub const POSITION_ROTATION_DEG: f64 = 36.0;
/// Radiance of a white diffuse surface at the origin under flash0 before the
/// random increments.
pub const FLASH_WHITE_RADIANCE: f32 = 1.5;
/// Panel radiance when on, before the random increment and tint.
pub const BACKLIGHT_RADIANCE: f32 = 1.5;
/// Diffuse albedo of the switched-off panel before the random addition.
pub const BACKLIGHT_ALBEDO: f32 = 0.85;
pub const PROJECTOR_WIDTH: u32 = 1024;
pub const PROJECTOR_HEIGHT: u32 = 768;
const BACKLIGHT_HALF_SIZE: f64 = 1.2;
const WARM_HUE: f32 = 0.1666;
const COLD_HUE: f32 = 0.58;

/// What the rig randomization needs from the caller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RigOptions {
    /// Camera image size in pixels (0 is taken as 1).
    pub width: u32,
    pub height: u32,
    /// Number of positions (0 is taken as 1).
    pub positions: usize,
}

impl Default for RigOptions {
    fn default() -> Self {
        RigOptions {
            width: 256,
            height: 256,
            positions: 3,
        }
    }
}

/// The environment strength range the light levels are balanced against.
pub const ENV_STRENGTH: std::ops::Range<f32> = 0.25..1.0;
/// The environment strength the exposure assumes (the middle of the range),
/// like a camera's fixed exposure for typical surroundings.
pub const NOMINAL_ENV_STRENGTH: f32 = 0.625;

/// A random rig.
pub fn random_rig(rng: &mut Pcg64, options: RigOptions) -> Rig {
    let width = options.width.max(1);
    let height = options.height.max(1);
    let focal_mm = FOCAL_LENGTHS_MM[rng.gen_range(0..FOCAL_LENGTHS_MM.len())];
    let f = focal_mm / SENSOR_WIDTH_MM * width.max(height) as f64;
    let intrinsics = Intrinsics {
        width,
        height,
        fx: f,
        fy: f,
        cx: width as f64 / 2.0,
        cy: height as f64 / 2.0,
        distortion: [0.0; 5],
    };
    let base = base_position(rng);
    let mut positions = vec![base.clone()];
    for k in 1..options.positions.max(1) {
        let limit = POSITION_ROTATION_DEG.to_radians();
        let ax = rng.gen_range(-limit..=limit);
        let ay = rng.gen_range(-limit..=limit);
        let rotation = DQuat::from_rotation_y(ay) * DQuat::from_rotation_x(ax);
        positions.push(rotate_position(&base, rotation, format!("p{k}")));
    }
    Rig {
        intrinsics,
        positions,
    }
}

fn jitter(rng: &mut Pcg64, amount: f64) -> f64 {
    rng.gen_range(-amount..=amount)
}

fn base_position(rng: &mut Pcg64) -> RigPosition {
    let baseline_centre = DVec3::new(
        0.1 * rng.gen::<f64>(),
        0.1 * rng.gen::<f64>(),
        -1.5 - 0.1 * rng.gen::<f64>(),
    );
    let baseline: f64 = rng.gen_range(0.2..=0.4);
    // Looking along +Z with +Y up, the image's x axis is world -X.
    let along = -DVec3::X;
    let flash_at = |rng: &mut Pcg64, side: f64| {
        baseline_centre
            + along * (side * 0.5 * baseline + jitter(rng, 0.1 * baseline))
            + DVec3::Y * jitter(rng, 0.05 * baseline)
            + DVec3::Z * jitter(rng, 0.05 * baseline)
    };
    let flash0 = flash_at(rng, -1.0);
    let flash1 = flash_at(rng, 1.0);
    let projector_at = baseline_centre
        + along * jitter(rng, 0.5 * baseline)
        + DVec3::Y * jitter(rng, 0.05 * baseline)
        + DVec3::Z * jitter(rng, 0.05 * baseline);
    let focus = DVec3::new(
        0.1 * rng.gen::<f64>(),
        0.1 * rng.gen::<f64>(),
        0.5 * rng.gen::<f64>(),
    );
    let camera_to_world = look_at(flash0, focus, DVec3::Y);
    let projector_to_world = look_at(projector_at, focus, DVec3::Y);

    // Light levels (eq. 3.1 for the flashes).
    let distance = flash0.length() as f32;
    let i0 = FLASH_WHITE_RADIANCE * std::f32::consts::PI * distance * distance;
    let shared: f32 = rng.gen();
    let flash_intensity =
        |rng: &mut Pcg64| i0 * (1.0 + 0.5 * shared + 0.1 * (0.5 * shared) * rng.gen::<f32>());
    let intensities = [flash_intensity(rng), flash_intensity(rng)];
    let hue = if rng.gen_bool(0.3) {
        COLD_HUE
    } else {
        WARM_HUE
    };
    let saturation: f32 = rng.gen_range(0.05..0.15);
    let flash_color =
        |rng: &mut Pcg64| hsv_to_rgb(hue, saturation + rng.gen_range(-0.02..0.02), 1.0);
    let colors = [flash_color(rng), flash_color(rng)];
    let flashes = [flash0, flash1]
        .iter()
        .zip(intensities.iter().zip(colors))
        .enumerate()
        .map(|(k, (p, (&intensity, color)))| PointLight {
            name: format!("flash{k}"),
            position: p.as_vec3(),
            color,
            intensity,
        })
        .collect();

    let tan_half: f64 = rng.gen_range(0.4..=0.6);
    let pf = PROJECTOR_WIDTH as f64 / 2.0 / tan_half;
    let projector = Projector {
        name: "projector".into(),
        projector_to_world,
        intrinsics: Intrinsics {
            width: PROJECTOR_WIDTH,
            height: PROJECTOR_HEIGHT,
            fx: pf,
            fy: pf,
            cx: PROJECTOR_WIDTH as f64 / 2.0,
            cy: PROJECTOR_HEIGHT as f64 / 2.0,
            distortion: [0.0; 5],
        },
        color: Vec3::ONE,
        intensity: 2.0 * i0 * (1.0 + 0.5 * rng.gen::<f32>()),
    };

    let backlight = {
        let axes = DMat3::from_mat4(camera_to_world);
        let (right, down) = (axes.x_axis, axes.y_axis);
        let centre = (focus - flash0).normalize() * rng.gen_range(1.0..=1.2);
        let tilt = DQuat::from_axis_angle(right, jitter(rng, 0.1))
            * DQuat::from_axis_angle(down, jitter(rng, 0.1));
        let tint_hue = if rng.gen_bool(0.5) {
            WARM_HUE
        } else {
            COLD_HUE
        };
        let tint = hsv_to_rgb(tint_hue, rng.gen_range(0.0..0.1), 1.0);
        Backlight {
            name: "backlight".into(),
            center: centre.as_vec3(),
            half_u: (tilt * right * BACKLIGHT_HALF_SIZE).as_vec3(),
            half_v: (tilt * -down * BACKLIGHT_HALF_SIZE).as_vec3(),
            radiance: tint * BACKLIGHT_RADIANCE * (1.0 + 0.5 * rng.gen::<f32>()),
            albedo: BACKLIGHT_ALBEDO + rng.gen_range(0.0..0.1),
        }
    };

    let flash_white = intensities[0] / (std::f32::consts::PI * distance * distance);
    RigPosition {
        name: "p0".into(),
        camera_to_world,
        flashes,
        projector,
        backlight,
        exposure_s: 0.5 / (flash_white + NOMINAL_ENV_STRENGTH),
    }
}

/// `base` with the whole head rotated about the origin.
fn rotate_position(base: &RigPosition, rotation: DQuat, name: String) -> RigPosition {
    let m = DMat4::from_quat(rotation);
    let r = rotation.as_quat();
    RigPosition {
        name,
        camera_to_world: m * base.camera_to_world,
        flashes: base
            .flashes
            .iter()
            .map(|f| PointLight {
                position: r * f.position,
                ..f.clone()
            })
            .collect(),
        projector: Projector {
            projector_to_world: m * base.projector.projector_to_world,
            ..base.projector.clone()
        },
        backlight: Backlight {
            center: r * base.backlight.center,
            half_u: r * base.backlight.half_u,
            half_v: r * base.backlight.half_v,
            ..base.backlight.clone()
        },
        exposure_s: base.exposure_s,
    }
}

impl Rig {
    /// The camera of position `index`, if there is one.
    pub fn camera(&self, index: usize) -> Option<PinholeCamera> {
        self.positions
            .get(index)
            .map(|p| PinholeCamera::new(self.intrinsics, p.camera_to_world))
    }
}

/// The contract's `[[position.light]]` entries for one position: flash0 and
/// flash1 (point), the projector (pose and intrinsics) and the backlight,
/// each with its colour (normalized to a largest channel of 1) and
/// intensity (W/sr; the backlight's radiance).
pub fn rig_to_manifest_lights(position: &RigPosition) -> Vec<Light> {
    let colour = |c: Vec3| c.as_dvec3().to_array();
    let mut lights: Vec<Light> = position
        .flashes
        .iter()
        .map(|f| Light {
            name: f.name.clone(),
            kind: LightKind::Point {
                position: f.position.as_dvec3(),
            },
            color: colour(f.color),
            intensity: Some(f.intensity as f64),
        })
        .collect();
    let p = &position.projector;
    lights.push(Light {
        name: p.name.clone(),
        kind: LightKind::Projector {
            projector_to_world: p.projector_to_world,
            intrinsics: p.intrinsics,
        },
        color: colour(p.color),
        intensity: Some(p.intensity as f64),
    });
    let b = &position.backlight;
    let peak = b.radiance.max_element();
    let (color, intensity) = if peak > 0.0 && peak.is_finite() {
        (colour(b.radiance / peak), peak)
    } else {
        ([1.0; 3], 0.0)
    };
    lights.push(Light {
        name: b.name.clone(),
        kind: LightKind::Backlight,
        color,
        intensity: Some(intensity as f64),
    });
    lights
}

/// The rig a scan manifest describes (a simulated scan's, or a rig file
/// with its exposure), so that calibration targets can be photographed
/// under exactly that rig: its camera, each position's pose, flashes and
/// projector, and a backlight panel of the manifest's radiance 1.1 units
/// beyond the origin on the camera's axis, facing it (the manifest does
/// not say where the panel stands; calibration measures only its
/// radiance). Every position takes the exposure of its first capture, or
/// without captures (a rig file) the one [`random_rig`] would choose for
/// its first flash. An error names the position and light that is missing
/// or has no intensity.
pub fn rig_from_manifest(manifest: &Manifest) -> Result<Rig, String> {
    let mut positions = Vec::new();
    for p in &manifest.positions {
        let no_intensity =
            |l: &Light| format!("position {}: light `{}` has no intensity", p.name, l.name);
        let intensity = |l: &Light| {
            l.intensity
                .filter(|i| i.is_finite() && *i >= 0.0)
                .map(|i| i as f32)
                .ok_or_else(|| no_intensity(l))
        };
        let colour = |l: &Light| Vec3::from_array(l.color.map(|c| c as f32));
        let mut flashes = Vec::new();
        let mut projector = None;
        let mut backlight = None;
        for l in &p.lights {
            match &l.kind {
                LightKind::Point { .. } => {
                    flashes.push(PointLight::from_manifest(l).ok_or_else(|| no_intensity(l))?)
                }
                LightKind::Projector {
                    projector_to_world,
                    intrinsics,
                } => {
                    projector = Some(Projector {
                        name: l.name.clone(),
                        projector_to_world: *projector_to_world,
                        intrinsics: *intrinsics,
                        color: colour(l),
                        intensity: intensity(l)?,
                    })
                }
                LightKind::Backlight => {
                    let axes = DMat3::from_mat4(p.camera_to_world);
                    let (right, down, forward) = (axes.x_axis, axes.y_axis, axes.z_axis);
                    let eye = p.camera_to_world.w_axis.truncate();
                    let centre = eye + forward * (eye.length() + 1.1);
                    backlight = Some(Backlight {
                        name: l.name.clone(),
                        center: centre.as_vec3(),
                        half_u: (right * BACKLIGHT_HALF_SIZE).as_vec3(),
                        half_v: (-down * BACKLIGHT_HALF_SIZE).as_vec3(),
                        radiance: colour(l) * intensity(l)?,
                        albedo: BACKLIGHT_ALBEDO,
                    })
                }
            }
        }
        let missing = |what: &str| format!("position {}: no {what} light", p.name);
        let exposure_s = match (p.captures.first(), flashes.first()) {
            (Some(c), _) => c.exposure_s as f32,
            (None, Some(f)) => {
                let d2 = f.position.length_squared().max(1e-6);
                let white = f.intensity / (std::f32::consts::PI * d2);
                0.5 / (white + NOMINAL_ENV_STRENGTH)
            }
            (None, None) => 1.0,
        };
        positions.push(RigPosition {
            name: p.name.clone(),
            camera_to_world: p.camera_to_world,
            flashes,
            projector: projector.ok_or_else(|| missing("projector"))?,
            backlight: backlight.ok_or_else(|| missing("backlight"))?,
            exposure_s,
        });
    }
    if positions.is_empty() {
        return Err("the manifest has no position".into());
    }
    Ok(Rig {
        intrinsics: manifest.camera,
        positions,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use rand::SeedableRng;

    /// Half the diagonal of the unit box: no object point is farther from
    /// the origin.
    const BOX_RADIUS: f64 = 0.8661;

    fn rigs() -> Vec<Rig> {
        (0..24)
            .map(|s| {
                let options = RigOptions {
                    width: 320,
                    height: 240,
                    positions: 4,
                };
                random_rig(&mut Pcg64::seed_from_u64(s), options)
            })
            .collect()
    }

    #[test]
    fn intrinsics_use_a_thesis_focal_length_and_a_centred_principal_point() {
        for rig in rigs() {
            let k = rig.intrinsics;
            assert_eq!((k.width, k.height, k.cx, k.cy), (320, 240, 160.0, 120.0));
            assert_eq!(k.fx, k.fy);
            let mm = k.fx / 320.0 * SENSOR_WIDTH_MM;
            assert!(
                FOCAL_LENGTHS_MM.iter().any(|&f| (f - mm).abs() < 1e-9),
                "{mm}"
            );
        }
    }

    #[test]
    fn every_camera_looks_at_the_origin_from_outside_the_box() {
        for rig in rigs() {
            assert_eq!(rig.positions.len(), 4);
            for (i, p) in rig.positions.iter().enumerate() {
                assert_eq!(p.name, format!("p{i}"));
                let cam = rig.camera(i).unwrap();
                let d = cam.center().length();
                assert!((1.5..2.0).contains(&d), "distance {d}");
                let px = cam.project(DVec3::ZERO).unwrap();
                let off = (px - DVec2::new(160.0, 120.0)) / DVec2::new(320.0, 240.0);
                assert!(off.abs().max_element() < 0.25, "origin at {px}");
            }
        }
    }

    #[test]
    fn flashes_sit_beside_the_camera_on_the_object_side() {
        for rig in rigs() {
            for p in &rig.positions {
                let cam = p.camera_to_world.transform_point3(DVec3::ZERO);
                let f0 = p.flashes[0].position.as_dvec3();
                let f1 = p.flashes[1].position.as_dvec3();
                assert!(f0.distance(cam) < 1e-6, "camera tracks flash0");
                let baseline = f0.distance(f1);
                assert!((0.15..0.5).contains(&baseline), "baseline {baseline}");
                for f in [f0, f1] {
                    assert!(f.length() > BOX_RADIUS);
                    // Same side as the camera, within about 25 degrees of it.
                    assert!(f.normalize().dot(cam.normalize()) > 0.9);
                }
                // flash1 is to the side: along the image x axis.
                let right = p.camera_to_world.transform_vector3(DVec3::X);
                assert!((f1 - f0).normalize().dot(right).abs() > 0.9);
            }
        }
    }

    /// Distance along `ray` to the panel and whether the hit lies on it.
    fn hit_panel(b: &Backlight, origin: DVec3, dir: DVec3) -> Option<f64> {
        let (c, u, v) = (
            b.center.as_dvec3(),
            b.half_u.as_dvec3(),
            b.half_v.as_dvec3(),
        );
        let n = u.cross(v).normalize();
        let t = (c - origin).dot(n) / dir.dot(n);
        let q = origin + dir * t - c;
        let inside = (q.dot(u) / u.length_squared()).abs() <= 1.0
            && (q.dot(v) / v.length_squared()).abs() <= 1.0;
        (t > 0.0 && inside).then_some(t)
    }

    #[test]
    fn backlight_faces_the_camera_behind_the_whole_object() {
        for rig in rigs() {
            for (i, p) in rig.positions.iter().enumerate() {
                let cam = rig.camera(i).unwrap();
                let eye = cam.center();
                let b = &p.backlight;
                let n = b.half_u.cross(b.half_v).as_dvec3();
                assert!(
                    n.dot(eye - b.center.as_dvec3()) > 0.0,
                    "emitting side faces the camera"
                );
                let to_origin = (-eye).normalize();
                let t = hit_panel(b, eye, to_origin).expect("line of sight hits the panel");
                assert!(
                    t > eye.length() + BOX_RADIUS,
                    "panel at {t}, object until {}",
                    eye.length() + BOX_RADIUS
                );
                // The silhouette of any object within 0.5 of the origin lies on
                // the panel: rays to points on that sphere's rim hit it.
                let side = cam.camera_to_world.transform_vector3(DVec3::X);
                let up = cam.camera_to_world.transform_vector3(DVec3::Y);
                for k in 0..16 {
                    let a = k as f64 * std::f64::consts::TAU / 16.0;
                    let rim = (side * a.cos() + up * a.sin()) * 0.5;
                    assert!(
                        hit_panel(b, eye, (rim - eye).normalize()).is_some(),
                        "rim {k} misses"
                    );
                }
                assert!((0.85..0.95).contains(&b.albedo));
                assert!(b.radiance.min_element() > 0.0);
            }
        }
    }

    #[test]
    fn projector_sees_the_object() {
        for rig in rigs() {
            for p in &rig.positions {
                let proj =
                    PinholeCamera::new(p.projector.intrinsics, p.projector.projector_to_world);
                let px = proj
                    .project(DVec3::ZERO)
                    .expect("origin in front of the projector");
                let k = p.projector.intrinsics;
                assert!(
                    px.x > 0.2 * k.width as f64 && px.x < 0.8 * k.width as f64,
                    "{px}"
                );
                assert!(
                    px.y > 0.2 * k.height as f64 && px.y < 0.8 * k.height as f64,
                    "{px}"
                );
                let d = proj.center().length();
                assert!(d > BOX_RADIUS && d < 2.0);
            }
        }
    }

    #[test]
    fn light_levels_follow_eq_3_1_and_outshine_the_environment() {
        for rig in rigs() {
            let p = &rig.positions[0];
            let d = p.flashes[0].position.length();
            let i0 = FLASH_WHITE_RADIANCE * std::f32::consts::PI * d * d;
            for f in &p.flashes {
                assert!(f.intensity >= i0 * 0.9999 && f.intensity <= i0 * 1.55 * 1.0001);
                // White and a pale tint: largest channel 1, saturation small.
                assert!((f.color.max_element() - 1.0).abs() < 1e-6);
                assert!(f.color.min_element() > 0.8);
            }
            let ratio = p.flashes[0].intensity / p.flashes[1].intensity;
            assert!((1.0 / 1.034..=1.034).contains(&ratio), "{ratio}");
            let white = p.flashes[0].intensity / (std::f32::consts::PI * d * d);
            assert!(white >= ENV_STRENGTH.end, "flash white {white}");
            assert_eq!(p.projector.color, Vec3::ONE);
            // White under flash0 plus the nominal environment reads 0.5.
            assert!((p.exposure_s * (white + NOMINAL_ENV_STRENGTH) - 0.5).abs() < 1e-5);
            assert!(rig.positions.iter().all(|q| q.exposure_s == p.exposure_s));
        }
    }

    #[test]
    fn further_positions_rotate_the_whole_head_about_the_origin_within_36_degrees() {
        for rig in rigs() {
            let p0 = &rig.positions[0];
            for p in &rig.positions[1..] {
                let rel = p.camera_to_world * p0.camera_to_world.inverse();
                let (_, rotation, translation) = rel.to_scale_rotation_translation();
                assert!(translation.length() < 1e-9, "rotation about the origin");
                let limit = (2.0f64 * POSITION_ROTATION_DEG.to_radians().powi(2)).sqrt();
                assert!(rotation.angle_between(DQuat::IDENTITY) <= limit + 1e-9);
                // Lights move with the head: same distances to the camera.
                let cam = p.camera_to_world.transform_point3(DVec3::ZERO);
                let cam0 = p0.camera_to_world.transform_point3(DVec3::ZERO);
                let d = p.flashes[1].position.as_dvec3().distance(cam);
                let d0 = p0.flashes[1].position.as_dvec3().distance(cam0);
                assert!((d - d0).abs() < 1e-5);
                let pp = p.projector.projector_to_world * p0.projector.projector_to_world.inverse();
                assert!(pp.abs_diff_eq(rel, 1e-9));
            }
        }
    }

    #[test]
    fn manifest_lights_describe_every_rig_light() {
        let rig = &rigs()[0];
        let p = &rig.positions[1];
        let lights = rig_to_manifest_lights(p);
        let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["flash0", "flash1", "projector", "backlight"]);
        match &lights[1].kind {
            LightKind::Point { position } => {
                assert_eq!(*position, p.flashes[1].position.as_dvec3())
            }
            other => panic!("{other:?}"),
        }
        match &lights[2].kind {
            LightKind::Projector {
                projector_to_world,
                intrinsics,
            } => {
                assert_eq!(*projector_to_world, p.projector.projector_to_world);
                assert_eq!(*intrinsics, p.projector.intrinsics);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(lights[3].kind, LightKind::Backlight);
        let back = lights[3].color.map(|c| c as f32);
        let recon = Vec3::from_array(back) * lights[3].intensity.unwrap() as f32;
        assert!((recon - p.backlight.radiance).length() < 1e-5);
        assert!(lights.iter().all(|l| l.intensity.is_some_and(|i| i > 0.0)));
    }

    #[test]
    fn rigs_are_deterministic_per_seed_and_degenerate_options_are_clamped() {
        let o = RigOptions::default();
        let a = random_rig(&mut Pcg64::seed_from_u64(1), o);
        assert_eq!(a, random_rig(&mut Pcg64::seed_from_u64(1), o));
        assert_ne!(a, random_rig(&mut Pcg64::seed_from_u64(2), o));
        let tiny = RigOptions {
            width: 0,
            height: 0,
            positions: 0,
        };
        let r = random_rig(&mut Pcg64::seed_from_u64(1), tiny);
        assert_eq!(r.positions.len(), 1);
        assert_eq!((r.intrinsics.width, r.intrinsics.height), (1, 1));
        assert!(r.positions[0].exposure_s.is_finite() && r.positions[0].exposure_s > 0.0);
    }

    #[test]
    fn a_rig_read_back_from_its_manifest_has_its_camera_poses_and_lights() {
        let rig = &rigs()[0];
        let manifest = crate::calib_target::truth_rig(rig);
        let back = rig_from_manifest(&manifest).unwrap();
        assert_eq!(back.intrinsics, rig.intrinsics);
        for (b, p) in back.positions.iter().zip(&rig.positions) {
            // A rig file has no captures: the exposure is chosen as the
            // rig's own was.
            assert!((b.exposure_s / p.exposure_s - 1.0).abs() < 1e-4);
            assert_eq!(b.camera_to_world, p.camera_to_world);
            assert_eq!(b.flashes, p.flashes);
            assert_eq!(b.projector, p.projector);
            let r = b.backlight.radiance - p.backlight.radiance;
            assert!(r.abs().max_element() < 1e-6, "{r}");
        }
        let mut dark = manifest.clone();
        dark.positions[0].lights[1].intensity = None;
        let e = rig_from_manifest(&dark).unwrap_err();
        assert!(e.contains("p0") && e.contains("flash1"), "{e}");
    }
}
