//! The unidirectional path tracer.
//!
//! One pass traces `samples` paths per pixel and accumulates light into
//! several *slots* at once, one per emitter term: the environment, each
//! flash, the projector under each pattern, the backlight panel. Light
//! transport is linear in the emitters and every emitter is handled by its
//! own estimator on the shared path (next-event estimation to each active
//! light at every vertex; for the environment and the panel also emission
//! found by BSDF sampling, combined with the power heuristic), so each slot
//! is an image of that emitter alone (unbiased up to the indirect clamp)
//! and any capture is a sum of slots. One pass per position therefore yields every capture.
//!
//! Path construction: box-filter jitter inside the pixel through the
//! contract's camera model; at each vertex next-event estimation, then BSDF
//! sampling for the continuation; Russian roulette from the fourth vertex
//! on; at most `max_depth` scattering vertices. Transmission continues the
//! path on the other side of the surface; the object is two-sided and
//! inside/outside follows from the geometric normal. Subsurface entry hands
//! over to a random walk (`super::subsurface`) whose exit is a vertex like
//! any other. A sample with any non-finite value is dropped whole and
//! counted, so no NaN or Inf can reach an image. Indirect light is clamped
//! per event as Cycles' default does ([`DEFAULT_CLAMP_INDIRECT`]).
//!
//! Boundaries: light transport for one pass; which passes to run and how
//! slots become captures is `super::capture`'s.

use super::environment::Environment;
use super::lights::{Flash, ProjectorLight};
use super::sampling::{power_heuristic, PixelRng};
use super::shading::{Lambert, Sampled, Shader};
use super::world::{Surface, World};
use crate::scene::MaterialField;
use glam::{DVec2, Vec3};
use matscan_scan::raster::RgbRaster;
use matscan_scan::{Pattern, PinholeCamera, Ray};
use rayon::prelude::*;

/// Which material the object has in a pass.
#[derive(Debug, Clone, Copy)]
pub enum MaterialMode<'a> {
    /// The scene's authored material.
    Authored(&'a MaterialField),
    /// Ideal white Lambertian everywhere (the `illum_` truth renders).
    WhiteDiffuse,
}

/// The projector with the patterns a pass renders it under.
#[derive(Debug, Clone)]
pub struct ProjectorTerm {
    pub light: ProjectorLight,
    /// Each pattern and its slot.
    pub patterns: Vec<(Pattern, usize)>,
}

/// Everything one pass needs.
pub struct Pass<'a> {
    pub world: World<'a>,
    pub camera: PinholeCamera,
    pub env: &'a Environment,
    pub env_slot: Option<usize>,
    pub flashes: Vec<(Flash, usize)>,
    pub projector: Option<ProjectorTerm>,
    /// Slot of the panel's emission; `None` while it is switched off.
    pub backlight_slot: Option<usize>,
    pub materials: MaterialMode<'a>,
    pub slots: usize,
    pub max_depth: u32,
    /// Largest contribution (max channel, radiance) of one indirect light
    /// event; infinity for none. See [`DEFAULT_CLAMP_INDIRECT`].
    pub clamp_indirect: f32,
}

/// Cycles' default "clamp indirect" (10), which the thesis's renders had:
/// light arriving after two or more scattering vertices is limited to this
/// radiance per sample. It removes the fireflies of caustics (a flash or
/// the sun seen through a near-mirror from a diffuse surface) at the cost
/// of dimming the brightest caustics; direct light is never clamped.
pub const DEFAULT_CLAMP_INDIRECT: f32 = 10.0;

/// `c` scaled down (hue kept) so its largest channel is at most `limit`.
#[inline]
fn clamped(c: Vec3, limit: f32) -> Vec3 {
    let m = c.max_element();
    if m > limit {
        c * (limit / m)
    } else {
        c
    }
}

/// Key of a pass's random numbers (together with the pixel).
#[derive(Debug, Clone, Copy)]
pub struct PassKey {
    pub seed: u64,
    pub position: u64,
    pub pass: u64,
}

/// The images of one pass: the mean radiance of each slot.
#[derive(Debug, Clone)]
pub struct PassImages {
    pub slots: Vec<RgbRaster>,
    /// Samples dropped for a non-finite value.
    pub dropped_samples: u64,
}

/// Throughput and length of the path being traced.
#[derive(Debug, Clone, Copy)]
struct PathState {
    beta: Vec3,
    /// Scattering vertices so far (subsurface exits included).
    vertices: u32,
}

/// Where a path scatters, and the clamp its light events get.
#[derive(Debug, Clone, Copy)]
struct Vertex {
    p: Vec3,
    ng: Vec3,
    limit: f32,
}

/// The previous vertex, for MIS weights of emitters hit by BSDF sampling.
#[derive(Debug, Clone, Copy)]
struct Prev {
    position: Vec3,
    pdf: f32,
    delta: bool,
}

const ROULETTE_FROM: u32 = 3;

impl Pass<'_> {
    /// Renders every slot; rows run in parallel on the current rayon pool.
    pub fn render(&self, samples: u32, key: PassKey) -> PassImages {
        self.render_where(samples, key, |_| true)
    }

    /// Renders every slot at the pixels (row-major index) `wanted` keeps,
    /// leaving the others black. Each pixel's random numbers depend on the
    /// pixel alone, so a kept pixel reads as in [`Self::render`].
    pub fn render_where(
        &self,
        samples: u32,
        key: PassKey,
        wanted: impl Fn(usize) -> bool + Sync,
    ) -> PassImages {
        let (w, h) = (self.camera.intrinsics.width, self.camera.intrinsics.height);
        let samples = samples.max(1);
        let rows: Vec<(Vec<Vec3>, u64)> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut row = vec![Vec3::ZERO; w as usize * self.slots];
                let mut dropped = 0u64;
                let mut sample = vec![Vec3::ZERO; self.slots];
                for x in 0..w {
                    let pixel = y as u64 * w as u64 + x as u64;
                    if !wanted(pixel as usize) {
                        continue;
                    }
                    let mut rng = PixelRng::new(key.seed, key.position, key.pass, pixel);
                    let acc = &mut row[x as usize * self.slots..(x as usize + 1) * self.slots];
                    for _ in 0..samples {
                        sample.iter_mut().for_each(|s| *s = Vec3::ZERO);
                        let j = rng.next2();
                        let ray = self
                            .camera
                            .ray(DVec2::new(x as f64 + j[0] as f64, y as f64 + j[1] as f64));
                        self.trace(ray, &mut rng, &mut sample);
                        if sample.iter().all(|s| s.is_finite()) {
                            acc.iter_mut().zip(&sample).for_each(|(a, s)| *a += *s);
                        } else {
                            dropped += 1;
                        }
                    }
                    acc.iter_mut().for_each(|a| *a /= samples as f32);
                }
                (row, dropped)
            })
            .collect();
        let mut slots: Vec<RgbRaster> = (0..self.slots)
            .map(|_| RgbRaster::filled(w, h, [0.0; 3]))
            .collect();
        let mut dropped_samples = 0;
        for (y, (row, dropped)) in rows.into_iter().enumerate() {
            dropped_samples += dropped;
            for x in 0..w as usize {
                for (s, slot) in slots.iter_mut().enumerate() {
                    *slot.get_mut(x as u32, y as u32) = row[x * self.slots + s].to_array();
                }
            }
        }
        PassImages {
            slots,
            dropped_samples,
        }
    }

    /// Adds one path's contributions to `out` (one entry per slot).
    pub fn trace(&self, mut ray: Ray, rng: &mut PixelRng, out: &mut [Vec3]) {
        let mut path = PathState {
            beta: Vec3::ONE,
            vertices: 0,
        };
        let mut prev: Option<Prev> = None;
        // Scattering vertices without subsurface exits (an exit belongs to
        // its entry), for what counts as direct light.
        let mut bounces = 0u32;
        loop {
            let limit = self.limit(bounces);
            let Some(hit) = self.world.intersect(&ray) else {
                self.add_environment(&ray, prev, path.beta, limit, out);
                break;
            };
            if let Surface::Panel { position } = hit.surface {
                self.add_panel_emission(&ray, position, prev, path.beta, limit, out);
            }
            if path.vertices >= self.max_depth {
                break;
            }
            path.vertices += 1;
            bounces += 1;
            let limit = self.limit(bounces);
            let wo = -ray.dir;
            let (p, ng, shader, on_panel) = match hit.surface {
                Surface::Panel { position } => {
                    let Some(panel) = self.world.panel else { break };
                    let l = Lambert::new(Vec3::splat(panel.albedo), panel.front, panel.front);
                    (position, panel.front, Shader::Lambert(l), true)
                }
                Surface::Object(sp) => {
                    let shader = match self.materials {
                        MaterialMode::WhiteDiffuse => Shader::Lambert(Lambert::new(
                            Vec3::ONE,
                            sp.shading_normal,
                            sp.geometric_normal,
                        )),
                        MaterialMode::Authored(field) => Shader::principled(&field.at(&sp), &sp),
                    };
                    (sp.position, sp.geometric_normal, shader, false)
                }
            };
            self.direct(p, ng, wo, &shader, on_panel, path.beta, limit, rng, out);
            let Some(s) = shader.sample(wo, rng.next3()) else {
                break;
            };
            let at = Vertex { p, ng, limit };
            let Some(next) = self.continue_path(at, &shader, s, &mut path, rng, out) else {
                break;
            };
            prev = Some(next.0);
            ray = next.1;
            if path.vertices > ROULETTE_FROM {
                let q = path.beta.max_element().min(0.95);
                if q.is_nan() || q <= 0.0 || rng.next_f32() >= q {
                    break;
                }
                path.beta /= q;
            }
        }
    }

    /// Applies a sampled scattering event: updates `beta`, runs the
    /// subsurface walk (and its exit vertex) when the sample enters the
    /// medium, and returns the next ray with its MIS record.
    fn continue_path(
        &self,
        Vertex { p, ng, limit }: Vertex,
        shader: &Shader,
        s: Sampled,
        path: &mut PathState,
        rng: &mut PixelRng,
        out: &mut [Vec3],
    ) -> Option<(Prev, Ray)> {
        let PathState { beta, vertices } = path;
        *beta *= s.weight;
        if !(beta.is_finite() && beta.max_element() > 0.0) {
            return None;
        }
        if s.lobe == super::shading::Lobe::SubsurfaceEntry {
            let medium = shader.subsurface_medium()?;
            let start = self.world.offset(p, ng, s.wi);
            let exit = super::subsurface::walk(&self.world, &medium, start, s.wi, rng)?;
            *beta *= exit.weight;
            if !(beta.is_finite() && beta.max_element() > 0.0) || *vertices >= self.max_depth {
                return None;
            }
            *vertices += 1;
            // The exit is a vertex: light reaches it from outside through
            // the exit lobe, and the path leaves through it.
            let xp = exit.surface.position;
            // Normals facing out of the object, whatever the mesh winding.
            let out_side = if exit.dir.dot(exit.surface.geometric_normal) >= 0.0 {
                1.0
            } else {
                -1.0
            };
            let xng = exit.surface.geometric_normal * out_side;
            let xns = exit.surface.shading_normal * out_side;
            let exit_shader = Shader::SubsurfaceExit(medium.exit(xns, xng));
            let wo = xng;
            self.direct(xp, xng, wo, &exit_shader, false, *beta, limit, rng, out);
            let xs = exit_shader.sample(wo, rng.next3())?;
            *beta *= xs.weight;
            if !(beta.is_finite() && beta.max_element() > 0.0) {
                return None;
            }
            let ray = Ray::new(self.world.offset(xp, xng, xs.wi), xs.wi);
            return Some((
                Prev {
                    position: xp,
                    pdf: xs.pdf,
                    delta: xs.delta,
                },
                ray,
            ));
        }
        let ray = Ray::new(self.world.offset(p, ng, s.wi), s.wi);
        Some((
            Prev {
                position: p,
                pdf: s.pdf,
                delta: s.delta,
            },
            ray,
        ))
    }

    /// The clamp for light arriving after `bounces` scattering vertices.
    fn limit(&self, bounces: u32) -> f32 {
        if bounces <= 1 {
            f32::INFINITY
        } else {
            self.clamp_indirect
        }
    }

    fn add_environment(
        &self,
        ray: &Ray,
        prev: Option<Prev>,
        beta: Vec3,
        limit: f32,
        out: &mut [Vec3],
    ) {
        let Some(slot) = self.env_slot else { return };
        let le = self.env.radiance(ray.dir);
        if le.max_element() <= 0.0 {
            return;
        }
        let w = match prev {
            Some(pv) if !pv.delta => power_heuristic(pv.pdf, self.env.pdf(ray.dir)),
            _ => 1.0,
        };
        out[slot] += clamped(beta * le * w, limit);
    }

    fn add_panel_emission(
        &self,
        ray: &Ray,
        position: Vec3,
        prev: Option<Prev>,
        beta: Vec3,
        limit: f32,
        out: &mut [Vec3],
    ) {
        let (Some(slot), Some(panel)) = (self.backlight_slot, self.world.panel) else {
            return;
        };
        let le = panel.emitted(-ray.dir);
        if le.max_element() <= 0.0 {
            return;
        }
        let w = match prev {
            Some(pv) if !pv.delta => {
                power_heuristic(pv.pdf, panel.pdf(pv.position, position, ray.dir))
            }
            _ => 1.0,
        };
        out[slot] += clamped(beta * le * w, limit);
    }

    /// Next-event estimation to every active emitter at a vertex.
    #[allow(clippy::too_many_arguments)]
    fn direct(
        &self,
        p: Vec3,
        ng: Vec3,
        wo: Vec3,
        shader: &Shader,
        on_panel: bool,
        beta: Vec3,
        limit: f32,
        rng: &mut PixelRng,
        out: &mut [Vec3],
    ) {
        for (flash, slot) in &self.flashes {
            let Some(ill) = flash.illuminate(p) else {
                continue;
            };
            let f = shader.eval(wo, ill.wi).value;
            if f.max_element() > 0.0
                && !self
                    .world
                    .occluded_point(self.world.offset(p, ng, ill.wi), ill.light_pos)
            {
                out[*slot] += clamped(beta * f * ill.incident, limit);
            }
        }
        if let Some(term) = &self.projector {
            if let Some((ill, pixel)) = term.light.illuminate_white(p) {
                let f = shader.eval(wo, ill.wi).value;
                if f.max_element() > 0.0
                    && !self
                        .world
                        .occluded_point(self.world.offset(p, ng, ill.wi), ill.light_pos)
                {
                    let base = beta * f * ill.incident;
                    for (pattern, slot) in &term.patterns {
                        out[*slot] +=
                            clamped(base * ProjectorLight::pattern_value(pattern, pixel), limit);
                    }
                }
            }
        }
        let u_panel = rng.next2();
        if let (Some(slot), Some(panel), false) = (self.backlight_slot, self.world.panel, on_panel)
        {
            if let Some(ls) = panel.sample(p, u_panel) {
                if ls.radiance.max_element() > 0.0 {
                    let e = shader.eval(wo, ls.wi);
                    if e.value.max_element() > 0.0
                        && !self
                            .world
                            .occluded_panel_point(self.world.offset(p, ng, ls.wi), ls.point)
                    {
                        let w = power_heuristic(ls.pdf, e.pdf);
                        out[slot] += clamped(beta * e.value * ls.radiance * (w / ls.pdf), limit);
                    }
                }
            }
        }
        let u_env = rng.next2();
        if let Some(slot) = self.env_slot {
            if let Some(es) = self.env.sample(u_env) {
                if es.radiance.max_element() > 0.0 {
                    let e = shader.eval(wo, es.dir);
                    if e.value.max_element() > 0.0
                        && !self
                            .world
                            .occluded_dir(self.world.offset(p, ng, es.dir), es.dir)
                    {
                        let w = power_heuristic(es.pdf, e.pdf);
                        out[slot] += clamped(beta * e.value * es.radiance * (w / es.pdf), limit);
                    }
                }
            }
        }
    }
}
