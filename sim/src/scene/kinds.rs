//! Scene kinds: how the object's material is authored, after the dataset
//! variants of thesis section 3.1.7.
//!
//! - `multimat`: every parameter its own random map (3.1.3.1): basecolor one
//!   mixed map per channel, roughness a mixed map, metallic a binary map
//!   (the thesis takes a material as metallic or not), transmission and
//!   subsurface mixed maps multiplied by a binary map so that part of the
//!   object has neither.
//! - `multimat-noenv`: the same materials without the environment (the
//!   thesis used a constant grey; the simulator's `EnvSource::None`).
//! - `2mat`: two random, spatially constant materials divided by one binary
//!   map.
//! - `2mat-transmission`: as `2mat`, but the first material is non-metallic
//!   with transmission present, so that transparency (and subsurface) shows
//!   far more often.
//! - `3mat`: `2mat` with the second material split again by a second binary
//!   map; the two parts differ in basecolor, roughness and metallic and share
//!   transmission and subsurface (as the thesis describes it).
//! - `realworld`: wood, stone, fabric or painted metal in turn by seed, as
//!   the thesis's "textureheaven" set (`super::realworld`); never drawn for
//!   training (a held-out material kind).
//! - `sweep-*` (the thesis's "predefined" datasets): spatially constant
//!   materials that step through one parameter across scenes while the rest
//!   stay fixed; the step is `seed % sweep_len`, so seeds 0..len enumerate the
//!   sweep:
//!   - `sweep-subsurface`: subsurface 0..1 in 20 steps; basecolor grey 0.5,
//!     roughness 0.5, not metallic, no transmission (the thesis's "reasonable
//!     average").
//!   - `sweep-basecolor`: HSV grid of 20 hues x 20 saturations (0..1) x
//!     values {0.33, 0.66, 0.99} = 1200 colours; roughness 0.5, dielectric,
//!     no transmission or subsurface.
//!   - `sweep-roughness`: roughness 0..1 in 40 steps (the thesis made 40
//!     scenes per version) for six versions: metallic and dielectric (without
//!     subsurface and transmission), each with white (1.0), grey (0.5) and
//!     black (0.0) basecolor; index = version * 40 + step.
//!
//! Random constant materials (`2mat`, `3mat`) draw basecolor uniformly per
//! channel and roughness uniformly; metallic is 0 or 1 (1 with chance 0.35);
//! transmission is present with chance 0.25 and subsurface with chance 0.3,
//! each then uniform in 0.2..1. The subsurface radius is the default (1, 1,
//! 1) everywhere. Boundaries: materials only; maps come from `super::maps`.

use super::color::hsv_to_rgb;
use super::maps::{binary_map, color_map, masked_map, mixed_map};
use super::model::{MaterialField, SceneError, Texture};
use glam::Vec3;
use matscan_bsdf::material::{Material, DEFAULT_SUBSURFACE_RADIUS};
use matscan_scan::Raster;
use rand::Rng;
use rand_pcg::Pcg64;
use std::fmt;
use std::str::FromStr;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SceneKind {
    Multimat,
    MultimatNoEnv,
    TwoMat,
    TwoMatTransmission,
    ThreeMat,
    SweepSubsurface,
    SweepBasecolor,
    SweepRoughness,
    RealWorld,
}

const SUBSURFACE_STEPS: u64 = 20;
const HUE_STEPS: u64 = 20;
const SATURATION_STEPS: u64 = 20;
const BASECOLOR_VALUES: [f32; 3] = [0.33, 0.66, 0.99];
const ROUGHNESS_STEPS: u64 = 40;
/// Basecolor of the roughness sweep versions: white, grey, black.
const ROUGHNESS_BASECOLORS: [f32; 3] = [1.0, 0.5, 0.0];

impl SceneKind {
    pub const ALL: [SceneKind; 9] = [
        SceneKind::Multimat,
        SceneKind::MultimatNoEnv,
        SceneKind::TwoMat,
        SceneKind::TwoMatTransmission,
        SceneKind::ThreeMat,
        SceneKind::SweepSubsurface,
        SceneKind::SweepBasecolor,
        SceneKind::SweepRoughness,
        SceneKind::RealWorld,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Multimat => "multimat",
            SceneKind::MultimatNoEnv => "multimat-noenv",
            SceneKind::TwoMat => "2mat",
            SceneKind::TwoMatTransmission => "2mat-transmission",
            SceneKind::ThreeMat => "3mat",
            SceneKind::SweepSubsurface => "sweep-subsurface",
            SceneKind::SweepBasecolor => "sweep-basecolor",
            SceneKind::SweepRoughness => "sweep-roughness",
            SceneKind::RealWorld => "realworld",
        }
    }

    /// Whether the scene has ambient light from an environment.
    pub fn has_environment(self) -> bool {
        self != SceneKind::MultimatNoEnv
    }

    /// Number of distinct scenes in a sweep kind (seeds beyond it repeat the
    /// materials with new geometry and rig); `None` for random kinds.
    pub fn sweep_len(self) -> Option<u64> {
        match self {
            SceneKind::SweepSubsurface => Some(SUBSURFACE_STEPS),
            SceneKind::SweepBasecolor => {
                Some(HUE_STEPS * SATURATION_STEPS * BASECOLOR_VALUES.len() as u64)
            }
            SceneKind::SweepRoughness => {
                Some(2 * ROUGHNESS_BASECOLORS.len() as u64 * ROUGHNESS_STEPS)
            }
            _ => None,
        }
    }

    /// The material of sweep step `index` (taken modulo the sweep length);
    /// `None` for random kinds.
    pub fn sweep_material(self, index: u64) -> Option<Material> {
        let i = index % self.sweep_len()?;
        let base = Material {
            basecolor: Vec3::splat(0.5),
            roughness: 0.5,
            metallic: 0.0,
            transmission: 0.0,
            subsurface: 0.0,
            subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
        };
        let step = |k: u64, n: u64| k as f32 / (n - 1) as f32;
        Some(match self {
            SceneKind::SweepSubsurface => Material {
                subsurface: step(i, SUBSURFACE_STEPS),
                ..base
            },
            SceneKind::SweepBasecolor => {
                let hue = (i % HUE_STEPS) as f32 / HUE_STEPS as f32;
                let sat = step((i / HUE_STEPS) % SATURATION_STEPS, SATURATION_STEPS);
                let value = BASECOLOR_VALUES[(i / (HUE_STEPS * SATURATION_STEPS)) as usize % 3];
                Material {
                    basecolor: hsv_to_rgb(hue, sat, value),
                    ..base
                }
            }
            _ => {
                let version = (i / ROUGHNESS_STEPS) as usize;
                let grey = ROUGHNESS_BASECOLORS[version % ROUGHNESS_BASECOLORS.len()];
                Material {
                    basecolor: Vec3::splat(grey),
                    roughness: step(i % ROUGHNESS_STEPS, ROUGHNESS_STEPS),
                    metallic: if version < ROUGHNESS_BASECOLORS.len() {
                        1.0
                    } else {
                        0.0
                    },
                    ..base
                }
            }
        })
    }

    /// The authored material of a scene of this kind: random kinds draw from
    /// `rng` with maps of `map_size` texels square; sweeps take step
    /// `seed % sweep_len`.
    pub fn material(self, rng: &mut Pcg64, seed: u64, map_size: u32) -> MaterialField {
        if let Some(m) = self.sweep_material(seed) {
            return MaterialField::uniform(&m);
        }
        match self {
            SceneKind::RealWorld => super::realworld::material(rng, seed, map_size),
            SceneKind::TwoMat => {
                let labels = labels_from(&binary_map(rng, map_size), None);
                let a = random_material(rng);
                let b = random_material(rng);
                field_by_label(&labels, &[a, b])
            }
            SceneKind::TwoMatTransmission => {
                let labels = labels_from(&binary_map(rng, map_size), None);
                let a = Material {
                    metallic: 0.0,
                    transmission: rng.gen_range(0.3..=1.0),
                    ..random_material(rng)
                };
                let b = random_material(rng);
                field_by_label(&labels, &[a, b])
            }
            SceneKind::ThreeMat => {
                let first = binary_map(rng, map_size);
                let split = binary_map(rng, map_size);
                let labels = labels_from(&first, Some(&split));
                let a = random_material(rng);
                let b1 = random_material(rng);
                let other = random_material(rng);
                let b2 = Material {
                    basecolor: other.basecolor,
                    roughness: other.roughness,
                    metallic: other.metallic,
                    ..b1
                };
                field_by_label(&labels, &[a, b1, b2])
            }
            _ => MaterialField {
                basecolor: Texture::Map(color_map(rng, map_size)),
                roughness: Texture::Map(mixed_map(rng, map_size)),
                metallic: Texture::Map(binary_map(rng, map_size)),
                transmission: Texture::Map(masked_map(rng, map_size)),
                subsurface: Texture::Map(masked_map(rng, map_size)),
                subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
            },
        }
    }
}

impl fmt::Display for SceneKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SceneKind {
    type Err = SceneError;

    fn from_str(s: &str) -> Result<Self, SceneError> {
        SceneKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| SceneError::UnknownKind {
                name: s.to_string(),
                expected: SceneKind::ALL.map(SceneKind::name).join(", "),
            })
    }
}

/// A random, spatially constant material (see the module docs for the
/// distributions).
pub fn random_material(rng: &mut Pcg64) -> Material {
    let basecolor = Vec3::new(rng.gen(), rng.gen(), rng.gen());
    let roughness = rng.gen();
    let metallic = if rng.gen_bool(0.35) { 1.0 } else { 0.0 };
    let transmission = if rng.gen_bool(0.25) {
        rng.gen_range(0.2..=1.0)
    } else {
        0.0
    };
    let subsurface = if rng.gen_bool(0.3) {
        rng.gen_range(0.2..=1.0)
    } else {
        0.0
    };
    Material {
        basecolor,
        roughness,
        metallic,
        transmission,
        subsurface,
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

/// Region labels: 0 where `first` is set; elsewhere 1 where `split` is set
/// (or everywhere without a split), else 2.
fn labels_from(first: &Raster<f32>, split: Option<&Raster<f32>>) -> Raster<u8> {
    Raster::from_fn(first.width, first.height, |x, y| {
        if *first.get(x, y) >= 0.5 {
            0
        } else if split.is_none_or(|s| *s.get(x, y) >= 0.5) {
            1
        } else {
            2
        }
    })
}

/// Per-parameter textures picking `materials[label]`; a parameter equal in
/// every used material becomes a constant.
fn field_by_label(labels: &Raster<u8>, materials: &[Material]) -> MaterialField {
    let used: Vec<usize> = {
        let mut u: Vec<usize> = labels.data.iter().map(|&l| l as usize).collect();
        u.sort_unstable();
        u.dedup();
        u.retain(|&l| l < materials.len());
        u
    };
    fn texture<T: Copy + PartialEq + Default>(
        labels: &Raster<u8>,
        used: &[usize],
        value: impl Fn(usize) -> T,
    ) -> Texture<T> {
        let first = used.first().map_or(T::default(), |&l| value(l));
        if used.iter().all(|&l| value(l) == first) {
            return Texture::Constant(first);
        }
        Texture::Map(labels.map(|&l| value(l as usize)))
    }
    let m = |l: usize| materials.get(l).copied().unwrap_or(Material::WHITE_DIFFUSE);
    MaterialField {
        basecolor: texture(labels, &used, |l| m(l).basecolor.to_array()),
        roughness: texture(labels, &used, |l| m(l).roughness),
        metallic: texture(labels, &used, |l| m(l).metallic),
        transmission: texture(labels, &used, |l| m(l).transmission),
        subsurface: texture(labels, &used, |l| m(l).subsurface),
        subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    const N: u32 = 64;

    fn rng(seed: u64) -> Pcg64 {
        Pcg64::seed_from_u64(seed)
    }

    fn texel<T: Copy>(t: &Texture<T>, i: usize) -> T {
        match t {
            Texture::Constant(v) => *v,
            Texture::Map(r) => r.data[i],
        }
    }

    /// The distinct (basecolor, roughness, metallic, transmission,
    /// subsurface) tuples over all texels.
    fn distinct_materials(f: &MaterialField) -> Vec<[u32; 7]> {
        let mut out: Vec<[u32; 7]> = (0..(N * N) as usize)
            .map(|i| {
                let c = texel(&f.basecolor, i);
                [
                    c[0].to_bits(),
                    c[1].to_bits(),
                    c[2].to_bits(),
                    texel(&f.roughness, i).to_bits(),
                    texel(&f.metallic, i).to_bits(),
                    texel(&f.transmission, i).to_bits(),
                    texel(&f.subsurface, i).to_bits(),
                ]
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn map_of(t: &Texture<f32>) -> &Raster<f32> {
        match t {
            Texture::Map(r) => r,
            Texture::Constant(_) => panic!("expected a map"),
        }
    }

    #[test]
    fn kind_names_round_trip_and_unknown_names_are_rejected() {
        for kind in SceneKind::ALL {
            assert_eq!(kind.to_string().parse::<SceneKind>(), Ok(kind));
        }
        assert_eq!(SceneKind::TwoMat.to_string(), "2mat");
        assert!("4mat".parse::<SceneKind>().is_err());
        assert!(!SceneKind::MultimatNoEnv.has_environment());
        assert!(SceneKind::Multimat.has_environment());
    }

    #[test]
    fn multimat_gives_every_parameter_its_own_map() {
        for seed in 0..4 {
            let f = SceneKind::Multimat.material(&mut rng(seed), seed, N);
            let metallic = map_of(&f.metallic);
            assert!(metallic.data.iter().all(|&v| v == 0.0 || v == 1.0));
            let metal_share = metallic.data.iter().sum::<f32>() / metallic.data.len() as f32;
            assert!((0.1..0.9).contains(&metal_share), "{metal_share}");
            let rough = map_of(&f.roughness);
            let (lo, hi) = rough
                .data
                .iter()
                .fold((1.0f32, 0.0f32), |(a, b), &v| (a.min(v), b.max(v)));
            assert!(hi - lo > 0.5, "roughness spans {lo}..{hi}");
            for t in [&f.transmission, &f.subsurface] {
                let m = map_of(t);
                let zero =
                    m.data.iter().filter(|&&v| v == 0.0).count() as f32 / m.data.len() as f32;
                assert!((0.1..0.9).contains(&zero), "zero share {zero}");
            }
            assert_ne!(f.transmission, f.subsurface);
            let Texture::Map(c) = &f.basecolor else {
                panic!("constant basecolor")
            };
            assert!(c.data.iter().any(|p| (p[0] - p[1]).abs() > 0.2));
        }
    }

    #[test]
    fn two_mat_has_exactly_two_materials_split_by_a_mask() {
        for seed in 0..6 {
            let f = SceneKind::TwoMat.material(&mut rng(seed), seed, N);
            let d = distinct_materials(&f);
            assert_eq!(d.len(), 2, "seed {seed}");
            assert!(d
                .iter()
                .all(|m| m[4] == 0f32.to_bits() || m[4] == 1f32.to_bits()));
        }
    }

    #[test]
    fn two_mat_transmission_has_a_transmissive_dielectric() {
        for seed in 0..6 {
            let f = SceneKind::TwoMatTransmission.material(&mut rng(seed), seed, N);
            let d = distinct_materials(&f);
            assert_eq!(d.len(), 2, "seed {seed}");
            assert!(d
                .iter()
                .any(|m| f32::from_bits(m[4]) == 0.0 && f32::from_bits(m[5]) >= 0.3));
        }
    }

    #[test]
    fn three_mat_splits_the_second_material_in_colour_roughness_and_metallic() {
        for seed in 0..6 {
            let f = SceneKind::ThreeMat.material(&mut rng(seed), seed, N);
            let d = distinct_materials(&f);
            assert_eq!(d.len(), 3, "seed {seed}");
            // Two of the three share transmission and subsurface.
            let shared = (0..3).any(|i| (i + 1..3).any(|j| d[i][5..] == d[j][5..]));
            assert!(shared, "seed {seed}: {d:?}");
        }
    }

    #[test]
    fn sweeps_are_constant_and_step_through_their_parameter() {
        let sub: Vec<f32> = (0..20)
            .map(|s| {
                SceneKind::SweepSubsurface
                    .sweep_material(s)
                    .unwrap()
                    .subsurface
            })
            .collect();
        assert_eq!(sub[0], 0.0);
        assert_eq!(sub[19], 1.0);
        assert!(sub.windows(2).all(|w| w[1] > w[0]));
        let f = SceneKind::SweepSubsurface.material(&mut rng(0), 7, N);
        assert_eq!(f.subsurface, Texture::Constant(7.0 / 19.0));
        assert_eq!(f.roughness, Texture::Constant(0.5));

        let n = SceneKind::SweepBasecolor.sweep_len().unwrap();
        assert_eq!(n, 1200);
        let mut colours: Vec<[u32; 3]> = (0..n)
            .map(|i| {
                let m = SceneKind::SweepBasecolor.sweep_material(i).unwrap();
                assert_eq!((m.metallic, m.transmission, m.subsurface), (0.0, 0.0, 0.0));
                m.basecolor.to_array().map(f32::to_bits)
            })
            .collect();
        colours.sort_unstable();
        colours.dedup();
        // Zero saturation makes the 20 hues of a value one grey.
        assert_eq!(colours.len(), 1200 - 3 * 19);

        let r = SceneKind::SweepRoughness;
        assert_eq!(r.sweep_len(), Some(240));
        let white_metal_rough = r.sweep_material(39).unwrap();
        assert_eq!(
            (white_metal_rough.metallic, white_metal_rough.roughness),
            (1.0, 1.0)
        );
        assert_eq!(white_metal_rough.basecolor, Vec3::ONE);
        let black_dielectric_smooth = r.sweep_material(200).unwrap();
        assert_eq!(black_dielectric_smooth.metallic, 0.0);
        assert_eq!(black_dielectric_smooth.roughness, 0.0);
        assert_eq!(black_dielectric_smooth.basecolor, Vec3::ZERO);
        assert_eq!(r.sweep_material(240), r.sweep_material(0));
        assert_eq!(SceneKind::TwoMat.sweep_material(3), None);
    }

    #[test]
    fn random_materials_are_metallic_or_not_with_plausible_shares() {
        let mut r = rng(1);
        let ms: Vec<Material> = (0..2000).map(|_| random_material(&mut r)).collect();
        assert!(ms.iter().all(|m| m.metallic == 0.0 || m.metallic == 1.0));
        let share =
            |f: &dyn Fn(&Material) -> bool| ms.iter().filter(|m| f(m)).count() as f32 / 2000.0;
        assert!((0.3..0.4).contains(&share(&|m| m.metallic == 1.0)));
        assert!((0.2..0.3).contains(&share(&|m| m.transmission > 0.0)));
        assert!((0.25..0.35).contains(&share(&|m| m.subsurface > 0.0)));
    }

    #[test]
    fn materials_are_deterministic_per_seed() {
        for kind in SceneKind::ALL {
            let a = kind.material(&mut rng(3), 3, 32);
            let b = kind.material(&mut rng(3), 3, 32);
            assert_eq!(a, b, "{kind}");
        }
        assert_ne!(
            SceneKind::TwoMat.material(&mut rng(3), 3, 32),
            SceneKind::TwoMat.material(&mut rng(4), 4, 32)
        );
    }
}
