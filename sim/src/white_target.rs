//! The radiometric calibration target on the simulated rig: a matte white
//! card of known reflectance at a known pose (where the printed board's
//! reference placement stands), rendered by the same path tracer as the
//! scans, in the same Principled BSDF the radiometry models it with.
//!
//! The mount left empty (the backlight panel photographed alone) is the
//! card put away behind the panel: the renderer needs an object, and one
//! behind the panel neither shows nor lights anything the camera sees.
//!
//! Boundaries: the scenes only; the capture path renders them.

use crate::calib_target::{flat_mesh, target_scene};
use crate::scene::{Rig, Scene, Texture};
use glam::{DMat4, DVec3};
use matscan_scan::white_bundle::WhiteCard;

/// The simulated operator's card: its reflectance, which the daemon's
/// `[calibration] white_albedo` and `white_roughness` default to.
pub const CARD_ALBEDO: f64 = 0.9;
pub const CARD_ROUGHNESS: f64 = 1.0;

/// The scene of an empty mount at rig position `position`: a small card
/// half a metre behind that position's backlight panel, out of the
/// camera's sight.
pub fn empty_mount_scene(rig: &Rig, position: usize) -> Scene {
    let hidden = rig
        .positions
        .get(position)
        .or(rig.positions.first())
        .map(|p| {
            let b = &p.backlight;
            // The emitting side, which faces the camera, is half_u x half_v.
            let towards_camera = b.half_u.cross(b.half_v).as_dvec3().normalize_or_zero();
            b.center.as_dvec3() - 0.5 * towards_camera
        })
        .unwrap_or(DVec3::new(0.0, 0.0, 100.0));
    let card = WhiteCard {
        albedo: CARD_ALBEDO,
        roughness: CARD_ROUGHNESS,
        size: [0.05, 0.05],
        card_to_world: DMat4::from_translation(hidden),
    };
    white_card_scene(&card, rig)
}

/// The card's scene: `card` (its reflectance, size and pose) under `rig`.
pub fn white_card_scene(card: &WhiteCard, rig: &Rig) -> Scene {
    let albedo = card.albedo.clamp(0.0, 1.0) as f32;
    let mesh = flat_mesh(card.card_to_world, card.size);
    let roughness = card.roughness.clamp(0.0, 1.0) as f32;
    target_scene(
        "white-card",
        "card",
        mesh,
        Texture::Constant([albedo; 3]),
        roughness,
        rig,
    )
}
