//! Ambient light from infinitely far away: a procedural sky (no file
//! needed), an equirectangular HDR map, a uniform colour (for tests), or
//! nothing; with rotation about the world up axis, a strength factor, and
//! importance sampling for next-event estimation.
//!
//! Conventions. World up is +Y (the rig's `look_at` up, see
//! `crate::scene`). The equirectangular parametrization, in the map's own
//! (unrotated) frame: column u in [0, 1) is the azimuth
//! `phi = atan2(x, -z) = 2 pi (u - 1/2)`, so the map's centre looks toward
//! -Z and u grows toward +X; row v in [0, 1) is the polar angle
//! `theta = acos(y) = pi v`, row 0 (the top of the image) looking straight
//! up. `rotation` r turns the map about +Y by r (a feature at azimuth phi in
//! the map appears at phi + r in the world).
//!
//! Sampling: the map (or the procedural sky, evaluated on the same grid) is
//! reduced to a luminance grid of at most 256 x 128 cells, weighted by
//! sin(theta) and floored at 1 % of the mean so no direction with light has
//! density 0. Cell weights never underestimate a cell's light (a map cell
//! takes the mean over its texels plus a one-texel border, the sky's sun
//! disc counts in every cell it may touch): a bright sliver in a cell of
//! low weight is what makes fireflies; a piecewise-constant 2D distribution picks a cell and a point
//! in it. `sample` returns the true radiance in the sampled direction and
//! `pdf` is the exact density of that strategy, so MIS stays unbiased.
//!
//! Boundaries: radiance and sampling only; visibility is the integrator's.

use super::error::SimError;
use super::sampling::{uniform_sphere, Distribution2D};
use crate::scene::{EnvSource, EnvSpec};
use glam::{Vec2, Vec3};
use matscan_scan::raster::RgbRaster;
use rand::{Rng, SeedableRng};
use std::f32::consts::PI;

/// Rec. 709 luminance weights.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// A direction sampled toward the environment.
#[derive(Debug, Clone, Copy)]
pub struct EnvSample {
    pub dir: Vec3,
    pub radiance: Vec3,
    /// Solid-angle density.
    pub pdf: f32,
}

#[derive(Debug, Clone)]
enum Source {
    Off,
    Uniform(Vec3),
    Procedural(ProceduralSky),
    Map(RgbRaster),
}

/// The environment as the integrator sees it.
#[derive(Debug, Clone)]
pub struct Environment {
    source: Source,
    strength: f32,
    /// cos and sin of the rotation about +Y.
    rot: (f32, f32),
    /// Present for the procedural sky and maps.
    dist: Option<Distribution2D>,
}

const GRID_W: usize = 256;
const GRID_H: usize = 128;

impl Environment {
    /// No ambient light.
    pub fn off() -> Self {
        Environment {
            source: Source::Off,
            strength: 0.0,
            rot: (1.0, 0.0),
            dist: None,
        }
    }

    /// The same radiance from every direction (sampled uniformly over the
    /// sphere): the white furnace.
    pub fn uniform(radiance: Vec3) -> Self {
        Environment {
            source: Source::Uniform(sanitize(radiance)),
            strength: 1.0,
            rot: (1.0, 0.0),
            dist: None,
        }
    }

    /// The procedural sky of `seed`.
    pub fn procedural(seed: u64, strength: f32, rotation: f32) -> Self {
        Self::with_source(
            Source::Procedural(ProceduralSky::new(seed)),
            strength,
            rotation,
        )
    }

    /// An equirectangular map already in memory (row 0 looks up).
    pub fn from_map(map: RgbRaster, strength: f32, rotation: f32) -> Self {
        if map.width == 0 || map.height == 0 {
            return Self::off();
        }
        Self::with_source(Source::Map(map), strength, rotation)
    }

    /// The environment a scene asks for; maps are read as linear EXR.
    pub fn from_spec(spec: &EnvSpec) -> Result<Self, SimError> {
        match &spec.source {
            EnvSource::None => Ok(Self::off()),
            EnvSource::Procedural { seed } => {
                Ok(Self::procedural(*seed, spec.strength, spec.rotation))
            }
            EnvSource::Map(path) => {
                let map = matscan_scan::image_io::read_rgb_exr(path)?;
                Ok(Self::from_map(map, spec.strength, spec.rotation))
            }
        }
    }

    fn with_source(source: Source, strength: f32, rotation: f32) -> Self {
        let strength = if strength.is_finite() {
            strength.max(0.0)
        } else {
            0.0
        };
        let rotation = if rotation.is_finite() { rotation } else { 0.0 };
        let mut env = Environment {
            source,
            strength,
            rot: (rotation.cos(), rotation.sin()),
            dist: None,
        };
        if strength > 0.0 {
            env.dist = Some(env.build_distribution());
        } else {
            env.source = Source::Off;
        }
        env
    }

    pub fn is_off(&self) -> bool {
        matches!(self.source, Source::Off)
    }

    /// Radiance arriving from world direction `dir` (unit, pointing away
    /// from the scene).
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let base = match &self.source {
            Source::Off => return Vec3::ZERO,
            Source::Uniform(c) => return *c,
            Source::Procedural(sky) => sky.radiance(self.to_local(dir)),
            Source::Map(map) => map_lookup(map, dir_to_uv(self.to_local(dir))),
        };
        sanitize(base * self.strength)
    }

    /// A direction toward the environment, its radiance and solid-angle
    /// density; `None` when the environment is off or the sample degenerate.
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvSample> {
        match &self.source {
            Source::Off => None,
            Source::Uniform(c) => Some(EnvSample {
                dir: uniform_sphere(u),
                radiance: *c,
                pdf: 1.0 / (4.0 * PI),
            }),
            _ => {
                let dist = self.dist.as_ref()?;
                let (uv, pdf_uv) = dist.sample(u);
                let (local, sin_theta) = uv_to_dir(uv);
                if sin_theta < 1e-6 || pdf_uv <= 0.0 {
                    return None;
                }
                let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
                let dir = self.to_world(local);
                let radiance = self.radiance(dir);
                (pdf.is_finite() && pdf > 0.0).then_some(EnvSample { dir, radiance, pdf })
            }
        }
    }

    /// Solid-angle density of [`Environment::sample`] producing `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match &self.source {
            Source::Off => 0.0,
            Source::Uniform(_) => 1.0 / (4.0 * PI),
            _ => {
                let Some(dist) = self.dist.as_ref() else {
                    return 0.0;
                };
                let local = self.to_local(dir);
                let sin_theta = (1.0 - local.y * local.y).max(0.0).sqrt();
                if sin_theta < 1e-6 {
                    return 0.0;
                }
                let pdf = dist.pdf(dir_to_uv(local)) / (2.0 * PI * PI * sin_theta);
                if pdf.is_finite() {
                    pdf
                } else {
                    0.0
                }
            }
        }
    }

    /// World to map frame: azimuth phi becomes phi - rotation.
    fn to_local(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.rot;
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    fn to_world(&self, d: Vec3) -> Vec3 {
        let (c, s) = self.rot;
        Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
    }

    /// Luminance x sin(theta) per grid cell, in the map frame (sampling
    /// happens in the map frame and is rotated afterwards).
    fn build_distribution(&self) -> Distribution2D {
        let (gw, gh, mut lum) = match &self.source {
            Source::Map(map) => map_cell_means(map),
            Source::Procedural(sky) => {
                let mut lum = vec![0.0f32; GRID_W * GRID_H];
                for y in 0..GRID_H {
                    for x in 0..GRID_W {
                        lum[y * GRID_W + x] = sky.cell_luminance(x, y);
                    }
                }
                (GRID_W, GRID_H, lum)
            }
            Source::Off | Source::Uniform(_) => (1, 1, vec![1.0]),
        };
        let mean = lum.iter().sum::<f32>() / lum.len().max(1) as f32;
        let floor = 0.01 * mean.max(1e-12);
        for y in 0..gh {
            let sin_theta = (PI * (y as f32 + 0.5) / gh as f32).sin();
            for v in &mut lum[y * gw..(y + 1) * gw] {
                *v = (v.max(0.0) + floor) * sin_theta;
            }
        }
        Distribution2D::new(&lum, gw, gh)
    }
}

fn sanitize(c: Vec3) -> Vec3 {
    let f = |x: f32| if x.is_finite() { x.max(0.0) } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// Map-frame direction to equirectangular (u, v) in [0, 1)^2.
pub fn dir_to_uv(d: Vec3) -> Vec2 {
    let phi = d.x.atan2(-d.z);
    let theta = d.y.clamp(-1.0, 1.0).acos();
    let u = (phi / (2.0 * PI) + 0.5).rem_euclid(1.0);
    let v = (theta / PI).clamp(0.0, 1.0 - f32::EPSILON);
    Vec2::new(u, v)
}

/// Equirectangular (u, v) to a map-frame direction and sin(theta).
pub fn uv_to_dir(uv: Vec2) -> (Vec3, f32) {
    let phi = 2.0 * PI * (uv.x - 0.5);
    let theta = PI * uv.y;
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    (Vec3::new(st * sp, ct, -st * cp), st.max(0.0))
}

/// Bilinear lookup, wrapping in u and clamping in v; texel centres at +0.5.
fn map_lookup(map: &RgbRaster, uv: Vec2) -> Vec3 {
    let (w, h) = (map.width as i64, map.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let texel = |xi: i64, yi: i64| {
        let xi = xi.rem_euclid(w) as u32;
        let yi = yi.clamp(0, h - 1) as u32;
        Vec3::from_array(*map.get(xi, yi))
    };
    let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
    let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
    sanitize(top.lerp(bottom, fy))
}

/// Mean texel luminance per grid cell, over the cell's texels and a
/// one-texel border: every texel counts, so a sun one texel wide still gets
/// its share of samples, and the border covers what bilinear lookup spreads
/// into the neighbouring cell.
fn map_cell_means(map: &RgbRaster) -> (usize, usize, Vec<f32>) {
    let (w, h) = (map.width as usize, map.height as usize);
    let gw = w.clamp(1, GRID_W);
    let gh = h.clamp(1, GRID_H);
    let texel: Vec<f32> = map
        .data
        .iter()
        .map(|p| luminance(sanitize(Vec3::from_array(*p))))
        .collect();
    let mut lum = vec![0.0f32; gw * gh];
    for cy in 0..gh {
        let (y0, y1) = (
            (cy * h / gh) as i64 - 1,
            ((cy + 1) * h).div_ceil(gh) as i64 + 1,
        );
        for cx in 0..gw {
            let (x0, x1) = (
                (cx * w / gw) as i64 - 1,
                ((cx + 1) * w).div_ceil(gw) as i64 + 1,
            );
            let (mut sum, mut count) = (0.0f64, 0u32);
            for y in y0.max(0)..y1.min(h as i64) {
                for x in x0..x1 {
                    sum += texel[y as usize * w + x.rem_euclid(w as i64) as usize] as f64;
                    count += 1;
                }
            }
            lum[cy * gw + cx] = if count > 0 {
                (sum / count as f64) as f32
            } else {
                0.0
            };
        }
    }
    (gw, gh, lum)
}

/// A seeded sky: a vertical gradient from horizon to zenith, a darker
/// ground below the horizon, a sun-like disc, and two or three broad
/// bright patches (windows, lamps, bright facades) of random colour, so the
/// ambient light has a direction and a tint like a real room or street.
/// Relative levels: sun irradiance at normal incidence 2 to 8 times a sky
/// of 0.3 to 1, patches 1.5 to 4 times the horizon; the whole sky is then
/// scaled to a mean luminance over the sphere of 1 at strength 1 (the rig's
/// light levels are balanced against that, see `crate::scene::rig`).
#[derive(Debug, Clone)]
struct ProceduralSky {
    zenith: Vec3,
    horizon: Vec3,
    ground: Vec3,
    sun_dir: Vec3,
    sun_cos_radius: f32,
    sun_radiance: Vec3,
    patches: Vec<Patch>,
}

/// A bright rectangle in (azimuth, elevation).
#[derive(Debug, Clone)]
struct Patch {
    azimuth: f32,
    elevation: f32,
    half_azimuth: f32,
    half_elevation: f32,
    radiance: Vec3,
}

impl ProceduralSky {
    fn new(seed: u64) -> Self {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(seed ^ 0x5EED_5C1E_u64);
        let tint = |rng: &mut rand_pcg::Pcg32, spread: f32| {
            Vec3::new(
                1.0 + rng.gen_range(-spread..spread),
                1.0 + rng.gen_range(-spread..spread),
                1.0 + rng.gen_range(-spread..spread),
            )
        };
        let sky_level = rng.gen_range(0.3f32..1.0);
        let zenith = Vec3::new(0.55, 0.7, 1.0) * tint(&mut rng, 0.2) * sky_level;
        let horizon = Vec3::new(0.95, 0.95, 1.0) * tint(&mut rng, 0.1) * sky_level * 1.3;
        let ground = Vec3::new(0.45, 0.38, 0.3) * tint(&mut rng, 0.3) * sky_level * 0.5;
        let sun_el = rng.gen_range(0.17f32..1.05);
        let sun_az = rng.gen_range(-PI..PI);
        let sun_dir = azimuth_elevation_dir(sun_az, sun_el);
        let radius = 3.0f32.to_radians();
        let solid_angle = 2.0 * PI * (1.0 - radius.cos());
        let sun_irradiance = rng.gen_range(2.0f32..8.0);
        let sun_radiance =
            Vec3::new(1.0, 0.95, 0.85) * tint(&mut rng, 0.05) * (sun_irradiance / solid_angle);
        let n_patches = rng.gen_range(2..=3);
        let patches = (0..n_patches)
            .map(|_| {
                let warm = rng.gen_bool(0.5);
                let base = if warm {
                    Vec3::new(1.0, 0.8, 0.55)
                } else {
                    Vec3::new(0.7, 0.85, 1.0)
                };
                Patch {
                    azimuth: rng.gen_range(-PI..PI),
                    elevation: rng.gen_range(-0.1f32..0.6),
                    half_azimuth: rng.gen_range(7.5f32..20.0).to_radians(),
                    half_elevation: rng.gen_range(5.0f32..15.0).to_radians(),
                    radiance: base
                        * tint(&mut rng, 0.15)
                        * luminance(horizon)
                        * rng.gen_range(1.5f32..4.0),
                }
            })
            .collect();
        let mut sky = ProceduralSky {
            zenith,
            horizon,
            ground,
            sun_dir,
            sun_cos_radius: radius.cos(),
            sun_radiance,
            patches,
        };
        let mean = sky.mean_luminance();
        if mean > 0.0 && mean.is_finite() {
            sky.scale(1.0 / mean);
        }
        sky
    }

    /// Mean luminance over the sphere: the gradient integrated numerically
    /// over height (d omega = d phi d y), the sun disc and the patches
    /// exactly by their solid angles (they add to the gradient).
    fn mean_luminance(&self) -> f32 {
        const STEPS: usize = 4096;
        let mut base = 0.0f64;
        for i in 0..STEPS {
            let y = -1.0 + 2.0 * (i as f32 + 0.5) / STEPS as f32;
            base += luminance(self.gradient(y)) as f64 * 2.0 / STEPS as f64;
        }
        // 2 pi * integral over y, divided by 4 pi.
        let mut mean = base / 2.0;
        let sun_solid_angle = 2.0 * PI * (1.0 - self.sun_cos_radius);
        mean += (luminance(self.sun_radiance) * sun_solid_angle / (4.0 * PI)) as f64;
        for p in &self.patches {
            let top = (p.elevation + p.half_elevation).min(PI / 2.0);
            let bottom = (p.elevation - p.half_elevation).max(-PI / 2.0);
            let solid_angle = 2.0 * p.half_azimuth * (top.sin() - bottom.sin()).max(0.0);
            mean += (luminance(p.radiance) * solid_angle / (4.0 * PI)) as f64;
        }
        mean as f32
    }

    /// Luminance of grid cell (x, y) for importance sampling: never below
    /// the true mean, so no part of the sky is starved of samples. The
    /// gradient by subsamples (it is smooth), the patches by their exact
    /// overlap (rectangles in the same azimuth-elevation grid), the sun by
    /// its sampled coverage, at least a quarter for every cell its disc may
    /// touch (slivers of a bright disc are what subsampling misses).
    fn cell_luminance(&self, x: usize, y: usize) -> f32 {
        const SUB: usize = 4;
        const SUN_SUB: usize = 8;
        let (du, dv) = (1.0 / GRID_W as f32, 1.0 / GRID_H as f32);
        let (u0, v0) = (x as f32 * du, y as f32 * dv);
        let mut base = 0.0;
        for sy in 0..SUB {
            for sx in 0..SUB {
                let uv = Vec2::new(
                    u0 + (sx as f32 + 0.5) / SUB as f32 * du,
                    v0 + (sy as f32 + 0.5) / SUB as f32 * dv,
                );
                base += luminance(self.gradient(uv_to_dir(uv).0.y));
            }
        }
        let mut lum = base / (SUB * SUB) as f32;

        // Cell extent in azimuth and elevation.
        let az0 = 2.0 * PI * (u0 - 0.5);
        let az_width = 2.0 * PI * du;
        let el_top = PI / 2.0 - PI * v0;
        let el_bottom = PI / 2.0 - PI * (v0 + dv);
        let cell_solid = az_width * (el_top.sin() - el_bottom.sin());
        for p in &self.patches {
            let centre = az0 + az_width / 2.0;
            let offset = (p.azimuth - centre + PI).rem_euclid(2.0 * PI) - PI;
            let (a0, a1) = (offset - p.half_azimuth, offset + p.half_azimuth);
            let az_overlap = (a1.min(az_width / 2.0) - a0.max(-az_width / 2.0)).max(0.0);
            let top = el_top.min(p.elevation + p.half_elevation);
            let bottom = el_bottom.max(p.elevation - p.half_elevation);
            if az_overlap > 0.0 && top > bottom && cell_solid > 0.0 {
                let fraction = az_overlap * (top.sin() - bottom.sin()) / cell_solid;
                lum += luminance(p.radiance) * fraction.clamp(0.0, 1.0);
            }
        }

        let centre_dir = uv_to_dir(Vec2::new(u0 + du / 2.0, v0 + dv / 2.0)).0;
        let half_diagonal = (az_width * az_width + (PI * dv) * (PI * dv)).sqrt() / 2.0;
        let reach = (self.sun_cos_radius.clamp(-1.0, 1.0).acos() + half_diagonal).min(PI);
        if centre_dir.dot(self.sun_dir) >= reach.cos() {
            let mut inside = 0;
            for sy in 0..SUN_SUB {
                for sx in 0..SUN_SUB {
                    let uv = Vec2::new(
                        u0 + (sx as f32 + 0.5) / SUN_SUB as f32 * du,
                        v0 + (sy as f32 + 0.5) / SUN_SUB as f32 * dv,
                    );
                    if uv_to_dir(uv).0.dot(self.sun_dir) >= self.sun_cos_radius {
                        inside += 1;
                    }
                }
            }
            let fraction = (inside as f32 / (SUN_SUB * SUN_SUB) as f32).max(0.25);
            lum += luminance(self.sun_radiance) * fraction;
        }
        lum
    }

    fn scale(&mut self, k: f32) {
        self.zenith *= k;
        self.horizon *= k;
        self.ground *= k;
        self.sun_radiance *= k;
        for p in &mut self.patches {
            p.radiance *= k;
        }
    }

    /// The sky and ground without the sun and patches, by height y.
    fn gradient(&self, y: f32) -> Vec3 {
        if y >= 0.0 {
            self.horizon.lerp(self.zenith, y.sqrt())
        } else {
            // A short blend below the horizon avoids a seam of infinite
            // contrast that would alias at the silhouette of reflections.
            let t = (-y / 0.08).min(1.0);
            self.horizon.lerp(self.ground, t)
        }
    }

    fn radiance(&self, d: Vec3) -> Vec3 {
        let y = d.y.clamp(-1.0, 1.0);
        let mut c = self.gradient(y);
        if d.dot(self.sun_dir) >= self.sun_cos_radius {
            c += self.sun_radiance;
        }
        let az = d.x.atan2(-d.z);
        let el = y.asin();
        for p in &self.patches {
            let daz = (az - p.azimuth + PI).rem_euclid(2.0 * PI) - PI;
            if daz.abs() <= p.half_azimuth && (el - p.elevation).abs() <= p.half_elevation {
                c += p.radiance;
            }
        }
        c
    }
}

/// Map-frame direction at azimuth (as in [`dir_to_uv`]) and elevation.
fn azimuth_elevation_dir(azimuth: f32, elevation: f32) -> Vec3 {
    let (se, ce) = elevation.sin_cos();
    let (sa, ca) = azimuth.sin_cos();
    Vec3::new(ce * sa, se, -ce * ca)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampling::PixelRng;

    #[test]
    fn uv_mapping_round_trips() {
        for d in [
            Vec3::new(0.3, 0.4, -0.5),
            Vec3::new(-0.7, -0.2, 0.1),
            Vec3::new(0.0, 0.1, 1.0),
        ] {
            let d = d.normalize();
            let (back, _) = uv_to_dir(dir_to_uv(d));
            assert!((back - d).length() < 1e-4, "{d} -> {back}");
        }
        assert!(dir_to_uv(Vec3::Y).y < 1e-6);
        assert!((dir_to_uv(-Vec3::Z).x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn rotation_turns_the_map_about_up() {
        let mut data = vec![[0.0f32; 3]; 64 * 32];
        // A bright column at the map's centre (azimuth 0, looking at -Z).
        for y in 0..32 {
            data[y * 64 + 32] = [10.0, 10.0, 10.0];
            data[y * 64 + 31] = [10.0, 10.0, 10.0];
        }
        let map = RgbRaster::from_vec(64, 32, data).unwrap();
        let quarter = std::f32::consts::FRAC_PI_2;
        let env = Environment::from_map(map, 1.0, quarter);
        // Rotated by +90 degrees, azimuth 0 (-Z) moves to azimuth 90 (+X).
        assert!(env.radiance(Vec3::X).x > 5.0);
        assert!(env.radiance(-Vec3::Z).x < 1.0);
    }

    #[test]
    fn sampling_density_matches_pdf_and_integrates_to_one() {
        let env = Environment::procedural(3, 1.0, 0.7);
        let mut rng = PixelRng::new(1, 0, 0, 0);
        // E[1 / pdf] over samples = 4 pi (measure of the sphere).
        let n = 40_000;
        let mut acc = 0.0f64;
        for _ in 0..n {
            let s = env.sample(rng.next2()).unwrap();
            assert!(
                (s.pdf - env.pdf(s.dir)).abs() <= 1e-3 * s.pdf.max(1.0),
                "{} {}",
                s.pdf,
                env.pdf(s.dir)
            );
            assert!(
                (s.radiance - env.radiance(s.dir)).length() < 1e-3 * s.radiance.length().max(1.0)
            );
            acc += 1.0 / s.pdf as f64;
        }
        let measure = acc / n as f64;
        assert!(
            (measure - 4.0 * std::f64::consts::PI).abs() < 0.4,
            "{measure}"
        );
    }

    #[test]
    fn importance_sampled_irradiance_matches_uniform_estimate() {
        // Mean radiance over the sphere, estimated two ways.
        let env = Environment::procedural(11, 1.0, 0.0);
        let mut rng = PixelRng::new(2, 0, 0, 0);
        let n = 200_000;
        let (mut is, mut uni) = (0.0f64, 0.0f64);
        for _ in 0..n {
            if let Some(s) = env.sample(rng.next2()) {
                is += (luminance(s.radiance) / s.pdf) as f64;
            }
            let d = uniform_sphere(rng.next2());
            uni += (luminance(env.radiance(d)) * 4.0 * PI) as f64;
        }
        let (is, uni) = (is / n as f64, uni / n as f64);
        assert!(
            (is - uni).abs() < 0.05 * uni,
            "importance {is} vs uniform {uni}"
        );
    }

    #[test]
    fn procedural_sky_has_a_bright_sun_and_is_seeded() {
        let a = Environment::procedural(5, 1.0, 0.0);
        let b = Environment::procedural(5, 1.0, 0.0);
        let c = Environment::procedural(6, 1.0, 0.0);
        let dirs: Vec<Vec3> = (0..200)
            .map(|i| uniform_sphere([(i as f32 + 0.5) / 200.0, (i as f32 * 0.618) % 1.0]))
            .collect();
        assert!(dirs.iter().all(|&d| a.radiance(d) == b.radiance(d)));
        assert!(dirs.iter().any(|&d| a.radiance(d) != c.radiance(d)));
        let Source::Procedural(sky) = &a.source else {
            unreachable!()
        };
        assert!(luminance(a.radiance(sky.sun_dir)) > 100.0 * luminance(a.radiance(Vec3::Y)));
    }

    #[test]
    fn procedural_sky_has_mean_luminance_one_at_strength_one() {
        for seed in [1, 2, 3] {
            let env = Environment::procedural(seed, 1.0, 0.3);
            let mut rng = PixelRng::new(seed, 0, 0, 0);
            let n = 100_000;
            let mut acc = 0.0f64;
            for _ in 0..n {
                let s = env.sample(rng.next2()).unwrap();
                acc += (luminance(s.radiance) / s.pdf) as f64;
            }
            let mean = acc / n as f64 / (4.0 * std::f64::consts::PI);
            assert!((mean - 1.0).abs() < 0.03, "seed {seed}: {mean}");
        }
    }

    #[test]
    fn an_exr_map_is_read_rotated_and_scaled() {
        use crate::scene::{EnvSource, EnvSpec};
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sky.exr");
        // Top half (looking up) bright red, bottom half dim blue.
        let map = RgbRaster::from_fn(32, 16, |_, y| {
            if y < 8 {
                [4.0, 0.0, 0.0]
            } else {
                [0.0, 0.0, 0.5]
            }
        });
        matscan_scan::image_io::write_rgb_exr(
            &path,
            &map,
            matscan_scan::image_io::Precision::Float,
        )
        .unwrap();
        let env = Environment::from_spec(&EnvSpec {
            source: EnvSource::Map(path),
            strength: 2.0,
            rotation: 1.0,
        })
        .unwrap();
        assert!((env.radiance(Vec3::Y) - Vec3::new(8.0, 0.0, 0.0)).length() < 1e-4);
        assert!((env.radiance(-Vec3::Y) - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-4);
        let missing = Environment::from_spec(&EnvSpec {
            source: EnvSource::Map(dir.path().join("none.exr")),
            strength: 1.0,
            rotation: 0.0,
        });
        assert!(missing.is_err());
    }

    #[test]
    fn strength_zero_or_off_gives_no_light() {
        let env = Environment::procedural(5, 0.0, 0.0);
        assert!(env.is_off());
        assert_eq!(env.radiance(Vec3::Y), Vec3::ZERO);
        assert!(env.sample([0.5, 0.5]).is_none());
        assert_eq!(Environment::off().pdf(Vec3::Y), 0.0);
    }
}
