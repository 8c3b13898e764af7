//! The rig's lights as the integrator sees them: point flashes, the pinhole
//! projector, and the backlight panel.
//!
//! - A flash is a delta point light: radiance arriving at a point is
//!   `intensity * colour / d^2` (no falloff with angle: the LEDs are treated
//!   as isotropic over the small cone the object subtends).
//! - The projector is a delta point light at its centre whose intensity
//!   toward a world point is `intensity * colour * pattern(u, v)`, where
//!   (u, v) are the integer indices `floor` of the point's projection with
//!   the projector's intrinsics and pose, exactly the contract's definition
//!   (`Pattern::value_at`); 0 outside the projector image or behind it. No
//!   cos^4 falloff: a pinhole projector's per-pixel intensity is the pattern.
//! - The backlight panel is a rectangle in the scene in every capture: a
//!   two-sided Lambertian reflector of albedo `Backlight::albedo` (about
//!   0.85, the thesis's "white diffuse when off") that, when switched on,
//!   also emits `Backlight::radiance` from the side facing the camera.
//!   Keeping the reflector when on makes every capture exactly
//!   ambient + its light (linearity), which the renderer exploits.
//!
//! Boundaries: emission, light sampling and the panel's ray intersection;
//! visibility is tested by the integrator.

use crate::scene::{Backlight, PointLight, Projector};
use glam::{DVec3, Vec3};
use matscan_scan::{Pattern, PinholeCamera, Ray};

/// Light arriving at a point from a delta light.
#[derive(Debug, Clone, Copy)]
pub struct DeltaIllumination {
    /// Unit direction from the shaded point toward the light.
    pub wi: Vec3,
    pub distance: f32,
    pub light_pos: Vec3,
    /// Radiance-like quantity `I / d^2` (irradiance at normal incidence).
    pub incident: Vec3,
}

fn sanitize(c: Vec3) -> Vec3 {
    let f = |x: f32| if x.is_finite() { x.max(0.0) } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// A point flash.
#[derive(Debug, Clone)]
pub struct Flash {
    pub position: Vec3,
    /// colour * intensity, W/sr per channel.
    pub intensity: Vec3,
}

impl Flash {
    pub fn new(light: &PointLight) -> Self {
        Flash {
            position: light.position,
            intensity: sanitize(light.color * light.intensity),
        }
    }

    pub fn illuminate(&self, p: Vec3) -> Option<DeltaIllumination> {
        delta_toward(p, self.position, self.intensity)
    }
}

fn delta_toward(p: Vec3, light_pos: Vec3, intensity: Vec3) -> Option<DeltaIllumination> {
    let d = light_pos - p;
    let d2 = d.length_squared();
    if !(d2 > 0.0 && d2.is_finite()) {
        return None;
    }
    let distance = d2.sqrt();
    let incident = sanitize(intensity / d2);
    Some(DeltaIllumination {
        wi: d / distance,
        distance,
        light_pos,
        incident,
    })
}

/// The pinhole projector.
#[derive(Debug, Clone)]
pub struct ProjectorLight {
    camera: PinholeCamera,
    pub center: Vec3,
    /// colour * intensity at full white, W/sr per channel.
    pub intensity: Vec3,
}

impl ProjectorLight {
    pub fn new(projector: &Projector) -> Self {
        let camera = PinholeCamera::new(projector.intrinsics, projector.projector_to_world);
        ProjectorLight {
            center: camera.center().as_vec3(),
            camera,
            intensity: sanitize(projector.color * projector.intensity),
        }
    }

    /// The projector pixel (column, row) whose light reaches world point `p`,
    /// or `None` outside the image or behind the projector.
    pub fn pixel_of(&self, p: Vec3) -> Option<(i64, i64)> {
        let px = self.camera.project(DVec3::from(p))?;
        let (u, v) = (px.x.floor(), px.y.floor());
        let k = &self.camera.intrinsics;
        let inside = u >= 0.0 && v >= 0.0 && u < k.width as f64 && v < k.height as f64;
        inside.then_some((u as i64, v as i64))
    }

    /// Light from the projector at full white reaching `p` (scale by the
    /// pattern value of [`ProjectorLight::pixel_of`]).
    pub fn illuminate_white(&self, p: Vec3) -> Option<(DeltaIllumination, (i64, i64))> {
        let pixel = self.pixel_of(p)?;
        Some((delta_toward(p, self.center, self.intensity)?, pixel))
    }

    /// The pattern's value at a projector pixel, clamped to [0, 1].
    pub fn pattern_value(pattern: &Pattern, pixel: (i64, i64)) -> f32 {
        let v = pattern.value_at(pixel.0, pixel.1) as f32;
        if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// A point sampled on the panel for next-event estimation.
#[derive(Debug, Clone, Copy)]
pub struct PanelSample {
    pub point: Vec3,
    pub wi: Vec3,
    pub distance: f32,
    /// Emitted radiance toward the shaded point (0 from the back side).
    pub radiance: Vec3,
    /// Solid-angle density at the shaded point.
    pub pdf: f32,
}

/// The backlight panel: geometry, reflectance and (when on) emission.
#[derive(Debug, Clone)]
pub struct Panel {
    pub center: Vec3,
    half_u: Vec3,
    half_v: Vec3,
    /// Unit normal of the emitting side (toward the camera).
    pub front: Vec3,
    area: f32,
    /// Emitted radiance of the front side when switched on.
    pub radiance: Vec3,
    pub albedo: f32,
    /// Unit edge directions and half lengths, for the hit test.
    eu: Vec3,
    ev: Vec3,
    lu: f32,
    lv: f32,
}

impl Panel {
    /// The panel of `backlight`, its front facing `camera_center`. `None`
    /// for a degenerate rectangle (the rig then has no panel).
    pub fn new(backlight: &Backlight, camera_center: Vec3) -> Option<Self> {
        let (lu, lv) = (backlight.half_u.length(), backlight.half_v.length());
        let n = backlight.half_u.cross(backlight.half_v);
        let area = 4.0 * n.length();
        if !(area > 0.0 && area.is_finite() && backlight.center.is_finite()) {
            return None;
        }
        let mut front = n.normalize();
        if front.dot(camera_center - backlight.center) < 0.0 {
            front = -front;
        }
        let albedo = if backlight.albedo.is_finite() {
            backlight.albedo.clamp(0.0, 1.0)
        } else {
            0.0
        };
        Some(Panel {
            center: backlight.center,
            half_u: backlight.half_u,
            half_v: backlight.half_v,
            front,
            area,
            radiance: sanitize(backlight.radiance),
            albedo,
            eu: backlight.half_u / lu,
            ev: backlight.half_v / lv,
            lu,
            lv,
        })
    }

    /// Distance along `ray` to the panel (either side), within the ray's
    /// interval.
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let denom = ray.dir.dot(self.front);
        if denom.abs() < 1e-12 {
            return None;
        }
        let t = (self.center - ray.origin).dot(self.front) / denom;
        if !(t > ray.t_min && t < ray.t_max) {
            return None;
        }
        let q = ray.at(t) - self.center;
        // Edges need not be orthogonal: solve in the (half_u, half_v) basis.
        let (a, b) = self.local_coords(q);
        (a.abs() <= 1.0 && b.abs() <= 1.0).then_some(t)
    }

    /// Coordinates of an in-plane offset in units of the half edges.
    fn local_coords(&self, q: Vec3) -> (f32, f32) {
        let (uu, uv, vv) = (
            self.half_u.dot(self.half_u),
            self.half_u.dot(self.half_v),
            self.half_v.dot(self.half_v),
        );
        let (qu, qv) = (q.dot(self.half_u), q.dot(self.half_v));
        let det = uu * vv - uv * uv;
        if det.abs() <= f32::MIN_POSITIVE {
            // Degenerate: fall back to projection on unit edges.
            return (q.dot(self.eu) / self.lu, q.dot(self.ev) / self.lv);
        }
        ((qu * vv - qv * uv) / det, (qv * uu - qu * uv) / det)
    }

    /// Emitted radiance leaving the panel toward direction `out` (unit,
    /// away from the panel) when on: the front side only.
    pub fn emitted(&self, out: Vec3) -> Vec3 {
        if out.dot(self.front) > 0.0 {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }

    pub fn is_emitting(&self) -> bool {
        self.radiance.max_element() > 0.0
    }

    /// Uniform area sampling seen from `p`.
    pub fn sample(&self, p: Vec3, u: [f32; 2]) -> Option<PanelSample> {
        let point =
            self.center + self.half_u * (2.0 * u[0] - 1.0) + self.half_v * (2.0 * u[1] - 1.0);
        let d = point - p;
        let d2 = d.length_squared();
        if !(d2 > 0.0 && d2.is_finite()) {
            return None;
        }
        let distance = d2.sqrt();
        let wi = d / distance;
        let cos_l = wi.dot(self.front).abs();
        if cos_l < 1e-7 {
            return None;
        }
        let pdf = d2 / (cos_l * self.area);
        if !pdf.is_finite() {
            return None;
        }
        Some(PanelSample {
            point,
            wi,
            distance,
            radiance: self.emitted(-wi),
            pdf,
        })
    }

    /// Solid-angle density of [`Panel::sample`] from `p` producing the hit
    /// `hit` in direction `wi`.
    pub fn pdf(&self, p: Vec3, hit: Vec3, wi: Vec3) -> f32 {
        let d2 = (hit - p).length_squared();
        let cos_l = wi.dot(self.front).abs();
        if cos_l < 1e-7 {
            return 0.0;
        }
        let pdf = d2 / (cos_l * self.area);
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// Diagonal length, for scale-relative epsilons.
    pub fn extent(&self) -> f32 {
        2.0 * (self.half_u + self.half_v)
            .length()
            .max((self.half_u - self.half_v).length())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampling::PixelRng;
    use matscan_scan::camera::{look_at, Intrinsics};

    fn backlight() -> Backlight {
        Backlight {
            name: "backlight".into(),
            center: Vec3::new(0.0, 0.0, 1.0),
            half_u: Vec3::new(0.5, 0.0, 0.0),
            half_v: Vec3::new(0.0, 0.25, 0.0),
            radiance: Vec3::splat(2.0),
            albedo: 0.85,
        }
    }

    #[test]
    fn panel_front_faces_the_camera_and_emits_only_there() {
        let p = Panel::new(&backlight(), Vec3::new(0.0, 0.0, -2.0)).unwrap();
        assert!((p.front - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        assert_eq!(p.emitted(-Vec3::Z), Vec3::splat(2.0));
        assert_eq!(p.emitted(Vec3::Z), Vec3::ZERO);
    }

    #[test]
    fn panel_hit_test_respects_its_edges() {
        let p = Panel::new(&backlight(), Vec3::new(0.0, 0.0, -2.0)).unwrap();
        let hit = |x: f32, y: f32| p.intersect(&Ray::new(Vec3::new(x, y, 0.0), Vec3::Z));
        assert!((hit(0.49, 0.24).unwrap() - 1.0).abs() < 1e-6);
        assert!(hit(0.51, 0.0).is_none());
        assert!(hit(0.0, 0.26).is_none());
    }

    #[test]
    fn panel_sampling_estimates_its_solid_angle() {
        let p = Panel::new(&backlight(), Vec3::new(0.0, 0.0, -2.0)).unwrap();
        let origin = Vec3::new(0.1, 0.0, 0.0);
        let mut rng = PixelRng::new(0, 0, 0, 0);
        let n = 20_000;
        let mut est = 0.0f64;
        for _ in 0..n {
            let s = p.sample(origin, rng.next2()).unwrap();
            assert!((s.pdf - p.pdf(origin, s.point, s.wi)).abs() < 1e-3 * s.pdf);
            est += 1.0 / s.pdf as f64;
        }
        est /= n as f64;
        // Reference: the solid angle by brute-force direction counting.
        let m = 400;
        let mut hits = 0usize;
        for k in 0..m * m {
            let u = [
                (k % m) as f32 / m as f32 + 0.5 / m as f32,
                (k / m) as f32 / m as f32,
            ];
            let d = crate::render::sampling::uniform_sphere(u);
            if p.intersect(&Ray::new(origin, d)).is_some() {
                hits += 1;
            }
        }
        let reference = 4.0 * std::f64::consts::PI * hits as f64 / (m * m) as f64;
        assert!(
            (est - reference).abs() < 0.03 * reference,
            "{est} vs {reference}"
        );
    }

    #[test]
    fn projector_pixel_is_the_floor_of_the_projection() {
        let k = Intrinsics {
            width: 100,
            height: 80,
            fx: 100.0,
            fy: 100.0,
            cx: 50.0,
            cy: 40.0,
            distortion: [0.0; 5],
        };
        let pose = look_at(DVec3::ZERO, DVec3::Z, DVec3::NEG_Y);
        let proj = ProjectorLight::new(&Projector {
            name: "projector".into(),
            projector_to_world: pose,
            intrinsics: k,
            color: Vec3::ONE,
            intensity: 3.0,
        });
        let cam = PinholeCamera::new(k, pose);
        let p = Vec3::new(0.123, -0.05, 1.0);
        let px = cam.project(DVec3::from(p)).unwrap();
        assert_eq!(
            proj.pixel_of(p),
            Some((px.x.floor() as i64, px.y.floor() as i64))
        );
        assert!(proj.pixel_of(Vec3::new(0.0, 0.0, -1.0)).is_none());
        assert!(proj.pixel_of(Vec3::new(0.6, 0.0, 1.0)).is_none());
        let (ill, _) = proj.illuminate_white(Vec3::new(0.0, 0.0, 2.0)).unwrap();
        assert!((ill.incident - Vec3::splat(0.75)).length() < 1e-6);
    }
}
