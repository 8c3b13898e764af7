//! One complete random scene from a seed: geometry, material, environment
//! and rig.
//!
//! Each part draws from its own generator stream derived from the seed, so
//! the parts are independent: the same seed with another geometry keeps the
//! same material, environment and rig. Boundaries: assembles the other
//! submodules; renders nothing.

use super::geometry::{generate_mesh, GeometryKind, GeometryOptions, UserMesh};
use super::kinds::SceneKind;
use super::model::{EnvSource, EnvSpec, Scene};
use super::noise::hash64;
use super::rig::{random_rig, RigOptions, ENV_STRENGTH};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Where the object comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum GeometrySource {
    Kind(GeometryKind),
    /// A procedural kind drawn from the seed, all five equally likely.
    Random,
    /// The user's mesh, used as given (see [`UserMesh`]).
    Mesh(UserMesh),
}

#[derive(Debug, Clone, PartialEq)]
pub struct SceneOptions {
    pub seed: u64,
    pub kind: SceneKind,
    pub geometry: GeometrySource,
    /// Camera image size in pixels.
    pub width: u32,
    pub height: u32,
    /// Number of rig positions.
    pub positions: usize,
    /// Side of the square parameter maps, texels (clamped to 2..=4096).
    pub map_size: u32,
}

impl Default for SceneOptions {
    fn default() -> Self {
        SceneOptions {
            seed: 0,
            kind: SceneKind::Multimat,
            geometry: GeometrySource::Random,
            width: 256,
            height: 256,
            positions: 3,
            map_size: 256,
        }
    }
}

/// Generator streams, one per scene part.
#[derive(Debug, Clone, Copy)]
enum Stream {
    Pick = 1,
    Geometry = 2,
    Material = 3,
    Environment = 4,
    Rig = 5,
}

fn stream(seed: u64, part: Stream) -> Pcg64 {
    Pcg64::seed_from_u64(hash64(seed ^ hash64(part as u64)))
}

/// The scene of `options`, identical for identical options.
pub fn generate(options: &SceneOptions) -> Scene {
    let seed = options.seed;
    let (mesh, geometry_name) = match &options.geometry {
        GeometrySource::Mesh(user) => (user.mesh().clone(), "mesh"),
        source => {
            let kind = match source {
                GeometrySource::Kind(k) => *k,
                _ => {
                    let all = GeometryKind::PICKED;
                    all[stream(seed, Stream::Pick).gen_range(0..all.len())]
                }
            };
            let mesh = generate_mesh(
                kind,
                &mut stream(seed, Stream::Geometry),
                &GeometryOptions::default(),
            );
            (mesh, kind.name())
        }
    };
    let material = options.kind.material(
        &mut stream(seed, Stream::Material),
        seed,
        options.map_size.clamp(2, 4096),
    );
    let environment = if options.kind.has_environment() {
        let mut rng = stream(seed, Stream::Environment);
        EnvSpec {
            source: EnvSource::Procedural {
                seed: hash64(rng.gen()),
            },
            strength: rng.gen_range(ENV_STRENGTH),
            rotation: rng.gen_range(0.0..std::f32::consts::TAU),
        }
    } else {
        EnvSpec {
            source: EnvSource::None,
            strength: 0.0,
            rotation: 0.0,
        }
    };
    let rig = random_rig(
        &mut stream(seed, Stream::Rig),
        RigOptions {
            width: options.width,
            height: options.height,
            positions: options.positions,
        },
    );
    Scene {
        name: format!("{}-{}-{:04}", options.kind, geometry_name, seed),
        kind: options.kind.name().to_string(),
        geometry: geometry_name.to_string(),
        mesh,
        material,
        environment,
        rig,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::geometry::UvProjection;
    use crate::scene::model::Texture;
    use glam::DVec3;

    fn small(seed: u64, kind: SceneKind, geometry: GeometrySource) -> SceneOptions {
        SceneOptions {
            seed,
            kind,
            geometry,
            width: 64,
            height: 48,
            positions: 2,
            map_size: 32,
        }
    }

    #[test]
    fn same_seed_gives_the_same_scene_and_other_seeds_differ() {
        let o = small(12, SceneKind::TwoMat, GeometrySource::Random);
        let a = generate(&o);
        assert_eq!(a, generate(&o));
        let b = generate(&SceneOptions { seed: 13, ..o });
        assert_ne!(a.material, b.material);
        assert_ne!(a.rig, b.rig);
        assert_ne!(a.environment, b.environment);
    }

    #[test]
    fn parts_do_not_depend_on_each_other() {
        let a = generate(&small(
            4,
            SceneKind::Multimat,
            GeometrySource::Kind(GeometryKind::Torus),
        ));
        let b = generate(&small(
            4,
            SceneKind::Multimat,
            GeometrySource::Kind(GeometryKind::Sphere),
        ));
        assert_ne!(a.mesh, b.mesh);
        assert_eq!(
            (a.material, a.rig, a.environment),
            (b.material, b.rig, b.environment)
        );
    }

    #[test]
    fn names_options_and_environment_follow_the_request() {
        let s = generate(&small(
            7,
            SceneKind::TwoMatTransmission,
            GeometrySource::Kind(GeometryKind::Leaves),
        ));
        assert_eq!(s.name, "2mat-transmission-leaves-0007");
        assert_eq!(s.kind, "2mat-transmission");
        assert_eq!((s.rig.intrinsics.width, s.rig.intrinsics.height), (64, 48));
        assert_eq!(s.rig.positions.len(), 2);
        assert!(matches!(s.environment.source, EnvSource::Procedural { .. }));
        assert!(ENV_STRENGTH.contains(&s.environment.strength));

        let n = generate(&small(
            7,
            SceneKind::MultimatNoEnv,
            GeometrySource::Kind(GeometryKind::Blob),
        ));
        assert_eq!(n.name, "multimat-noenv-blob-0007");
        assert_eq!(n.environment.source, EnvSource::None);
        let Texture::Map(m) = &n.material.roughness else {
            panic!("multimat roughness is a map")
        };
        assert_eq!((m.width, m.height), (32, 32));
    }

    #[test]
    fn random_geometry_draws_every_kind_over_seeds() {
        let mut seen: Vec<String> = (0..40)
            .map(|seed| {
                let o = SceneOptions {
                    positions: 1,
                    ..small(seed, SceneKind::SweepSubsurface, GeometrySource::Random)
                };
                generate(&o)
                    .name
                    .split('-')
                    .nth(2)
                    .unwrap_or_default()
                    .to_string()
            })
            .collect();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 5, "{seen:?}");
    }

    #[test]
    fn sweep_seeds_select_the_sweep_step() {
        let s = generate(&small(
            19,
            SceneKind::SweepSubsurface,
            GeometrySource::Kind(GeometryKind::Sphere),
        ));
        assert_eq!(s.material.subsurface, Texture::Constant(1.0));
    }

    #[test]
    fn user_meshes_are_used_as_given_and_named_mesh() {
        let mut m = generate_mesh(
            GeometryKind::Sphere,
            &mut Pcg64::seed_from_u64(1),
            &GeometryOptions::default(),
        );
        m.uvs = None;
        let user = UserMesh::new(m, UvProjection::Spherical).unwrap();
        let s = generate(&small(
            3,
            SceneKind::ThreeMat,
            GeometrySource::Mesh(user.clone()),
        ));
        assert_eq!(s.name, "3mat-mesh-0003");
        assert_eq!(&s.mesh, user.mesh());
    }

    #[test]
    fn the_object_is_in_view_of_every_position() {
        for seed in 0..4 {
            let s = generate(&small(seed, SceneKind::Multimat, GeometrySource::Random));
            let (lo, hi) = s.mesh.bounds().unwrap();
            let centre = ((lo + hi) * 0.5).as_dvec3();
            for i in 0..s.rig.positions.len() {
                let cam = s.rig.camera(i).unwrap();
                let px = cam.project(centre).expect("object in front");
                assert!(
                    (0.0..64.0).contains(&px.x) && (0.0..48.0).contains(&px.y),
                    "{px}"
                );
                assert!(cam.depth(DVec3::ZERO) > 1.0);
            }
        }
    }
}
