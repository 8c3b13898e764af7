//! HSV to RGB, as Blender's colour picker and the thesis specify light tints
//! and basecolor sweeps. Values are taken as linear RGB (no transfer curve),
//! which is how Cycles treats an HSV-specified shader colour.

use glam::Vec3;

/// `h` in turns (wrapped), `s` and `v` clamped to [0, 1].
pub fn hsv_to_rgb(h: f32, s: f32, v: f32) -> Vec3 {
    let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
    let h = finite(h).rem_euclid(1.0) * 6.0;
    let s = finite(s).clamp(0.0, 1.0);
    let v = finite(v).clamp(0.0, 1.0);
    let sector = (h.floor() as i32).rem_euclid(6);
    let f = h - h.floor();
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match sector {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_flash_tint_is_a_pale_yellow() {
        let c = hsv_to_rgb(0.1666, 0.1, 1.0);
        assert!((c.x - 1.0).abs() < 1e-3 && (c.y - 1.0).abs() < 1e-3);
        assert!((c.z - 0.9).abs() < 1e-3);
    }

    #[test]
    fn primaries_and_grey_convert_exactly() {
        assert_eq!(hsv_to_rgb(0.0, 1.0, 1.0), Vec3::new(1.0, 0.0, 0.0));
        assert!((hsv_to_rgb(1.0 / 3.0, 1.0, 1.0) - Vec3::Y).length() < 1e-5);
        assert!((hsv_to_rgb(2.0 / 3.0, 1.0, 1.0) - Vec3::Z).length() < 1e-5);
        assert_eq!(hsv_to_rgb(0.3, 0.0, 0.66), Vec3::splat(0.66));
        assert_eq!(hsv_to_rgb(f32::NAN, 2.0, -1.0), Vec3::ZERO);
    }
}
