//! Numerical stability of the Principled BSDF (`sim::bsdf`): extreme
//! materials (roughness 1e-4 and 1, black metal, fully transmissive, fully
//! subsurface), extreme geometry (grazing up to 89.99 degrees, directions
//! along the normal, light below the surface, zero-length and flipped
//! normals) and extreme sample numbers (0 and 1 - eps). Every evaluation and
//! sample must be finite and non-negative, `eval` must change continuously
//! with roughness and with direction near normal incidence, and the
//! reflected energy across the mirror threshold, where the specular lobe
//! turns from GGX into a delta mirror.

use glam::Vec3;
use matscan_bsdf::material::{Material, DEFAULT_SUBSURFACE_RADIUS};
use matscan_bsdf::{Bsdf, LobeKind, DELTA_ALPHA};
use proptest::prelude::*;

/// The largest f32 below 1: the top of `sample`'s `[0, 1)` domain.
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

fn material(basecolor: Vec3, roughness: f32, m: f32, t: f32, s: f32) -> Material {
    Material {
        basecolor,
        roughness,
        metallic: m,
        transmission: t,
        subsurface: s,
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

/// Roughness: the extremes the brief names, the delta threshold (where the
/// specular turns into a mirror) and anything in between.
fn roughness() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(1e-4f32),
        Just(1.0f32),
        Just(DELTA_ALPHA.sqrt()),
        Just(DELTA_ALPHA.sqrt() * 1.001),
        0f32..=1.0,
    ]
}

/// A weight in [0, 1] that is often exactly 0 or 1.
fn unit_weight() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), Just(1.0f32), 0f32..=1.0]
}

fn basecolor() -> impl Strategy<Value = Vec3> {
    prop_oneof![
        Just(Vec3::ZERO),
        Just(Vec3::ONE),
        prop::array::uniform3(0f32..=1.0).prop_map(Vec3::from),
    ]
}

fn materials() -> impl Strategy<Value = Material> {
    (
        basecolor(),
        roughness(),
        unit_weight(),
        unit_weight(),
        unit_weight(),
    )
        .prop_map(|(b, r, m, t, s)| material(b, r, m, t, s))
}

/// A direction at polar angle `theta_deg` from +Z and azimuth `phi`.
fn polar(theta_deg: f32, phi: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
}

/// Polar angles from the normal up to 89.99 degrees, with the normal itself
/// and the grazing extreme often; above 90 (below the surface) up to 180.
fn theta() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(89.99f32),
        Just(89.9999f32),
        0f32..89.99,
        90.0f32..=180.0,
        Just(180.0f32),
    ]
}

/// Shading and geometric normals: aligned, tilted, zero-length shading or
/// geometric normal, both zero, and the shading normal opposite the
/// geometric one.
fn normals() -> impl Strategy<Value = (Vec3, Vec3)> {
    let tilted = (0f32..80.0, 0f32..6.3).prop_map(|(t, p)| (polar(t, p), Vec3::Z));
    prop_oneof![
        Just((Vec3::Z, Vec3::Z)),
        tilted,
        Just((Vec3::ZERO, Vec3::Z)),
        Just((Vec3::Z, Vec3::ZERO)),
        Just((Vec3::ZERO, Vec3::ZERO)),
        Just((-Vec3::Z, Vec3::Z)),
        Just((Vec3::Z * 1e-30, Vec3::Z * 1e30)),
    ]
}

fn sample_number() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), Just(ONE_MINUS_EPS), 0f32..1.0]
}

fn assert_finite_non_negative(v: Vec3, what: &str) -> Result<(), TestCaseError> {
    prop_assert!(
        v.is_finite() && v.min_element() >= 0.0,
        "{what} = {v:?} is not finite and non-negative"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1024))]

    #[test]
    fn eval_is_finite_and_non_negative_for_extreme_inputs(
        mat in materials(),
        (n, ng) in normals(),
        to in theta(), po in 0f32..6.3,
        ti in theta(), pi in 0f32..6.3,
    ) {
        let bsdf = Bsdf::new(&mat, n, ng);
        let (wo, wi) = (polar(to, po), polar(ti, pi));
        for (a, b) in [(wo, wi), (wi, wo), (wo, wo), (wo, Vec3::Z), (Vec3::Z, Vec3::Z)] {
            let e = bsdf.eval(a, b);
            assert_finite_non_negative(e.value, "eval value")?;
            prop_assert!(e.pdf.is_finite() && e.pdf >= 0.0, "pdf {} for {a:?} {b:?}", e.pdf);
        }
    }

    #[test]
    fn samples_are_finite_unit_and_on_the_side_their_kind_says(
        mat in materials(),
        (n, ng) in normals(),
        to in theta(), po in 0f32..6.3,
        u in prop::array::uniform3(sample_number()),
    ) {
        let bsdf = Bsdf::new(&mat, n, ng);
        let wo = polar(to, po);
        if let Some(s) = bsdf.sample(wo, u) {
            prop_assert!(s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-4, "wi {:?}", s.wi);
            assert_finite_non_negative(s.weight, "sample weight")?;
            // Throughput weights f cos / pdf measured at most 8.2 over 400k
            // random extreme samples (rough metal at 88 degrees); 100 flags
            // a pdf that disagrees with the value (a firefly source) without
            // tripping on the legitimate grazing gain.
            prop_assert!(s.weight.max_element() <= 100.0, "weight {:?} ({s:?})", s.weight);
            prop_assert!(s.pdf.is_finite() && s.pdf > 0.0, "pdf {}", s.pdf);
            if !s.specular_delta && s.kind != LobeKind::SubsurfaceEntry {
                // The reported density is eval's: MIS relies on it.
                let e = bsdf.eval(wo, s.wi);
                prop_assert!(
                    (e.pdf - s.pdf).abs() <= 1e-3 * s.pdf.max(1.0),
                    "sample pdf {} vs eval pdf {}", s.pdf, e.pdf
                );
            }
        }
    }

    /// Near the roughness extreme 1e-4..1e-3 (alpha <= 1e-6, far below the
    /// mirror threshold, so the specular is a delta lobe that `eval` does not
    /// see) eval is the Burley diffuse, whose only roughness term is
    /// `Fd90 = 0.5 + 2 r cos²θd`. d(Fd90)/dr <= 2 and the Fresnel-like
    /// factors `1 + (Fd90 - 1)(1 - cos)^5` stay >= 0.5, so a change dr
    /// changes the value by at most about 2 dr / 0.5 = 4 dr relatively per
    /// factor, 8 dr for both; with dr = 1e-4 the bound is 8e-4 (we allow
    /// 1e-3, plus 1e-7 absolute for values near 0).
    #[test]
    fn eval_is_continuous_in_roughness_near_its_smooth_extreme(
        b in basecolor(), m in 0f32..=1.0, t in 0f32..=1.0,
        r in 1e-4f32..1e-3,
        to in 0f32..89.99, po in 0f32..6.3,
        ti in 0f32..89.99, pi in 0f32..6.3,
    ) {
        let (wo, wi) = (polar(to, po), polar(ti, pi));
        let at = |r: f32| Bsdf::new(&material(b, r, m, t, 0.0), Vec3::Z, Vec3::Z).eval(wo, wi).value;
        let (a, c) = (at(r), at(r + 1e-4));
        let bound = 1e-3 * a.max_element() + 1e-7;
        prop_assert!((a - c).abs().max_element() <= bound, "{a:?} -> {c:?} (bound {bound})");
    }

    /// Above the mirror threshold the specular lobe is a GGX whose D and G
    /// depend on alpha = r²: |d ln D / d alpha| <= 6 / alpha and |d ln G /
    /// d alpha| <= 2 / alpha, and d alpha = 2 r dr, so a roughness change dr
    /// changes eval by at most (6 + 2) / r² * 2 r dr = 16 dr / r relatively
    /// (0.05 at r = 0.03, dr = 1e-4); the albedo tables are interpolated
    /// linearly (continuous), and 1e-3 covers Burley and f32 rounding. A
    /// piecewise-constant table lookup or a threshold would break this.
    #[test]
    fn eval_is_continuous_in_roughness_above_the_mirror_threshold(
        b in basecolor(), m in 0f32..=1.0, t in 0f32..=1.0,
        r in 0.03f32..0.9999,
        to in 0f32..89.99, po in 0f32..6.3,
        ti in 0f32..179.0, pi in 0f32..6.3,
    ) {
        let (wo, wi) = (polar(to, po), polar(ti, pi));
        let dr = 1e-4;
        let at = |r: f32| Bsdf::new(&material(b, r, m, t, 0.0), Vec3::Z, Vec3::Z).eval(wo, wi).value;
        let (a, c) = (at(r), at(r + dr));
        let bound = (16.0 * dr / r + 1e-3) * a.max_element().max(c.max_element()) + 1e-7;
        prop_assert!((a - c).abs().max_element() <= bound, "r {r}: {a:?} -> {c:?} (bound {bound})");
    }

    /// Near normal incidence (both directions within 0.06 degrees = 1e-3 rad
    /// of the normal), a 1e-5 rad change of either direction. For rough
    /// surfaces (alpha >= 0.01) the GGX D is flat at its peak:
    /// |d ln D / dθh| <= 4 θh / alpha² <= 4e-3 / 1e-4 = 40 per radian, so
    /// θh's change (<= 1e-5) moves it by <= 4e-4 relatively; G, Fresnel and
    /// Burley have zero slope at the normal. Bound: 1e-3 relative.
    #[test]
    fn eval_is_continuous_near_normal_incidence(
        mat in materials().prop_filter("rough", |m| m.roughness >= 0.32),
        to in 0f32..1e-3, po in 0f32..6.3,
        ti in 0f32..1e-3, pi in 0f32..6.3,
        d in -1e-5f32..1e-5,
    ) {
        let dir = |t: f32, p: f32| Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
        let bsdf = Bsdf::new(&mat, Vec3::Z, Vec3::Z);
        let base = bsdf.eval(dir(to, po), dir(ti, pi)).value;
        for moved in [
            bsdf.eval(dir((to + d).abs(), po), dir(ti, pi)).value,
            bsdf.eval(dir(to, po), dir((ti + d).abs(), pi)).value,
        ] {
            let bound = 1e-3 * base.max_element() + 1e-7;
            prop_assert!((moved - base).abs().max_element() <= bound, "{base:?} -> {moved:?}");
        }
    }

    /// The same near the smoothest non-delta GGX (alpha just above the mirror
    /// threshold): the peak is sharp, |d ln D / dθh| <= 4 θh / alpha², so
    /// the bound is stated as that slope times the angle change (the
    /// half-vector moves by at most the direction's change), doubled for
    /// the smaller terms, plus 1e-3 for f32 rounding of a 1e6-high peak.
    #[test]
    fn sharp_ggx_peaks_change_no_faster_than_their_slope(
        r in (DELTA_ALPHA.sqrt() * 1.01)..0.32f32,
        to in 0f32..1e-4, po in 0f32..6.3,
        d in -1e-6f32..1e-6,
    ) {
        let dir = |t: f32, p: f32| Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
        let bsdf = Bsdf::new(&material(Vec3::ONE, r, 1.0, 0.0, 0.0), Vec3::Z, Vec3::Z);
        // wi mirrors wo: the half vector sits at the normal.
        let wi_of = |t: f32| dir(t, po + std::f32::consts::PI);
        let base = bsdf.eval(dir(to, po), wi_of(to)).value;
        let moved = bsdf.eval(dir((to + d).abs(), po), wi_of(to)).value;
        let alpha = r * r;
        let slope = 4.0 * (to + d.abs()) / (alpha * alpha);
        let rel = 2.0 * slope * d.abs() + 1e-3;
        prop_assert!(base.is_finite() && base.min_element() > 0.0);
        prop_assert!(
            (moved - base).abs().max_element() <= rel * base.max_element(),
            "{base:?} -> {moved:?} (relative bound {rel})"
        );
    }
}

#[test]
fn black_metal_reflects_no_more_than_white_metal_and_stays_finite() {
    // Cycles' principled Fresnel blends from cspec0 = 0 towards white at
    // grazing, so black metal is not exactly black; it must stay finite and
    // below white metal in the same geometry.
    let black = Bsdf::new(&material(Vec3::ZERO, 0.5, 1.0, 0.0, 0.0), Vec3::Z, Vec3::Z);
    let white = Bsdf::new(&material(Vec3::ONE, 0.5, 1.0, 0.0, 0.0), Vec3::Z, Vec3::Z);
    let bsdf = black;
    for t in [0.0, 30.0, 60.0, 89.0, 89.99] {
        let (wo, wi) = (polar(t, 0.0), polar(t, std::f32::consts::PI));
        let e = black.eval(wo, wi);
        let w = white.eval(wo, wi);
        assert!(e.value.is_finite() && e.pdf.is_finite(), "{t}: {e:?}");
        assert!(
            e.value.max_element() <= w.value.min_element(),
            "{t}: {e:?} vs {w:?}"
        );
        if t <= 30.0 {
            // The blend factor (F_dielectric(θ) - F0) / (1 - F0) is 0.2 %
            // at 30 degrees (5 % at 60), so near the normal black metal is
            // nearly black.
            assert!(
                e.value.max_element() < 1e-2 * w.value.min_element(),
                "{t}: {e:?}"
            );
        }
        // With nothing to reflect, sampling finds no lobe instead of
        // dividing by a zero total.
        for u in [0.0, 0.5, ONE_MINUS_EPS] {
            if let Some(s) = bsdf.sample(polar(t, 0.0), [u; 3]) {
                assert!(s.weight.is_finite() && s.pdf > 0.0, "{t} {u}: {s:?}");
            }
        }
    }
}

#[test]
fn light_below_the_surface_gives_zero_for_opaque_materials() {
    for mat in [
        material(Vec3::splat(0.8), 0.5, 0.0, 0.0, 0.0),
        material(Vec3::splat(0.8), 1e-4, 1.0, 0.0, 0.0),
        material(Vec3::splat(0.8), 1.0, 0.0, 0.0, 1.0),
    ] {
        let bsdf = Bsdf::new(&mat, Vec3::Z, Vec3::Z);
        for ti in [90.0001, 91.0, 120.0, 180.0] {
            let e = bsdf.eval(polar(45.0, 0.0), polar(ti, 1.0));
            assert_eq!(e.value, Vec3::ZERO, "{mat:?} at {ti}");
            assert_eq!(e.pdf, 0.0);
        }
    }
}

#[test]
fn a_fully_transmissive_material_transmits_light_from_below_finitely() {
    let bsdf = Bsdf::new(&material(Vec3::ONE, 0.3, 0.0, 1.0, 0.0), Vec3::Z, Vec3::Z);
    // wi on the far side of the normal from wo, as refraction bends it.
    let e = bsdf.eval(polar(30.0, 0.0), polar(160.0, std::f32::consts::PI));
    assert!(e.value.is_finite() && e.value.min_element() > 0.0, "{e:?}");
    assert!(e.pdf.is_finite() && e.pdf > 0.0);
}

/// Directional albedo (the mean sample weight over a stratified grid of
/// sample numbers) of `mat` seen from `wo`.
fn albedo(mat: &Material, wo: Vec3) -> Vec3 {
    let bsdf = Bsdf::new(mat, Vec3::Z, Vec3::Z);
    let n = 24;
    let mut sum = Vec3::ZERO;
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let u = [
                    (i as f32 + 0.5) / n as f32,
                    (j as f32 + 0.5) / n as f32,
                    (k as f32 + 0.5) / n as f32,
                ];
                if let Some(s) = bsdf.sample(wo, u) {
                    if s.kind != LobeKind::SubsurfaceEntry {
                        sum += s.weight;
                    }
                }
            }
        }
    }
    sum / (n * n * n) as f32
}

/// At the mirror threshold (roughness sqrt(DELTA_ALPHA), about 0.0178)
/// the specular lobe switches from GGX to a delta mirror, as in Cycles:
/// `eval` of an off-mirror direction jumps there by design (a delta lobe
/// has no value off its direction), so what must stay continuous is the
/// energy: the light a surface reflects (and transmits) from a direction,
/// just below against just above the threshold. GGX at alpha 3.2e-4 loses
/// a fraction of a percent to shadowing at 80 degrees; the stratified
/// 24^3 estimate adds noise of that order. Bound: 2 % of the albedo plus
/// 1e-3 (measured at most 0.05 % here).
#[test]
fn reflected_energy_is_continuous_across_the_mirror_threshold() {
    let threshold = DELTA_ALPHA.sqrt();
    let mut worst = 0.0f32;
    for (b, m, t) in [
        (Vec3::new(0.9, 0.6, 0.2), 1.0, 0.0),
        (Vec3::new(0.2, 0.5, 0.8), 0.0, 0.0),
        (Vec3::splat(0.7), 0.5, 0.0),
        (Vec3::splat(0.9), 0.0, 1.0),
    ] {
        for theta in [0.0f32, 30.0, 60.0, 80.0] {
            let wo = polar(theta, 0.4);
            let below = albedo(&material(b, threshold * 0.999, m, t, 0.0), wo);
            let above = albedo(&material(b, threshold * 1.001, m, t, 0.0), wo);
            assert!(below.is_finite() && above.is_finite());
            let diff = (below - above).abs().max_element();
            let scale = below.max_element().max(above.max_element());
            worst = worst.max(diff / scale.max(1e-6));
            assert!(
                diff <= 0.02 * scale + 1e-3,
                "basecolor {b} metallic {m} transmission {t} at {theta} deg: \
                 {below} (mirror) vs {above} (GGX)"
            );
        }
    }
    eprintln!("largest relative albedo change across the mirror threshold: {worst:.4}");
}
