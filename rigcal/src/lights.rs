//! The flashes located from a glossy sphere's highlights (a
//! `matscan-lights/1` bundle): each placement of a sphere of known radius
//! gives, per flash, one reflected ray, and the flash is the point nearest
//! to all its rays.
//!
//! - **The sphere**: its silhouette against the backlight panel (the
//!   backlit photo minus ambient), traced at half the panel's level to
//!   sub-pixel edge points. The silhouette of a sphere is a cone of rays
//!   tangent to it: every edge point's unit ray `u` satisfies `u . a =
//!   cos(beta)` for the unit direction `a` to the centre and the half-angle
//!   `beta`, linear in `a / cos(beta)`; `sin(beta) = radius / distance`
//!   gives the centre in 3D. Exact under perspective, where the outline is
//!   an ellipse, not a circle.
//! - **A highlight**: the flash photo minus ambient inside the silhouette;
//!   the centroid of the pixels above a quarter of the peak, weighted by
//!   their excess over it. A clipped
//!   peak is refused (its centroid is whatever the clipping left).
//! - **The ray**: the highlight pixel's ray meets the sphere; the normal
//!   there mirrors the view ray into the ray towards the flash.
//! - **The flash**: the least-squares point nearest to its rays, in the
//!   camera's frame, then carried to every position by that position's
//!   camera pose: the flashes ride with the camera.
//!
//! Boundaries: reads the bundle's photos and the rig file's camera; writes
//! nothing (see [`crate::write`]).

use crate::camera::{check_size, read_shot};
use crate::detect::percentile;
use crate::error::RigcalError;
use glam::{DMat3, DVec2, DVec3};
use matscan_scan::lights_bundle::{
    light_photo, LightsManifest, AMBIENT_PHOTO, BACKLIGHT_PHOTO, CLIPPED_LEVEL, FLASHES,
    PROJECTOR_PHOTO,
};
use matscan_scan::raster::RgbRaster;
use matscan_scan::{Intrinsics, Manifest};
use std::path::Path;

/// How far, in sphere radii, the projector's highlight may put the centre
/// from the outline's: the rim's pull is a fraction of a pixel, a
/// highlight that lands farther is a stray reflection.
const MIRROR_AGREEMENT: f64 = 0.03;
/// Fewest sub-pixel edge points that make a silhouette.
const MIN_EDGE_POINTS: usize = 24;

/// The sphere as one photo shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereView {
    /// Centre in the camera frame, bundle units.
    pub centre: DVec3,
    /// Where the centre projects, pixels.
    pub centre_px: DVec2,
    /// Apparent radius, pixels (the cone's half-angle times the focal
    /// length).
    pub radius_px: f64,
    /// Sub-pixel edge points the cone was fitted to.
    pub edge_points: usize,
    /// RMS of the edge points' angular distance from the fitted cone,
    /// pixels.
    pub edge_rms_px: f64,
    /// The centre was moved to where the calibrated projector's highlight
    /// puts it ([`centre_from_mirror`]); else it is the silhouette's.
    pub centred_by_projector: bool,
}

/// One flash's highlight on one placement, and the ray it gives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Highlight {
    pub pixel: DVec2,
    /// Where the ray leaves the sphere, camera frame.
    pub origin: DVec3,
    /// Unit direction towards the flash, camera frame.
    pub direction: DVec3,
}

/// One flash located.
#[derive(Debug, Clone, PartialEq)]
pub struct FlashFix {
    pub name: String,
    /// In the camera frame.
    pub position: DVec3,
    /// RMS distance of the fix from its rays, bundle units.
    pub ray_rms: f64,
    /// Largest angle between two of its rays, degrees: small angles locate
    /// the flash poorly along the rays.
    pub spread_deg: f64,
    pub rays: usize,
}

/// Every flash, with what each placement showed.
#[derive(Debug, Clone, PartialEq)]
pub struct LightCalibration {
    pub flashes: Vec<FlashFix>,
    /// Per placement: its folder and the sphere found there.
    pub spheres: Vec<(std::path::PathBuf, SphereView)>,
}

/// The sphere's silhouette in `backlit - ambient`: sub-pixel points where
/// the difference crosses half the panel's level, on the dark blob that
/// does not touch the image's border.
pub fn find_sphere(
    backlit: &RgbRaster,
    ambient: &RgbRaster,
    camera: &Intrinsics,
    radius: f64,
    path: &Path,
) -> Result<SphereView, RigcalError> {
    let not_found = |reason: String| RigcalError::SphereNotFound {
        path: path.to_path_buf(),
        reason,
    };
    let (w, h) = (backlit.width as usize, backlit.height as usize);
    if (ambient.width, ambient.height) != (backlit.width, backlit.height) || w < 8 || h < 8 {
        return Err(not_found("the photo and its ambient differ in size".into()));
    }
    let level: Vec<f32> = backlit
        .data
        .iter()
        .zip(&ambient.data)
        .map(|(b, a)| {
            let d = (b[0] - a[0]) + (b[1] - a[1]) + (b[2] - a[2]);
            if d.is_finite() {
                d / 3.0
            } else {
                0.0
            }
        })
        .collect();
    // The panel: the photo's bright end (it may fill only part of the view,
    // but surely more than a fiftieth of it around the sphere).
    let panel = percentile(&level, 0.98);
    if panel <= 1e-4 {
        return Err(not_found(
            "the backlight panel is not behind it (the backlit photo is as dark as ambient)".into(),
        ));
    }
    let half = 0.5 * panel;
    let dark: Vec<bool> = level.iter().map(|&v| v < half).collect();
    let blob = central_dark_blob(&dark, w, h).ok_or_else(|| {
        not_found(
            "no dark disc wholly inside the photo against the backlight panel; place the \
             sphere so that the panel is behind all of it"
                .into(),
        )
    })?;
    // The iso-level halfway between the sphere's own level and the
    // panel's: an anti-aliased edge crosses it where the outline lies.
    let inner: Vec<f32> = level
        .iter()
        .zip(&blob)
        .filter(|(_, &b)| b)
        .map(|(&v, _)| v)
        .collect();
    let inner_level = percentile(&inner, 0.5);
    let half = 0.5 * (panel + inner_level);
    // Sub-pixel crossings of that level between 4-neighbours, one of them
    // on the blob.
    let mut edge = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for (nx, ny) in [(x + 1, y), (x, y + 1)] {
                if nx >= w || ny >= h {
                    continue;
                }
                let j = ny * w + nx;
                if blob[i] == blob[j] || !(blob[i] || blob[j]) {
                    continue;
                }
                let (a, b) = (level[i], level[j]);
                if (a - half) * (b - half) > 0.0 || a == b {
                    continue;
                }
                let t = f64::from((half - a) / (b - a)).clamp(0.0, 1.0);
                // Pixel centres at +0.5: the contract's pixel (i, j) covers
                // [i, i + 1) x [j, j + 1).
                let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5)
                    + t * DVec2::new((nx - x) as f64, (ny - y) as f64);
                edge.push(p);
            }
        }
    }
    if edge.len() < MIN_EDGE_POINTS {
        return Err(not_found(format!(
            "its outline has {} edge points (at least {MIN_EDGE_POINTS}): the sphere is too \
             small in the photo",
            edge.len()
        )));
    }
    let rays: Vec<DVec3> = edge
        .iter()
        .map(|&p| camera.ray_direction(p).normalize())
        .collect();
    let no_circle =
        || not_found("its outline is no circle (the fit of a sphere's silhouette failed)".into());
    let (axis, cos_beta) = fit_cone(&rays).ok_or_else(no_circle)?;
    let sin_beta = (1.0 - cos_beta * cos_beta).max(0.0).sqrt();
    if !(sin_beta > 1e-6 && cos_beta > 0.0) {
        return Err(not_found("its outline is no circle".into()));
    }
    let centre = axis * (radius / sin_beta);
    let f = 0.5 * (camera.fx + camera.fy);
    let residual = (rays
        .iter()
        .map(|u| (u.dot(axis).clamp(-1.0, 1.0).acos() - cos_beta.acos()).powi(2))
        .sum::<f64>()
        / rays.len() as f64)
        .sqrt();
    let centre_px = camera
        .project_camera_point(centre)
        .ok_or_else(|| not_found("its centre is behind the camera".into()))?;
    let edge_points = rays.len();
    Ok(SphereView {
        centre,
        centre_px,
        radius_px: cos_beta.acos() * f,
        edge_points,
        edge_rms_px: residual * f,
        centred_by_projector: false,
    })
}

/// The largest 4-connected component of `dark` that does not touch the
/// image's border: the sphere against the panel.
fn central_dark_blob(dark: &[bool], w: usize, h: usize) -> Option<Vec<bool>> {
    let mut label = vec![0u32; dark.len()];
    let mut best: Option<(usize, u32)> = None;
    let mut next = 0u32;
    for start in 0..dark.len() {
        if !dark[start] || label[start] != 0 {
            continue;
        }
        next += 1;
        let (mut size, mut border) = (0usize, false);
        let mut stack = vec![start];
        label[start] = next;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % w, i / w);
            border |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let mut visit = |j: usize| {
                if dark[j] && label[j] == 0 {
                    label[j] = next;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        if !border && best.is_none_or(|(s, _)| size > s) {
            best = Some((size, next));
        }
    }
    let (_, id) = best?;
    Some(label.iter().map(|&l| l == id).collect())
}

/// The cone `u . a = c` through unit rays `rays`: least squares on
/// `u . w = 1` with `w = a / c`. `None` when the rays do not fix it.
pub fn fit_cone(rays: &[DVec3]) -> Option<(DVec3, f64)> {
    let mut ata = DMat3::ZERO;
    let mut atb = DVec3::ZERO;
    for u in rays {
        ata += outer(*u, *u);
        atb += *u;
    }
    if ata.determinant().abs() < 1e-18 {
        return None;
    }
    let w = ata.inverse() * atb;
    let norm = w.length();
    (norm.is_finite() && norm > 1.0).then(|| (w / norm, 1.0 / norm))
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The highlight of one flash inside the sphere's disc: the centroid of
/// `flash - ambient` above a quarter of its peak, weighted by the excess.
pub fn find_highlight(
    flash: &RgbRaster,
    ambient: &RgbRaster,
    sphere: &SphereView,
    path: &Path,
) -> Result<DVec2, RigcalError> {
    let (w, h) = (flash.width as i64, flash.height as i64);
    let inside = 0.95 * sphere.radius_px;
    let at = |x: i64, y: i64| -> (f32, bool) {
        let i = (y * w + x) as usize;
        let (f, a) = (flash.data[i], ambient.data[i]);
        let d = ((f[0] - a[0]) + (f[1] - a[1]) + (f[2] - a[2])) / 3.0;
        let clipped = f.iter().any(|&v| v >= CLIPPED_LEVEL);
        (if d.is_finite() { d } else { 0.0 }, clipped)
    };
    let (cx, cy) = (sphere.centre_px.x, sphere.centre_px.y);
    let r = sphere.radius_px.ceil() as i64 + 1;
    // The peak, and the disc's median under this light: a highlight must
    // stand out of the sphere's own lit surface (a glossy sphere's diffuse
    // share).
    let mut peak = (0.0f32, 0i64, 0i64);
    let mut disc = Vec::new();
    for y in (cy as i64 - r).max(0)..(cy as i64 + r).min(h) {
        for x in (cx as i64 - r).max(0)..(cx as i64 + r).min(w) {
            if DVec2::new(x as f64 + 0.5 - cx, y as f64 + 0.5 - cy).length() > inside {
                continue;
            }
            let (v, _) = at(x, y);
            disc.push(v);
            if v > peak.0 {
                peak = (v, x, y);
            }
        }
    }
    let floor = percentile(&disc, 0.5).max(0.0);
    if peak.0 <= 10.0 * floor.max(1e-4) {
        return Err(RigcalError::Highlight {
            path: path.to_path_buf(),
            reason: format!(
                "no highlight on the sphere (its brightest point is {:.2e}, its surface {:.2e}): \
                 the flash did not fire or its reflection misses the sphere",
                peak.0, floor
            ),
        });
    }
    let threshold = 0.25 * peak.0;
    // The highlight: the pixels above the threshold connected to the peak,
    // however wide the lobe spreads them.
    let mut seen = std::collections::HashSet::new();
    let mut stack = vec![(peak.1, peak.2)];
    seen.insert((peak.1, peak.2));
    let mut sum = DVec2::ZERO;
    let mut weight = 0.0;
    while let Some((x, y)) = stack.pop() {
        let (v, clipped) = at(x, y);
        if clipped {
            return Err(RigcalError::Highlight {
                path: path.to_path_buf(),
                reason: format!(
                    "the highlight is clipped at pixel ({x}, {y}); lower the exposure or the \
                     flash's power"
                ),
            });
        }
        let excess = f64::from(v - threshold);
        sum += excess * DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        weight += excess;
        for (nx, ny) in [(x + 1, y), (x - 1, y), (x, y + 1), (x, y - 1)] {
            let inside_disc =
                DVec2::new(nx as f64 + 0.5 - cx, ny as f64 + 0.5 - cy).length() <= inside;
            if nx >= 0
                && ny >= 0
                && nx < w
                && ny < h
                && inside_disc
                && !seen.contains(&(nx, ny))
                && at(nx, ny).0 > threshold
            {
                seen.insert((nx, ny));
                stack.push((nx, ny));
            }
        }
    }
    Ok(sum / weight.max(f64::MIN_POSITIVE))
}

/// The ray towards the flash whose highlight is at `pixel` on `sphere`:
/// the view ray mirrored about the normal where it meets the sphere.
/// `None` when the pixel's ray misses the sphere.
pub fn reflected_ray(
    camera: &Intrinsics,
    sphere: &SphereView,
    radius: f64,
    pixel: DVec2,
) -> Option<Highlight> {
    let v = camera.ray_direction(pixel).normalize();
    let c = sphere.centre;
    let b = v.dot(c);
    let disc = b * b - (c.length_squared() - radius * radius);
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let t = b - disc.sqrt();
    let origin = v * t;
    let n = (origin - c) / radius;
    let direction = (v - 2.0 * v.dot(n) * n).normalize();
    direction.is_finite().then_some(Highlight {
        pixel,
        origin,
        direction,
    })
}

/// The sphere's centre from the highlight at `pixel` of a light at the
/// known point `light` (camera frame): the highlight's point lies on the
/// pixel's ray at the depth where it meets `sphere` (the silhouette's
/// sphere), its normal halves the ways to the camera and to the light, and
/// the centre lies one radius behind it. The silhouette's centre is only
/// as good as its outline, which a glossy rim's glow pulls in on the side
/// where the backlight mirrors widest; a highlight is not, and the
/// silhouette's small error in depth hardly turns the normal. `None` when
/// the ray misses the sphere.
pub fn centre_from_mirror(
    camera: &Intrinsics,
    sphere: &SphereView,
    radius: f64,
    pixel: DVec2,
    light: DVec3,
) -> Option<DVec3> {
    let v = camera.ray_direction(pixel).normalize();
    let c = sphere.centre;
    let b = v.dot(c);
    // Where the silhouette's sphere is nearest to the ray, when it misses by
    // a little: the two spheres differ by the outline's error.
    let disc = (b * b - (c.length_squared() - radius * radius)).max(0.0);
    let p = v * (b - disc.sqrt());
    let n = ((-p).normalize() + (light - p).normalize()).normalize();
    let centre = p - n * radius;
    (centre.is_finite() && b > 0.0).then_some(centre)
}

/// The point nearest to every ray (origin, unit direction) in least
/// squares, with the RMS distance and the largest angle between two rays;
/// `None` for fewer than two rays or rays that are all parallel.
pub fn nearest_point(rays: &[(DVec3, DVec3)]) -> Option<(DVec3, f64, f64)> {
    if rays.len() < 2 {
        return None;
    }
    let mut a = DMat3::ZERO;
    let mut b = DVec3::ZERO;
    for (o, d) in rays {
        let m = DMat3::IDENTITY - outer(*d, *d);
        a += m;
        b += m * *o;
    }
    let spread = rays
        .iter()
        .flat_map(|(_, d)| {
            rays.iter()
                .map(move |(_, e)| d.dot(*e).clamp(-1.0, 1.0).acos())
        })
        .fold(0.0, f64::max)
        .to_degrees();
    if a.determinant().abs() < 1e-12 || spread < 0.5 {
        return None;
    }
    let p = a.inverse() * b;
    let rms = (rays
        .iter()
        .map(|(o, d)| {
            let q = p - *o;
            (q - d * q.dot(*d)).length_squared()
        })
        .sum::<f64>()
        / rays.len() as f64)
        .sqrt();
    p.is_finite().then_some((p, rms, spread))
}

/// Locates every flash from the bundle in `dir` (`manifest`), with the
/// camera of `rig` (the rig file `matscan calib rig` wrote). The positions
/// are in the camera frame; [`flashes_in_world`] carries them to each
/// position.
pub fn calibrate_lights(
    dir: &Path,
    manifest: &LightsManifest,
    rig: &Manifest,
) -> Result<LightCalibration, RigcalError> {
    let camera = rig.camera;
    let mut spheres = Vec::new();
    let mut rays: Vec<Vec<(DVec3, DVec3)>> = vec![Vec::new(); FLASHES.len()];
    for placement in &manifest.placements {
        if !rig.positions.iter().any(|p| p.name == placement.position) {
            return Err(RigcalError::UnknownPosition {
                path: dir.join(&placement.folder),
                position: placement.position.clone(),
            });
        }
        let folder = dir.join(&placement.folder);
        let ambient = read_shot(&folder.join(AMBIENT_PHOTO))?;
        let backlit_path = folder.join(BACKLIGHT_PHOTO);
        let backlit = read_shot(&backlit_path)?;
        check_size(&backlit, &camera, &backlit_path)?;
        let mut sphere = find_sphere(&backlit, &ambient, &camera, manifest.radius, &backlit_path)?;
        let projector_path = folder.join(PROJECTOR_PHOTO);
        if let (Some(light), true) = (
            projector_centre(rig, &placement.position),
            projector_path.is_file(),
        ) {
            let photo = read_shot(&projector_path)?;
            check_size(&photo, &camera, &projector_path)?;
            // A place outside the projector's image has no highlight of it,
            // or a stray one: its outline's centre stands.
            let mirrored = find_highlight(&photo, &ambient, &sphere, &projector_path)
                .ok()
                .and_then(|pixel| {
                    centre_from_mirror(&camera, &sphere, manifest.radius, pixel, light)
                })
                .and_then(|c| Some((c, camera.project_camera_point(c)?)))
                .filter(|(_, px)| {
                    (*px - sphere.centre_px).length() <= MIRROR_AGREEMENT * sphere.radius_px
                });
            if let Some((centre, centre_px)) = mirrored {
                sphere.centre = centre;
                sphere.centre_px = centre_px;
                sphere.centred_by_projector = true;
            }
        }
        for (k, light) in FLASHES.iter().enumerate() {
            let path = folder.join(light_photo(light));
            let photo = read_shot(&path)?;
            check_size(&photo, &camera, &path)?;
            let pixel = find_highlight(&photo, &ambient, &sphere, &path)?;
            let ray = reflected_ray(&camera, &sphere, manifest.radius, pixel).ok_or_else(|| {
                RigcalError::Highlight {
                    path: path.clone(),
                    reason: "the highlight lies off the sphere found in the backlit photo".into(),
                }
            })?;
            rays[k].push((ray.origin, ray.direction));
        }
        spheres.push((placement.folder.clone(), sphere));
    }
    let mut flashes = Vec::new();
    for (k, light) in FLASHES.iter().enumerate() {
        let (position, ray_rms, spread_deg) = nearest_point(&rays[k]).ok_or_else(|| {
            RigcalError::Degenerate(format!(
                "the rays of `{light}` from {} placements are parallel: place the sphere \
                 farther apart (left, right, near, far)",
                rays[k].len()
            ))
        })?;
        flashes.push(FlashFix {
            name: light.to_string(),
            position,
            ray_rms,
            spread_deg,
            rays: rays[k].len(),
        });
    }
    Ok(LightCalibration { flashes, spheres })
}

/// The projector's centre in the camera frame at `position`, if the rig
/// file calibrates one there.
fn projector_centre(rig: &Manifest, position: &str) -> Option<DVec3> {
    let p = rig.positions.iter().find(|p| p.name == position)?;
    p.lights.iter().find_map(|l| match l.kind {
        matscan_scan::LightKind::Projector {
            projector_to_world, ..
        } => Some(
            p.camera_to_world
                .inverse()
                .transform_point3(projector_to_world.w_axis.truncate()),
        ),
        _ => None,
    })
}

/// `rig` with each position's flashes moved to where `lights` found them
/// (camera frame, carried by each position's camera pose); a flash the
/// rig file lacks is added as a point light.
pub fn flashes_in_world(rig: &Manifest, lights: &LightCalibration) -> Manifest {
    let mut out = rig.clone();
    for position in &mut out.positions {
        for fix in &lights.flashes {
            let world = position.camera_to_world.transform_point3(fix.position);
            match position.lights.iter_mut().find(|l| l.name == fix.name) {
                Some(l) => l.kind = matscan_scan::LightKind::Point { position: world },
                None => position.lights.push(matscan_scan::Light {
                    name: fix.name.clone(),
                    kind: matscan_scan::LightKind::Point { position: world },
                    color: [1.0; 3],
                    intensity: None,
                }),
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Intrinsics {
        Intrinsics {
            width: 640,
            height: 480,
            fx: 700.0,
            fy: 700.0,
            cx: 321.0,
            cy: 238.5,
            distortion: [-0.05, 0.02, 0.0, 0.0, 0.0],
        }
    }

    /// Unit rays tangent to a sphere at `centre` of `radius`.
    fn silhouette(centre: DVec3, radius: f64, n: usize) -> Vec<DVec3> {
        let a = centre.normalize();
        let sin_b = radius / centre.length();
        let cos_b = (1.0 - sin_b * sin_b).sqrt();
        let e1 = a.any_orthonormal_vector();
        let e2 = a.cross(e1);
        (0..n)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                (a * cos_b + (e1 * t.cos() + e2 * t.sin()) * sin_b).normalize()
            })
            .collect()
    }

    #[test]
    fn the_cone_of_a_spheres_outline_gives_its_centre() {
        let centre = DVec3::new(0.3, -0.2, 1.4);
        let (a, c) = fit_cone(&silhouette(centre, 0.04, 90)).unwrap();
        let d = 0.04 / (1.0 - c * c).sqrt();
        assert!((a * d - centre).length() < 1e-7, "{}", a * d);
        assert!(fit_cone(&[DVec3::Z; 10]).is_none());
    }

    #[test]
    fn mirrored_highlights_of_several_placements_meet_at_the_flash() {
        let k = camera();
        let flash = DVec3::new(0.15, -0.05, 0.02);
        let radius = 0.04;
        let mut rays = Vec::new();
        for centre in [
            DVec3::new(-0.3, 0.1, 1.2),
            DVec3::new(0.35, -0.15, 1.0),
            DVec3::new(0.0, 0.25, 1.5),
        ] {
            // The mirror point: where the normal halves the way to the camera
            // and to the flash, found by bisection on the sphere.
            let mut n = (-centre).normalize();
            for _ in 0..200 {
                let p = centre + n * radius;
                let half = ((-p).normalize() + (flash - p).normalize()).normalize();
                n = (n + 0.5 * (half - n)).normalize();
            }
            let p = centre + n * radius;
            let pixel = k.project_camera_point(p).unwrap();
            let view = SphereView {
                centre,
                centre_px: k.project_camera_point(centre).unwrap(),
                radius_px: 30.0,
                edge_points: 100,
                edge_rms_px: 0.0,
                centred_by_projector: false,
            };
            let ray = reflected_ray(&k, &view, radius, pixel).unwrap();
            assert!((ray.origin - p).length() < 1e-6, "{} vs {p}", ray.origin);
            rays.push((ray.origin, ray.direction));
        }
        let (found, rms, spread) = nearest_point(&rays).unwrap();
        assert!((found - flash).length() < 1e-5, "{found}");
        assert!(rms < 1e-5 && spread > 5.0, "{rms} {spread}");
        // One ray, or parallel rays, fix nothing.
        assert!(nearest_point(&rays[..1]).is_none());
        assert!(nearest_point(&[(DVec3::ZERO, DVec3::Z), (DVec3::X, DVec3::Z)]).is_none());
    }

    #[test]
    fn a_known_lights_highlight_centres_a_sphere_whose_outline_is_off() {
        let k = camera();
        let radius = 0.04;
        let centre = DVec3::new(0.25, -0.12, 1.1);
        let light = DVec3::new(-0.2, 0.05, 0.03);
        // The true mirror point of `light`, by iteration on the sphere.
        let mut n = (-centre).normalize();
        for _ in 0..200 {
            let p = centre + n * radius;
            let half = ((-p).normalize() + (light - p).normalize()).normalize();
            n = (n + 0.5 * (half - n)).normalize();
        }
        let pixel = k.project_camera_point(centre + n * radius).unwrap();
        // An outline pulled in on one side: the centre 0.2 px off and 0.7 %
        // too far.
        let off = (centre + DVec3::new(0.2 / 700.0 * 1.1, 0.0, 0.0)) * 1.007;
        let outline = SphereView {
            centre: off,
            centre_px: k.project_camera_point(off).unwrap(),
            radius_px: 25.0,
            edge_points: 100,
            edge_rms_px: 0.0,
            centred_by_projector: false,
        };
        let found = centre_from_mirror(&k, &outline, radius, pixel, light).unwrap();
        let across = |c: DVec3| c.normalize().cross(centre.normalize()).length() * 700.0;
        assert!(across(off) > 0.15, "{}", across(off));
        // What is left comes from the depth's 0.7 %, which turns the way to
        // the light (20 cm beside the camera) a little.
        assert!(
            across(found) < 0.04,
            "the centre's direction {} px off",
            across(found)
        );
        assert!((found.length() / centre.length() - 1.0).abs() < 0.01);
    }

    /// A backlit photo of a dark sphere before the panel and its ambient.
    fn backlit(k: &Intrinsics, centre: DVec3, radius: f64) -> (RgbRaster, RgbRaster) {
        let samples = 4;
        let backlit = RgbRaster::from_fn(k.width, k.height, |x, y| {
            let mut lit = 0.0;
            for sy in 0..samples {
                for sx in 0..samples {
                    let px = DVec2::new(
                        x as f64 + (sx as f64 + 0.5) / samples as f64,
                        y as f64 + (sy as f64 + 0.5) / samples as f64,
                    );
                    let v = k.ray_direction(px).normalize();
                    let b = v.dot(centre);
                    let hit = b * b - (centre.length_squared() - radius * radius) >= 0.0;
                    lit += if hit { 0.02 } else { 0.6 };
                }
            }
            [0.05 + lit / (samples * samples) as f32; 3]
        });
        let ambient = RgbRaster::from_fn(k.width, k.height, |_, _| [0.05; 3]);
        (backlit, ambient)
    }

    #[test]
    fn a_sphere_before_the_backlight_is_found_to_a_fraction_of_a_millimetre() {
        let k = camera();
        let centre = DVec3::new(0.12, 0.05, 0.9);
        let (b, a) = backlit(&k, centre, 0.04);
        let s = find_sphere(&b, &a, &k, 0.04, Path::new("backlight.exr")).unwrap();
        assert!(
            (s.centre - centre).length() < 3e-4,
            "{} vs {centre}",
            s.centre
        );
        assert!(s.edge_points > 100 && s.edge_rms_px < 0.1, "{s:?}");
        // The panel off: named, with what to do.
        let e = find_sphere(&a, &a, &k, 0.04, Path::new("p0/sphere-00/backlight.exr"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("p0/sphere-00/backlight.exr") && e.contains("panel"),
            "{e}"
        );
        // Cut by the photo's edge: not a whole silhouette.
        let (b, a) = backlit(&k, DVec3::new(0.62, 0.0, 0.9), 0.04);
        let e = find_sphere(&b, &a, &k, 0.04, Path::new("x.exr")).unwrap_err();
        assert!(e.to_string().contains("sphere not found"), "{e}");
    }

    #[test]
    fn a_missing_or_clipped_highlight_is_refused_naming_the_photo() {
        let k = camera();
        let centre = DVec3::new(0.0, 0.0, 0.9);
        let (b, a) = backlit(&k, centre, 0.04);
        let s = find_sphere(&b, &a, &k, 0.04, Path::new("b.exr")).unwrap();
        let e = find_highlight(&a, &a, &s, Path::new("p0/sphere-00/flash0.exr"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("flash0.exr") && e.contains("no highlight"),
            "{e}"
        );
        let (cx, cy) = (s.centre_px.x as u32, s.centre_px.y as u32);
        let spot = |level: f32| {
            RgbRaster::from_fn(k.width, k.height, |x, y| {
                let d = (x as f32 - cx as f32).powi(2) + (y as f32 - cy as f32 + 3.0).powi(2);
                [0.05 + level * (-d / 2.0).exp(); 3]
            })
        };
        let found = find_highlight(&spot(0.5), &a, &s, Path::new("f.exr")).unwrap();
        let want = DVec2::new(cx as f64 + 0.5, cy as f64 - 3.0 + 0.5);
        assert!((found - want).length() < 0.05, "{found} vs {want}");
        let e = find_highlight(
            &spot(3.0).map(|p| p.map(|v| v.min(1.0))),
            &a,
            &s,
            Path::new("f.exr"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("clipped"), "{e}");
    }
}
