//! Captures of a rig position: which passes to trace and how their slots
//! add up to photos.
//!
//! Every capture is the ambient scene plus its rig lights (the contract's
//! definition), and light transport is linear, so one pass per position
//! renders the environment and every distinct rig-light term (each flash,
//! the projector under each pattern, the backlight) as separate slots, and
//! each photo is `exposure_s * (environment + its lights)`. Exact in
//! expectation, and the ambient work (long environment paths) is shared by
//! all captures. The `illum_` truth images are a second pass with the object
//! white Lambertian and the environment off.
//!
//! Boundaries: rendering to rasters; files are `super::bundle_writer`'s.

use super::environment::Environment;
use super::error::SimError;
use super::integrator::{MaterialMode, Pass, PassKey, ProjectorTerm, DEFAULT_CLAMP_INDIRECT};
use super::lights::{Flash, Panel, ProjectorLight};
use super::truth::{render_panel_mask, render_truth, TruthMaps};
use super::world::{ObjectGeometry, World};
use crate::scene::{RigPosition, Scene};
use matscan_scan::raster::{MaskRaster, RgbRaster};
use matscan_scan::{Pattern, PinholeCamera};

/// Samples per pixel when nothing else is asked for: the figure that keeps a
/// 3-position 256 x 256 scan within 60 s on two cores (see `super`).
pub const DEFAULT_SAMPLES: u32 = 32;
/// Scattering vertices per path at most.
pub const DEFAULT_MAX_DEPTH: u32 = 8;

/// How to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Paths per pixel (at least 1).
    pub samples: u32,
    /// Renders are a deterministic function of the scene and this seed.
    pub seed: u64,
    /// Scattering vertices per path at most.
    pub max_depth: u32,
    /// Largest radiance of one indirect light event per sample (Cycles'
    /// "clamp indirect"); infinity or 0 for none.
    pub clamp_indirect: f32,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            samples: DEFAULT_SAMPLES,
            seed: 0,
            max_depth: DEFAULT_MAX_DEPTH,
            clamp_indirect: DEFAULT_CLAMP_INDIRECT,
        }
    }
}

/// One photo to take: the rig lights switched on (by their names at the
/// position) and the projector's pattern. With the projector on and no
/// pattern, the projector shows full white.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureSpec {
    pub name: String,
    pub lights: Vec<String>,
    pub pattern: Option<Pattern>,
}

impl CaptureSpec {
    pub fn new(name: &str, lights: &[&str], pattern: Option<Pattern>) -> Self {
        CaptureSpec {
            name: name.to_string(),
            lights: lights.iter().map(|s| s.to_string()).collect(),
            pattern,
        }
    }
}

/// The rendered photos of one position.
#[derive(Debug, Clone)]
pub struct PositionImages {
    /// One photo per requested capture, in order: `exposure_s` times
    /// radiance.
    pub photos: Vec<RgbRaster>,
    /// The environment alone (the ambient photo), times `exposure_s`.
    pub ambient: RgbRaster,
    /// Per capture, its rig lights alone (`photo - ambient`), times
    /// `exposure_s`.
    pub light_only: Vec<RgbRaster>,
    /// Samples dropped for a non-finite value (0 in a healthy render).
    pub dropped_samples: u64,
}

/// The object's material in a photo pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectMaterial {
    /// The scene's authored material (the photos).
    Authored,
    /// Ideal white Lambertian everywhere (white references, furnace tests).
    WhiteDiffuse,
}

/// The emitter slots of a pass and, per capture, which slots it sums.
struct SlotPlan {
    env_slot: Option<usize>,
    flashes: Vec<(Flash, usize, String)>,
    patterns: Vec<(Pattern, usize)>,
    backlight_slot: Option<usize>,
    per_capture: Vec<Vec<usize>>,
    slots: usize,
}

/// What rays hit and what lights shine, per scene; reused for every
/// position and pass.
pub struct Renderer<'a> {
    scene: &'a Scene,
    object: ObjectGeometry<'a>,
    env: Environment,
}

/// Pass numbers inside one position's random streams.
const PASS_PHOTOS: u64 = 0;
const PASS_ILLUM: u64 = 1;

impl<'a> Renderer<'a> {
    /// Builds the BVH and the environment (reading its map, if any).
    pub fn new(scene: &'a Scene) -> Result<Self, SimError> {
        Ok(Renderer {
            scene,
            object: ObjectGeometry::new(&scene.mesh),
            env: Environment::from_spec(&scene.environment)?,
        })
    }

    /// With an environment built elsewhere (tests, custom skies).
    pub fn with_environment(scene: &'a Scene, env: Environment) -> Self {
        Renderer {
            scene,
            object: ObjectGeometry::new(&scene.mesh),
            env,
        }
    }

    pub fn environment(&self) -> &Environment {
        &self.env
    }

    fn rig(&self, position: usize) -> Result<&'a RigPosition, SimError> {
        self.scene
            .rig
            .positions
            .get(position)
            .ok_or(SimError::NoSuchPosition {
                index: position,
                count: self.scene.rig.positions.len(),
            })
    }

    /// The contract's camera at a position.
    pub fn camera(&self, position: usize) -> Result<PinholeCamera, SimError> {
        let rig = self.rig(position)?;
        Ok(PinholeCamera::new(
            self.scene.rig.intrinsics,
            rig.camera_to_world,
        ))
    }

    fn panel(&self, position: usize) -> Result<Option<Panel>, SimError> {
        let camera = self.camera(position)?;
        Ok(Panel::new(
            &self.rig(position)?.backlight,
            camera.center().as_vec3(),
        ))
    }

    /// Every requested capture of a position, from one pass.
    pub fn render_position(
        &self,
        position: usize,
        captures: &[CaptureSpec],
        opts: &RenderOptions,
    ) -> Result<PositionImages, SimError> {
        self.render_position_with(position, captures, opts, ObjectMaterial::Authored)
    }

    /// [`Renderer::render_position`] with a choice of object material.
    pub fn render_position_with(
        &self,
        position: usize,
        captures: &[CaptureSpec],
        opts: &RenderOptions,
        material: ObjectMaterial,
    ) -> Result<PositionImages, SimError> {
        let rig = self.rig(position)?;
        let plan = plan_slots(rig, captures, !self.env.is_off())?;
        let panel = self.panel(position)?;
        let authored = material == ObjectMaterial::Authored;
        let pass = self.pass(position, &plan, panel.as_ref(), authored, opts)?;
        let images = pass.render(
            opts.samples,
            PassKey {
                seed: opts.seed,
                position: position as u64,
                pass: PASS_PHOTOS,
            },
        );
        let exposure = exposure_of(rig);
        let (w, h) = (pass.camera.intrinsics.width, pass.camera.intrinsics.height);
        let sum = |slots: &[usize]| {
            let mut out = RgbRaster::filled(w, h, [0.0f32; 3]);
            for &s in slots {
                for (o, v) in out.data.iter_mut().zip(&images.slots[s].data) {
                    for c in 0..3 {
                        o[c] += v[c] * exposure;
                    }
                }
            }
            out
        };
        let ambient = sum(&plan.env_slot.into_iter().collect::<Vec<_>>());
        let light_only: Vec<RgbRaster> = plan.per_capture.iter().map(|slots| sum(slots)).collect();
        let photos = light_only
            .iter()
            .map(|l| {
                let mut p = l.clone();
                for (o, a) in p.data.iter_mut().zip(&ambient.data) {
                    for c in 0..3 {
                        o[c] += a[c];
                    }
                }
                p
            })
            .collect();
        Ok(PositionImages {
            photos,
            ambient,
            light_only,
            dropped_samples: images.dropped_samples,
        })
    }

    /// The `illum_` truth images of `captures`: each capture's rig lights
    /// alone on an ideal white Lambertian object, environment off, times
    /// `exposure_s`.
    pub fn render_illum(
        &self,
        position: usize,
        captures: &[CaptureSpec],
        opts: &RenderOptions,
    ) -> Result<Vec<RgbRaster>, SimError> {
        let rig = self.rig(position)?;
        let plan = plan_slots(rig, captures, false)?;
        let panel = self.panel(position)?;
        let pass = self.pass(position, &plan, panel.as_ref(), false, opts)?;
        let images = pass.render(
            opts.samples,
            PassKey {
                seed: opts.seed,
                position: position as u64,
                pass: PASS_ILLUM,
            },
        );
        let exposure = exposure_of(rig);
        let (w, h) = (pass.camera.intrinsics.width, pass.camera.intrinsics.height);
        Ok(plan
            .per_capture
            .iter()
            .map(|slots| {
                let mut out = RgbRaster::filled(w, h, [0.0f32; 3]);
                for &s in slots {
                    for (o, v) in out.data.iter_mut().zip(&images.slots[s].data) {
                        for c in 0..3 {
                            o[c] += v[c] * exposure;
                        }
                    }
                }
                out
            })
            .collect())
    }

    /// Truth maps of a position (primary hits at pixel centres).
    pub fn render_truth(&self, position: usize) -> Result<TruthMaps, SimError> {
        let camera = self.camera(position)?;
        let panel = self.panel(position)?;
        let world = World::new(&self.object, panel.as_ref());
        Ok(render_truth(&world, &camera, &self.scene.material))
    }

    /// Pixels showing the front of the backlight panel (white reference).
    pub fn panel_mask(&self, position: usize) -> Result<MaskRaster, SimError> {
        let camera = self.camera(position)?;
        let panel = self.panel(position)?;
        let world = World::new(&self.object, panel.as_ref());
        Ok(render_panel_mask(&world, &camera))
    }

    fn pass<'p>(
        &'p self,
        position: usize,
        plan: &SlotPlan,
        panel: Option<&'p Panel>,
        authored: bool,
        opts: &RenderOptions,
    ) -> Result<Pass<'p>, SimError> {
        let rig = self.rig(position)?;
        let projector = (!plan.patterns.is_empty()).then(|| ProjectorTerm {
            light: ProjectorLight::new(&rig.projector),
            patterns: plan.patterns.clone(),
        });
        Ok(Pass {
            world: World::new(&self.object, panel),
            camera: self.camera(position)?,
            env: &self.env,
            env_slot: plan.env_slot,
            flashes: plan
                .flashes
                .iter()
                .map(|(f, s, _)| (f.clone(), *s))
                .collect(),
            projector,
            backlight_slot: plan.backlight_slot,
            materials: if authored {
                MaterialMode::Authored(&self.scene.material)
            } else {
                MaterialMode::WhiteDiffuse
            },
            slots: plan.slots,
            max_depth: opts.max_depth,
            clamp_indirect: if opts.clamp_indirect > 0.0 && !opts.clamp_indirect.is_nan() {
                opts.clamp_indirect
            } else {
                f32::INFINITY
            },
        })
    }
}

fn exposure_of(rig: &RigPosition) -> f32 {
    if rig.exposure_s.is_finite() && rig.exposure_s > 0.0 {
        rig.exposure_s
    } else {
        1.0
    }
}

/// Assigns one slot to the environment (when `with_env`) and one to each
/// distinct rig-light term the captures use.
fn plan_slots(
    rig: &RigPosition,
    captures: &[CaptureSpec],
    with_env: bool,
) -> Result<SlotPlan, SimError> {
    let mut plan = SlotPlan {
        env_slot: None,
        flashes: Vec::new(),
        patterns: Vec::new(),
        backlight_slot: None,
        per_capture: Vec::new(),
        slots: 0,
    };
    if with_env {
        plan.env_slot = Some(0);
        plan.slots = 1;
    }
    for spec in captures {
        let mut slots = Vec::new();
        for name in &spec.lights {
            let slot = if let Some(flash) = rig.flashes.iter().find(|f| &f.name == name) {
                match plan.flashes.iter().find(|(_, _, n)| n == name) {
                    Some((_, s, _)) => *s,
                    None => {
                        let s = plan.slots;
                        plan.slots += 1;
                        plan.flashes.push((Flash::new(flash), s, name.clone()));
                        s
                    }
                }
            } else if &rig.projector.name == name {
                let pattern = spec.pattern.unwrap_or(Pattern::Uniform { level: 1.0 });
                match plan.patterns.iter().find(|(p, _)| *p == pattern) {
                    Some((_, s)) => *s,
                    None => {
                        let s = plan.slots;
                        plan.slots += 1;
                        plan.patterns.push((pattern, s));
                        s
                    }
                }
            } else if &rig.backlight.name == name {
                match plan.backlight_slot {
                    Some(s) => s,
                    None => {
                        let s = plan.slots;
                        plan.slots += 1;
                        plan.backlight_slot = Some(s);
                        s
                    }
                }
            } else {
                return Err(SimError::NoSuchLight {
                    position: rig.name.clone(),
                    light: name.clone(),
                });
            };
            if !slots.contains(&slot) {
                slots.push(slot);
            }
        }
        plan.per_capture.push(slots);
    }
    Ok(plan)
}

/// One capture of one position (renders its own pass; to render several
/// captures of a position, [`Renderer::render_position`] shares the work).
pub fn render_capture(
    scene: &Scene,
    position: usize,
    capture: &CaptureSpec,
    opts: &RenderOptions,
) -> Result<RgbRaster, SimError> {
    let renderer = Renderer::new(scene)?;
    let mut images = renderer.render_position(position, std::slice::from_ref(capture), opts)?;
    Ok(images.photos.remove(0))
}
