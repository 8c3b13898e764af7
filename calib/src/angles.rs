//! The cosines of the thesis's BRDF angles (eqs. 3.2 to 3.4) as pure
//! functions of a normal `n`, a view vector `v` and a light vector `l`.
//!
//! Boundaries: plain vector math, no maps; the callers decide which frame
//! the vectors live in (cosines do not depend on it). Work is in f64 so the
//! projections of eq. 3.4 keep their precision near the pole.
//!
//! Guarantees, for every finite or non-finite input: the result is finite
//! and in `[-1, 1]`; a zero-length (or non-finite) vector gives 0.

use glam::DVec3;

/// Below this sine of the polar angle (|V_S| or |L_S| for unit V, L, N),
/// the azimuth of eq. 3.4 is not trusted: see [`cos_vl`].
pub const AZIMUTH_EPSILON: f64 = 1e-4;

/// `cos(angle NL)` (eq. 3.2) or `cos(angle NV)` (eq. 3.3): the cosine of the
/// direct angle between two vectors of any length.
pub fn cos_between(a: DVec3, b: DVec3) -> f64 {
    match (a.try_normalize(), b.try_normalize()) {
        (Some(a), Some(b)) => a.dot(b).clamp(-1.0, 1.0),
        _ => 0.0,
    }
}

/// `cos(angle VL)` of eq. 3.4: the cosine of the azimuth between `v` and
/// `l` once both are projected onto the surface plane of normal `n`.
///
/// Eq. 3.4 is undefined where `v` or `l` is parallel to `n` (a projection
/// vanishes), and no continuous extension exists there: the limit depends on
/// the direction of approach. We therefore compute
/// `V_S . L_S / (max(|V_S|, e) * max(|L_S|, e))` with unit `v`, `l`, `n` and
/// `e` = [`AZIMUTH_EPSILON`]: exactly eq. 3.4 wherever both projections are
/// longer than `e` (polar angles above ~0.006 degrees), and fading linearly
/// to 0 as a projection shrinks to nothing. The result is continuous in all
/// three vectors, and its value at the pole, 0, is the mean of `cos` over a
/// uniform azimuth, which is what an isotropic BRDF sees there (its value
/// does not depend on the azimuth when `v` or `l` is at the pole).
pub fn cos_vl(n: DVec3, v: DVec3, l: DVec3) -> f64 {
    let (Some(n), Some(v), Some(l)) = (n.try_normalize(), v.try_normalize(), l.try_normalize())
    else {
        return 0.0;
    };
    let vs = v - n * v.dot(n);
    let ls = l - n * l.dot(n);
    let denom = vs.length().max(AZIMUTH_EPSILON) * ls.length().max(AZIMUTH_EPSILON);
    (vs.dot(ls) / denom).clamp(-1.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn cos_between_matches_the_direct_angle_for_any_lengths() {
        let a = DVec3::new(3.0, 0.0, 0.0);
        let b = DVec3::new(0.5, 0.5, 0.0);
        assert!((cos_between(a, b) - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-12);
        assert_eq!(cos_between(a, -a), -1.0);
    }

    #[test]
    fn zero_or_nan_vectors_give_zero() {
        assert_eq!(cos_between(DVec3::ZERO, DVec3::X), 0.0);
        assert_eq!(cos_between(DVec3::NAN, DVec3::X), 0.0);
        assert_eq!(cos_vl(DVec3::ZERO, DVec3::X, DVec3::Y), 0.0);
        assert_eq!(cos_vl(DVec3::Z, DVec3::INFINITY, DVec3::Y), 0.0);
    }

    #[test]
    fn cos_vl_is_the_cosine_of_the_azimuth_between_projections() {
        // V at azimuth 0, L at azimuth 60 degrees, both 45 degrees from N.
        let n = DVec3::Z;
        let v = DVec3::new(1.0, 0.0, 1.0);
        let phi = 60f64.to_radians();
        let l = DVec3::new(phi.cos(), phi.sin(), 1.0) * 7.0;
        assert!((cos_vl(n, v, l) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn cos_vl_at_the_pole_is_zero_and_fades_continuously() {
        let n = DVec3::Z;
        let l = DVec3::new(1.0, 0.0, 1.0);
        assert_eq!(cos_vl(n, n, l), 0.0);
        assert_eq!(cos_vl(n, l, n * 2.0), 0.0);
        // Approaching the pole along the azimuth of L: the exact value is 1
        // until the projection drops below the epsilon, then fades to 0.
        let at = |s: f64| cos_vl(n, DVec3::new(s, 0.0, (1.0 - s * s).sqrt()), l);
        assert!((at(2.0 * AZIMUTH_EPSILON) - 1.0).abs() < 1e-9);
        assert!((at(0.5 * AZIMUTH_EPSILON) - 0.5).abs() < 1e-6);
        assert!(at(1e-9).abs() < 1e-4);
    }

    proptest! {
        #[test]
        fn cosines_are_finite_and_bounded(
            n in prop::array::uniform3(-1e3f64..1e3),
            v in prop::array::uniform3(-1e3f64..1e3),
            l in prop::array::uniform3(-1e3f64..1e3),
        ) {
            let (n, v, l) = (DVec3::from(n), DVec3::from(v), DVec3::from(l));
            for c in [cos_between(n, l), cos_between(n, v), cos_vl(n, v, l), cos_vl(n, n, l)] {
                prop_assert!(c.is_finite() && (-1.0..=1.0).contains(&c));
            }
        }

        #[test]
        fn cos_vl_is_continuous_near_the_pole(
            theta in 0f64..1e-3, phi in 0f64..6.3, dtheta in -1e-7f64..1e-7,
        ) {
            let n = DVec3::Z;
            let l = DVec3::new(0.6, 0.0, 0.8);
            let dir = |t: f64| DVec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos());
            let a = cos_vl(n, dir(theta), l);
            let b = cos_vl(n, dir((theta + dtheta).abs()), l);
            // Lipschitz bound: slope of the fade is at most 1/e per radian.
            prop_assert!((a - b).abs() <= dtheta.abs() / AZIMUTH_EPSILON * 1.01 + 1e-12);
        }
    }
}
