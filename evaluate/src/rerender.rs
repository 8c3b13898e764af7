//! Re-rendering a scanned object with a material of UV textures under novel
//! lights and from novel views, with the simulated rig's path tracer
//! (`matscan_sim::render::Renderer`). `matscan render` and
//! `matscan eval --textures` stand on it.
//!
//! Framing ([`Framing`]): everything is placed relative to the object's
//! axis-aligned bounding box (centre `c`, half diagonal `r`) and the
//! reference camera's axes (right, up = -y, back = -z, the OpenCV frame), so
//! "left" means the left of the reference image whatever the world's axes.
//!
//! Lights ([`LightName`]): one white point light each, at distance `3 r`
//! from `c` in the direction given in the reference camera's
//! (right, up, back) axes, or attached to the camera:
//!
//! | name        | direction (right, up, back) | |
//! |-------------|-----------------------------|--------------------------------|
//! | `key-left`  | (-1, 0.8, 1)                | front left, above              |
//! | `key-right` | (1, 0.8, 1)                 | front right, above             |
//! | `top`       | (0, 1, 0.25)                | from above, grazing the front  |
//! | `rim`       | (0.6, 0.6, -1)              | behind the object: silhouettes |
//! | `camera`    | at each view's camera, `0.1 d` above it (d = distance to `c`) | a flash |
//! | `none`      | no point light (with `+env`: the environment alone) | |
//!
//! Each light's intensity is `pi * D^2` (D its distance to `c`), so a white
//! Lambertian surface at `c` facing it has radiance 1. A lighting
//! ([`Lighting`]) is a light name with `+env` for the environment on: the
//! renderer's procedural sky of seed [`ENV_SEED`] at strength
//! [`ENV_STRENGTH`] (mean radiance 0.5). Exposure is 1; no backlight panel,
//! no projector.
//!
//! Views ([`CameraPose`]): the reference camera itself (`ref`), or `orbit-KK`, N
//! cameras on the circle about the axis through `c` along the reference
//! camera's up, at the reference camera's distance and elevation, looking at
//! `c`; `orbit-00` sits where the reference camera is.
//!
//! Material ([`material_from_textures`]): the UV textures as
//! `Texture::Map`s (already linear). The maps hold effective transmission
//! and subsurface (the scan format's convention), and the BSDF applies the
//! metallic > transmission > subsurface precedence itself, so they are
//! turned back into authored values (`t / (1 - m)`, `s / ((1 - m)(1 - t))`)
//! before rendering. Missing textures take each parameter's default (`Param::default_value`). The subsurface
//! radius is the renderer's default (1, 1, 1) in scene units: the scan
//! format carries no radius, so estimated and true renders share it.
//!
//! Noise: every render of a view uses the same seed, so two renders that
//! differ only in material share their random numbers where paths agree,
//! and a material rendered against itself is bit-identical.
//!
//! Boundaries: builds a `matscan_sim::scene::Scene` from a mesh, a camera
//! model and a material and renders it; reading textures is
//! `matscan_bake`'s job, comparing images is `crate::image_metrics`'.

use glam::{DMat3, DMat4, DQuat, DVec3, Vec3};
use matscan_bake::BakedTextures;
use matscan_scan::camera::{look_at, Intrinsics};
use matscan_scan::raster::{MaskRaster, RgbRaster};
use matscan_scan::{Bundle, Mesh, Param, ScanError};
use matscan_sim::render::{CaptureSpec, Environment, RenderOptions, Renderer, SimError};
use matscan_sim::scene::{
    Backlight, EnvSource, EnvSpec, MaterialField, PointLight, Projector, Rig, RigPosition, Scene,
    Texture,
};
use std::fmt;
use std::str::FromStr;

/// Seed of the procedural sky of `+env` lightings.
pub const ENV_SEED: u64 = 1;
/// Strength of that sky (its mean radiance; the rig's generator draws
/// 0.25..1).
pub const ENV_STRENGTH: f32 = 0.5;
/// Seed of every re-render (see the module's note on noise).
pub const RENDER_SEED: u64 = 0x5eed;
/// Distance of the fixed lights from the box centre, in half diagonals.
const LIGHT_DISTANCE: f64 = 3.0;
const LIGHT: &str = "key";

/// What can go wrong re-rendering.
#[derive(Debug, thiserror::Error)]
pub enum RerenderError {
    #[error("the mesh has no vertices with finite positions, so there is nothing to frame")]
    EmptyMesh,
    #[error("the mesh has no texture coordinates, so UV textures cannot be applied to it")]
    NoUvs,
    #[error("unknown lighting `{name}` (expected one of {expected}, optionally with `+env`)")]
    UnknownLighting { name: String, expected: String },
    #[error("image size {0} px: expected 8 to 4096")]
    BadSize(u32),
    #[error("samples per pixel must be at least 1")]
    NoSamples,
    #[error("the reference camera sits at the object's centre; no view can look at it")]
    CameraAtCentre,
    #[error(transparent)]
    Render(#[from] SimError),
    #[error(transparent)]
    Scan(#[from] ScanError),
}

/// A named point light (see the module's table).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightName {
    KeyLeft,
    KeyRight,
    Top,
    Rim,
    Camera,
    None,
}

impl LightName {
    pub const ALL: [LightName; 6] = [
        LightName::KeyLeft,
        LightName::KeyRight,
        LightName::Top,
        LightName::Rim,
        LightName::Camera,
        LightName::None,
    ];

    pub fn name(self) -> &'static str {
        match self {
            LightName::KeyLeft => "key-left",
            LightName::KeyRight => "key-right",
            LightName::Top => "top",
            LightName::Rim => "rim",
            LightName::Camera => "camera",
            LightName::None => "none",
        }
    }

    /// Direction from the box centre in the reference camera's (right, up,
    /// back) axes; `None` for the camera light and for no light.
    fn direction(self) -> Option<DVec3> {
        match self {
            LightName::KeyLeft => Some(DVec3::new(-1.0, 0.8, 1.0)),
            LightName::KeyRight => Some(DVec3::new(1.0, 0.8, 1.0)),
            LightName::Top => Some(DVec3::new(0.0, 1.0, 0.25)),
            LightName::Rim => Some(DVec3::new(0.6, 0.6, -1.0)),
            LightName::Camera | LightName::None => None,
        }
    }
}

/// A light and whether the environment is on: `key-left`, `top+env`,
/// `none+env`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Lighting {
    pub light: LightName,
    pub environment: bool,
}

impl fmt::Display for Lighting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.light.name())?;
        if self.environment {
            f.write_str("+env")?;
        }
        Ok(())
    }
}

impl FromStr for Lighting {
    type Err = RerenderError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (name, environment) = match s.strip_suffix("+env") {
            Some(n) => (n, true),
            None => (s, false),
        };
        let unknown = |name: String| RerenderError::UnknownLighting {
            name,
            expected: LightName::ALL.map(LightName::name).join(", "),
        };
        let light = LightName::ALL
            .into_iter()
            .find(|l| l.name() == name)
            .ok_or_else(|| unknown(s.to_string()))?;
        if light == LightName::None && !environment {
            return Err(unknown(format!(
                "{s} (no light and no environment renders black)"
            )));
        }
        Ok(Lighting { light, environment })
    }
}

/// A camera pose to render from.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPose {
    /// `ref` or `orbit-KK`: part of the image file names.
    pub name: String,
    /// OpenCV frame, as the scan format's positions.
    pub camera_to_world: DMat4,
}

/// One image to render: a view under a lighting.
#[derive(Debug, Clone, PartialEq)]
pub struct Shot {
    pub view: CameraPose,
    pub lighting: Lighting,
}

impl Shot {
    /// `<view>-<lighting>`, the image's file stem (`ref-key-left`,
    /// `orbit-02-camera+env`).
    pub fn name(&self) -> String {
        format!("{}-{}", self.view.name, self.lighting)
    }
}

/// Where the object is and where the reference camera looks from.
#[derive(Debug, Clone, PartialEq)]
pub struct Framing {
    /// Centre of the object's bounding box.
    pub centre: DVec3,
    /// Half the box's diagonal (at least a tiny positive length).
    pub radius: f64,
    /// The reference camera's pose.
    pub reference: DMat4,
}

impl Framing {
    pub fn new(mesh: &Mesh, reference: DMat4) -> Result<Self, RerenderError> {
        let (lo, hi) = mesh.bounds().ok_or(RerenderError::EmptyMesh)?;
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(RerenderError::EmptyMesh);
        }
        let centre = (lo + hi) * 0.5;
        let eye = reference.w_axis.truncate();
        if !(eye - centre).length().is_normal() {
            return Err(RerenderError::CameraAtCentre);
        }
        Ok(Framing {
            centre,
            radius: ((hi - lo).length() * 0.5).max(1e-6),
            reference,
        })
    }

    /// The reference camera's (right, up, back) axes.
    fn axes(&self) -> (DVec3, DVec3, DVec3) {
        let m = DMat3::from_mat4(self.reference);
        (
            m.x_axis.normalize_or_zero(),
            -m.y_axis.normalize_or_zero(),
            -m.z_axis.normalize_or_zero(),
        )
    }

    /// The reference camera as a view.
    pub fn reference_view(&self) -> CameraPose {
        CameraPose {
            name: "ref".into(),
            camera_to_world: self.reference,
        }
    }

    /// `n` cameras on the circle about the axis through the centre along
    /// the reference camera's up, the first where the reference camera is,
    /// each looking at the centre.
    pub fn orbit(&self, n: usize) -> Vec<CameraPose> {
        let (_, up, _) = self.axes();
        let eye = self.reference.w_axis.truncate();
        let offset = eye - self.centre;
        (0..n)
            .map(|k| {
                let angle = std::f64::consts::TAU * k as f64 / n as f64;
                let e = self.centre + DQuat::from_axis_angle(up, angle) * offset;
                CameraPose {
                    name: format!("orbit-{k:02}"),
                    camera_to_world: look_at_safe(e, self.centre, up),
                }
            })
            .collect()
    }

    /// Where `light` is for a camera at `view` (`None`: no point light).
    pub fn light_position(&self, light: LightName, view: &CameraPose) -> Option<DVec3> {
        if light == LightName::Camera {
            let eye = view.camera_to_world.w_axis.truncate();
            let up = -DMat3::from_mat4(view.camera_to_world)
                .y_axis
                .normalize_or_zero();
            return Some(eye + up * 0.1 * (eye - self.centre).length());
        }
        let d = light.direction()?.normalize();
        let (right, up, back) = self.axes();
        let dir = (right * d.x + up * d.y + back * d.z).normalize_or_zero();
        Some(self.centre + dir * LIGHT_DISTANCE * self.radius)
    }
}

/// `look_at`, with another up vector when the view direction is (nearly)
/// parallel to `up`.
fn look_at_safe(eye: DVec3, target: DVec3, up: DVec3) -> DMat4 {
    let forward = (target - eye).normalize_or_zero();
    let up = if forward.cross(up).length() > 1e-6 {
        up
    } else {
        forward.any_orthonormal_vector()
    };
    look_at(eye, target, up)
}

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderSettings {
    /// Image width; the height follows the reference camera's aspect.
    pub width: u32,
    pub samples: u32,
    /// Seed of the path tracer's random numbers: keep it when comparing
    /// materials (see the module's note on noise); change it to measure the
    /// noise itself.
    pub seed: u64,
}

impl RenderSettings {
    /// `width` px, `samples` per pixel, [`RENDER_SEED`].
    pub fn new(width: u32, samples: u32) -> Self {
        RenderSettings {
            width,
            samples,
            seed: RENDER_SEED,
        }
    }
}

/// A rendered shot: linear radiance (exposure 1) and the pixels whose
/// centre sees the object.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub image: RgbRaster,
    pub mask: MaskRaster,
}

/// The reference camera's intrinsics scaled to `width` (same field of
/// view; distortion dropped, since the images are synthetic).
pub fn scaled_intrinsics(k: &Intrinsics, width: u32) -> Intrinsics {
    let s = f64::from(width) / f64::from(k.width.max(1));
    let height = ((f64::from(k.height) * s).round() as u32).max(1);
    Intrinsics {
        distortion: [0.0; 5],
        ..k.scaled(s, s, width, height)
    }
}

/// Renders every shot of the object `mesh` with `material`, seen through
/// `intrinsics` (scaled to `settings.width`).
pub fn render_shots(
    mesh: &Mesh,
    material: &MaterialField,
    intrinsics: &Intrinsics,
    framing: &Framing,
    shots: &[Shot],
    settings: RenderSettings,
) -> Result<Vec<Rendered>, RerenderError> {
    if !(8..=4096).contains(&settings.width) {
        return Err(RerenderError::BadSize(settings.width));
    }
    if settings.samples == 0 {
        return Err(RerenderError::NoSamples);
    }
    if mesh.uvs.is_none() {
        return Err(RerenderError::NoUvs);
    }
    let intrinsics = scaled_intrinsics(intrinsics, settings.width);
    let positions = shots
        .iter()
        .enumerate()
        .map(|(i, shot)| rig_position(i, shot, framing, &intrinsics))
        .collect();
    let scene = Scene {
        name: "rerender".into(),
        kind: "rerender".into(),
        geometry: "mesh".into(),
        mesh: mesh.clone(),
        material: material.clone(),
        environment: EnvSpec {
            source: EnvSource::None,
            strength: 0.0,
            rotation: 0.0,
        },
        rig: Rig {
            intrinsics,
            positions,
        },
    };
    let dark = Renderer::with_environment(&scene, Environment::off());
    let lit = shots
        .iter()
        .any(|s| s.lighting.environment)
        .then(|| Renderer::with_environment(&scene, sky()));
    let opts = RenderOptions {
        samples: settings.samples,
        seed: settings.seed,
        ..RenderOptions::default()
    };
    shots
        .iter()
        .enumerate()
        .map(|(i, shot)| {
            let renderer = match (&lit, shot.lighting.environment) {
                (Some(r), true) => r,
                _ => &dark,
            };
            let lights: &[&str] = if shot.lighting.light == LightName::None {
                &[]
            } else {
                &[LIGHT]
            };
            let capture = CaptureSpec::new(&shot.name(), lights, None);
            let mut images = renderer.render_position(i, &[capture], &opts)?;
            let mask = renderer.render_truth(i)?.mask;
            Ok(Rendered {
                image: images.photos.remove(0),
                mask,
            })
        })
        .collect()
}

/// A scan's object as re-rendering needs it: mesh, camera model and
/// framing about the reference position's camera.
#[derive(Debug, Clone)]
pub struct ScanObject {
    pub mesh: Mesh,
    pub intrinsics: Intrinsics,
    pub framing: Framing,
}

impl ScanObject {
    /// The object of `bundle`, framed by the camera of `reference_position`.
    pub fn new(bundle: &Bundle, reference_position: &str) -> Result<Self, RerenderError> {
        let mesh = bundle.read_mesh()?;
        let reference = bundle.position(reference_position)?.camera_to_world;
        let framing = Framing::new(&mesh, reference)?;
        Ok(ScanObject {
            mesh,
            intrinsics: bundle.manifest.camera,
            framing,
        })
    }

    /// The shots of `views` (the reference view when `orbit` is `None`,
    /// else that many orbit views) under each of `lightings`.
    pub fn shots(&self, lightings: &[Lighting], orbit: Option<usize>) -> Vec<Shot> {
        let views = match orbit {
            Some(n) => self.framing.orbit(n),
            None => vec![self.framing.reference_view()],
        };
        views
            .iter()
            .flat_map(|view| {
                lightings.iter().map(|&lighting| Shot {
                    view: view.clone(),
                    lighting,
                })
            })
            .collect()
    }

    /// [`render_shots`] of this object.
    pub fn render(
        &self,
        material: &MaterialField,
        shots: &[Shot],
        settings: RenderSettings,
    ) -> Result<Vec<Rendered>, RerenderError> {
        render_shots(
            &self.mesh,
            material,
            &self.intrinsics,
            &self.framing,
            shots,
            settings,
        )
    }
}

fn sky() -> Environment {
    Environment::procedural(ENV_SEED, ENV_STRENGTH, 0.0)
}

/// The rig of one shot: its camera and its one point light; the projector
/// is dark and the backlight panel absent (zero size).
fn rig_position(index: usize, shot: &Shot, framing: &Framing, k: &Intrinsics) -> RigPosition {
    let flashes = framing
        .light_position(shot.lighting.light, &shot.view)
        .map(|p| {
            let d2 = (p - framing.centre).length_squared();
            PointLight {
                name: LIGHT.into(),
                position: p.as_vec3(),
                color: Vec3::ONE,
                intensity: (std::f64::consts::PI * d2) as f32,
            }
        })
        .into_iter()
        .collect();
    RigPosition {
        name: format!("s{index}"),
        camera_to_world: shot.view.camera_to_world,
        flashes,
        projector: Projector {
            name: "projector".into(),
            projector_to_world: shot.view.camera_to_world,
            intrinsics: *k,
            color: Vec3::ZERO,
            intensity: 0.0,
        },
        backlight: Backlight {
            name: "backlight".into(),
            center: Vec3::ZERO,
            half_u: Vec3::ZERO,
            half_v: Vec3::ZERO,
            radiance: Vec3::ZERO,
            albedo: 0.0,
        },
        exposure_s: 1.0,
    }
}

/// The material of a baked texture set (see the module doc for the
/// effective-to-authored conversion and the defaults).
pub fn material_from_textures(textures: &BakedTextures) -> MaterialField {
    let (w, h) = (textures.width(), textures.height());
    let scalar = |p: Param, default: f32| -> Vec<f32> {
        textures
            .scalar(p)
            .map(|r| r.data.iter().map(|v| clean(*v)).collect())
            .unwrap_or_else(|| vec![default; w as usize * h as usize])
    };
    let metallic = scalar(Param::Metallic, Param::Metallic.default_value());
    let eff_t = scalar(Param::Transmission, Param::Transmission.default_value());
    let eff_s = scalar(Param::Subsurface, Param::Subsurface.default_value());
    let transmission: Vec<f32> = eff_t
        .iter()
        .zip(&metallic)
        .map(|(t, m)| authored(*t, 1.0 - m))
        .collect();
    let subsurface: Vec<f32> = eff_s
        .iter()
        .zip(metallic.iter().zip(&transmission))
        .map(|(s, (m, t))| authored(*s, (1.0 - m) * (1.0 - t)))
        .collect();
    let map = |data: Vec<f32>| {
        Texture::Map(matscan_scan::Raster {
            width: w,
            height: h,
            data,
        })
    };
    MaterialField {
        basecolor: match textures.basecolor() {
            Some(r) => Texture::Map(r.map(|p| p.map(clean))),
            None => Texture::Constant([Param::Basecolor.default_value(); 3]),
        },
        roughness: map(scalar(Param::Roughness, Param::Roughness.default_value())),
        metallic: map(metallic),
        transmission: map(transmission),
        subsurface: map(subsurface),
        subsurface_radius: matscan_bsdf::material::DEFAULT_SUBSURFACE_RADIUS,
    }
}

fn clean(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The authored value whose effective value is `effective` after a factor
/// `keep` (what the higher-precedence parameters leave); 0 where nothing is
/// left to show it.
fn authored(effective: f32, keep: f32) -> f32 {
    if keep > 1e-4 {
        (effective / keep).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_metrics::compare;
    use matscan_estimate::pipeline::metrics::PSNR_CAP;
    use matscan_scan::raster::ScalarRaster;
    use matscan_scan::PinholeCamera;
    use matscan_sim::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};

    fn tiny_scene() -> Scene {
        generate(&SceneOptions {
            seed: 3,
            kind: SceneKind::Multimat,
            geometry: GeometrySource::Kind(GeometryKind::Sphere),
            width: 32,
            height: 32,
            positions: 1,
            map_size: 64,
        })
    }

    fn shots(framing: &Framing) -> Vec<Shot> {
        let key = Lighting {
            light: LightName::KeyLeft,
            environment: false,
        };
        let mut out = vec![Shot {
            view: framing.reference_view(),
            lighting: key,
        }];
        for view in framing.orbit(3).into_iter().skip(1).take(1) {
            out.push(Shot {
                view,
                lighting: "camera+env".parse().unwrap(),
            });
        }
        out
    }

    fn render(scene: &Scene, material: &MaterialField) -> Vec<Rendered> {
        let framing = Framing::new(&scene.mesh, scene.rig.positions[0].camera_to_world).unwrap();
        render_shots(
            &scene.mesh,
            material,
            &scene.rig.intrinsics,
            &framing,
            &shots(&framing),
            RenderSettings::new(32, 8),
        )
        .unwrap()
    }

    #[test]
    fn the_true_material_against_itself_is_identical() {
        let scene = tiny_scene();
        let a = render(&scene, &scene.material);
        let b = render(&scene, &scene.material);
        assert_eq!(a.len(), 2);
        for (a, b) in a.iter().zip(&b) {
            assert!(a.mask.data.iter().filter(|m| **m).count() > 50);
            let s = compare(&a.image, &b.image, &a.mask).unwrap();
            assert_eq!(s.psnr, PSNR_CAP, "{s:?}");
            assert_eq!(s.ssim, 1.0, "{s:?}");
            assert!(a.image.data.iter().flatten().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn a_halved_basecolor_scores_measurably_lower() {
        let scene = tiny_scene();
        let truth = render(&scene, &scene.material);
        let mut wrong = scene.material.clone();
        wrong.basecolor = match &scene.material.basecolor {
            Texture::Map(r) => Texture::Map(r.map(|p| p.map(|v| v * 0.5))),
            Texture::Constant(c) => Texture::Constant(c.map(|v| v * 0.5)),
        };
        let est = render(&scene, &wrong);
        for (t, e) in truth.iter().zip(&est) {
            let s = compare(&e.image, &t.image, &t.mask).unwrap();
            assert!(s.psnr < 30.0, "{s:?}");
            assert!(s.ssim < 0.97, "{s:?}");
            assert!(s.mad > 0.02, "{s:?}");
        }
    }

    #[test]
    fn lightings_parse_and_print_alike() {
        for light in LightName::ALL {
            for environment in [false, true] {
                if light == LightName::None && !environment {
                    assert!("none".parse::<Lighting>().is_err());
                    continue;
                }
                let l = Lighting { light, environment };
                assert_eq!(l.to_string().parse::<Lighting>().unwrap(), l);
            }
        }
        let err = "key-up".parse::<Lighting>().unwrap_err().to_string();
        assert!(err.contains("key-up") && err.contains("key-left"), "{err}");
    }

    #[test]
    fn orbit_cameras_circle_the_centre_and_look_at_it() {
        let scene = tiny_scene();
        let reference = scene.rig.positions[0].camera_to_world;
        let framing = Framing::new(&scene.mesh, reference).unwrap();
        let views = framing.orbit(4);
        let eye = |m: &DMat4| m.w_axis.truncate();
        let d0 = (eye(&reference) - framing.centre).length();
        assert!((eye(&views[0].camera_to_world) - eye(&reference)).length() < 1e-9);
        let k = scaled_intrinsics(&scene.rig.intrinsics, 32);
        for (i, v) in views.iter().enumerate() {
            assert_eq!(v.name, format!("orbit-{i:02}"));
            let d = (eye(&v.camera_to_world) - framing.centre).length();
            assert!((d - d0).abs() < 1e-9, "{d} vs {d0}");
            let px = PinholeCamera::new(k, v.camera_to_world)
                .project(framing.centre)
                .unwrap();
            assert!(
                (px.x - 16.0).abs() < 1e-6 && (px.y - 16.0).abs() < 1e-6,
                "{px}"
            );
        }
        // Opposite views are mirrored through the axis.
        let e2 = eye(&views[2].camera_to_world) - framing.centre;
        let e0 = eye(&views[0].camera_to_world) - framing.centre;
        let (_, up, _) = framing.axes();
        assert!((e2.dot(up) - e0.dot(up)).abs() < 1e-9);
        assert!(((e2 + e0) - 2.0 * up * e0.dot(up)).length() < 1e-9);
    }

    #[test]
    fn key_left_lights_the_left_of_the_image() {
        let scene = tiny_scene();
        let white = MaterialField::uniform(&matscan_bsdf::material::Material::WHITE_DIFFUSE);
        let framing = Framing::new(&scene.mesh, scene.rig.positions[0].camera_to_world).unwrap();
        let side_means = |light| {
            let shot = Shot {
                view: framing.reference_view(),
                lighting: Lighting {
                    light,
                    environment: false,
                },
            };
            let r = render_shots(
                &scene.mesh,
                &white,
                &scene.rig.intrinsics,
                &framing,
                &[shot],
                RenderSettings::new(32, 4),
            )
            .unwrap()
            .remove(0);
            let mean = |left: bool| {
                let (mut s, mut n) = (0.0, 0);
                for y in 0..32 {
                    for x in 0..32 {
                        if *r.mask.get(x, y) && (x < 16) == left {
                            s += r.image.get(x, y)[1];
                            n += 1;
                        }
                    }
                }
                s / n as f32
            };
            (mean(true), mean(false))
        };
        let (l, r) = side_means(LightName::KeyLeft);
        assert!(l > 1.5 * r, "left {l} right {r}");
        let (l, r) = side_means(LightName::KeyRight);
        assert!(r > 1.5 * l, "left {l} right {r}");
    }

    #[test]
    fn effective_maps_turn_back_into_authored_values() {
        let cov = MaskRaster::filled(2, 1, true);
        let mut t = BakedTextures::new(cov);
        let s = |a: f32, b: f32| ScalarRaster::from_vec(2, 1, vec![a, b]).unwrap();
        t.set_scalar(Param::Metallic, s(0.5, 1.0)).unwrap();
        t.set_scalar(Param::Transmission, s(0.25, 0.3)).unwrap();
        t.set_scalar(Param::Subsurface, s(0.125, f32::NAN)).unwrap();
        let field = material_from_textures(&t);
        let at = |x: u32| {
            let Texture::Map(r) = &field.transmission else {
                panic!("transmission is a map")
            };
            let Texture::Map(ss) = &field.subsurface else {
                panic!("subsurface is a map")
            };
            (*r.get(x, 0), *ss.get(x, 0))
        };
        // 0.25 / (1 - 0.5) = 0.5; 0.125 / ((1 - 0.5)(1 - 0.5)) = 0.5.
        assert_eq!(at(0), (0.5, 0.5));
        // Fully metallic: nothing left to transmit; NaN becomes 0.
        assert_eq!(at(1), (0.0, 0.0));
        let Texture::Map(rough) = &field.roughness else {
            panic!("roughness is a map")
        };
        assert_eq!(rough.data, vec![Param::Roughness.default_value(); 2]);
        assert_eq!(
            field.basecolor,
            Texture::Constant([Param::Basecolor.default_value(); 3])
        );
        let m = matscan_bsdf::material::Material {
            basecolor: Vec3::ONE,
            roughness: 0.5,
            metallic: 0.5,
            transmission: 0.5,
            subsurface: 0.5,
            subsurface_radius: Vec3::ONE,
        };
        assert!((m.effective_transmission() - 0.25).abs() < 1e-6);
        assert!((m.effective_subsurface() - 0.125).abs() < 1e-6);
    }
}
