//! Sets of simulated scans: one scene, a run of seeds, or a whole
//! [`Recipe`], each scene published atomically so that a stopped run
//! resumes where it stopped (a folder that exists is complete).
//!
//! A recipe is a small TOML file in the repository (`data/recipes/`) that
//! names every scene of a data set a figure was measured on, so anyone can
//! render that set again bit for bit:
//!
//! ```toml
//! description = "what the set is for and which figures use it"
//! size = 64          # image width = height in pixels
//! positions = 3      # scan-head positions
//! samples = 16       # path-tracing samples per pixel
//!
//! [[set]]
//! kind = "2mat"      # a scene kind (see `SceneKind`)
//! geometry = "torus" # a geometry kind, or `random`
//! count = 10         # scenes; scene i has seed `seed + i`
//! seed = 20000
//! ```
//!
//! Each set may override `size`, `positions` and `samples`. Scene `i` of a
//! set is written to `<kind>-<geometry>/scene-<seed + i>` (six digits)
//! under the output folder; the renderer's own seed is the set's first
//! seed, as a run of `matscan simulate --dataset` uses it, so a set
//! rendered either way is identical. `--shard K/N` renders the scenes whose
//! index in recipe order is K modulo N: disjoint slices whose union is the
//! whole set.
//!
//! Scenes render one after another, each using every core (tile-parallel
//! inside the renderer), which keeps peak memory at one scene's worth.

use crate::render::describe::{description_dir, write_description, DESCRIPTION_FILE};
use crate::render::{write_scan_bundle, SimError, SimOptions};
use crate::scene::{generate, GeometryKind, GeometrySource, SceneKind, SceneOptions};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A data set that could not be read or rendered.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file or folder could not be read or created.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A recipe breaks the format.
    #[error("{}: {message}", path.display())]
    Recipe { path: PathBuf, message: String },
    /// A scene could not be rendered or written.
    #[error("writing simulated scan to {}: {source}", path.display())]
    Render {
        path: PathBuf,
        #[source]
        source: SimError,
    },
}

/// Renders one scene into `out` and returns the seconds it took; with
/// `describe`, also writes the scene's description beside it
/// (`crate::render::describe`).
pub fn render_scene(
    options: &SceneOptions,
    sim: &SimOptions,
    out: &Path,
    describe: bool,
) -> Result<f64, DatasetError> {
    let start = Instant::now();
    let scene = generate(options);
    let failed = |source| DatasetError::Render {
        path: out.to_path_buf(),
        source,
    };
    let bundle = write_scan_bundle(&scene, sim, out).map_err(failed)?;
    if describe {
        write_description(&scene, sim, &bundle, out).map_err(failed)?;
    }
    Ok(start.elapsed().as_secs_f64())
}

/// Describes the scene of a bundle rendered before (regenerating the scene
/// from its options, which is cheap beside rendering), unless done already.
fn describe_present(planned: &PlannedScene, out: &Path) -> Result<(), DatasetError> {
    if description_dir(out).join(DESCRIPTION_FILE).exists() {
        return Ok(());
    }
    let failed = |source| DatasetError::Render {
        path: out.to_path_buf(),
        source,
    };
    let bundle = matscan_scan::Bundle::open(out).map_err(|e| failed(SimError::Scan(e)))?;
    write_description(&generate(&planned.scene), &planned.sim, &bundle, out).map_err(failed)?;
    Ok(())
}

/// One scene of a data set: where it goes and how it is made.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedScene {
    /// The scene's folder, relative to the set's folder.
    pub folder: PathBuf,
    pub scene: SceneOptions,
    pub sim: SimOptions,
}

/// How many scenes a run rendered and found already present.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderSummary {
    pub rendered: usize,
    pub present: usize,
}

/// Renders `scenes` under `dir`, skipping those already there (with
/// `describe`, describing each scene, also those already rendered);
/// `progress` hears (done, total) after each scene.
pub fn render_scenes(
    scenes: &[PlannedScene],
    dir: &Path,
    describe: bool,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<RenderSummary, DatasetError> {
    std::fs::create_dir_all(dir).map_err(|source| DatasetError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut summary = RenderSummary::default();
    for (i, planned) in scenes.iter().enumerate() {
        let out = dir.join(&planned.folder);
        if out.join(matscan_scan::bundle::MANIFEST_FILE).exists() {
            summary.present += 1;
            if describe {
                describe_present(planned, &out)?;
            }
        } else {
            if let Some(parent) = out.parent() {
                std::fs::create_dir_all(parent).map_err(|source| DatasetError::Io {
                    path: parent.to_path_buf(),
                    source,
                })?;
            }
            render_scene(&planned.scene, &planned.sim, &out, describe)?;
            summary.rendered += 1;
        }
        progress(i + 1, scenes.len());
    }
    Ok(summary)
}

/// `count` scenes like `base` with seeds `first_seed..first_seed+count`,
/// as `scene-<seed>` folders (the renderer's seed is `sim`'s, unchanged).
pub fn seed_run(
    base: &SceneOptions,
    sim: &SimOptions,
    first_seed: u64,
    count: u64,
) -> Vec<PlannedScene> {
    (first_seed..first_seed.saturating_add(count))
        .map(|seed| PlannedScene {
            folder: PathBuf::from(format!("scene-{seed:06}")),
            scene: SceneOptions {
                seed,
                ..base.clone()
            },
            sim: *sim,
        })
        .collect()
}

/// One `[[set]]` of a recipe.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RecipeSet {
    pub kind: String,
    pub geometry: String,
    pub count: u64,
    pub seed: u64,
    pub size: Option<u32>,
    pub positions: Option<usize>,
    pub samples: Option<u32>,
}

/// A data set described by scene kind, geometry, count, seed, image size
/// and samples (see the module doc).
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    pub description: String,
    pub size: u32,
    pub positions: usize,
    pub samples: u32,
    #[serde(rename = "set")]
    pub sets: Vec<RecipeSet>,
}

/// The K-th of N disjoint slices of a set (`K/N`, K from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("`{s}`: expected K/N with 0 <= K < N, e.g. 0/4");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = k.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl Recipe {
    /// Reads and checks the recipe at `path`.
    pub fn read(path: &Path) -> Result<Recipe, DatasetError> {
        let text = std::fs::read_to_string(path).map_err(|source| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Recipe::parse(&text, path)
    }

    /// Parses and checks the recipe `text`; errors name `path`, where it
    /// came from.
    pub fn parse(text: &str, path: &Path) -> Result<Recipe, DatasetError> {
        let recipe: Recipe = toml::from_str(text).map_err(|e| DatasetError::Recipe {
            path: path.to_path_buf(),
            message: e.message().to_string(),
        })?;
        recipe.scenes().map_err(|message| DatasetError::Recipe {
            path: path.to_path_buf(),
            message,
        })?;
        Ok(recipe)
    }

    /// Every scene of the recipe, in recipe order; an `Err` names the set
    /// and key that break the format.
    pub fn scenes(&self) -> Result<Vec<PlannedScene>, String> {
        if self.sets.is_empty() {
            return Err("no [[set]]: expected at least one".to_string());
        }
        let mut scenes = Vec::new();
        for (i, set) in self.sets.iter().enumerate() {
            let at =
                |key: &str| format!("set {} ({}-{}): key `{key}`", i + 1, set.kind, set.geometry);
            let kind: SceneKind = set
                .kind
                .parse()
                .map_err(|e| format!("{}: {e}", at("kind")))?;
            let geometry = match set.geometry.as_str() {
                "random" => GeometrySource::Random,
                g => GeometrySource::Kind(
                    g.parse::<GeometryKind>()
                        .map_err(|e| format!("{}: {e} or random", at("geometry")))?,
                ),
            };
            let size = set.size.unwrap_or(self.size);
            if !(8..=4096).contains(&size) {
                return Err(format!("{}: {size}, expected 8 to 4096 pixels", at("size")));
            }
            let positions = set.positions.unwrap_or(self.positions);
            if !(1..=64).contains(&positions) {
                return Err(format!(
                    "{}: {positions}, expected 1 to 64",
                    at("positions")
                ));
            }
            let samples = set.samples.unwrap_or(self.samples);
            if samples == 0 {
                return Err(format!(
                    "{}: 0, expected at least one sample per pixel",
                    at("samples")
                ));
            }
            if set.count == 0 {
                return Err(format!("{}: 0, expected at least one scene", at("count")));
            }
            let base = SceneOptions {
                seed: set.seed,
                kind,
                geometry,
                width: size,
                height: size,
                positions,
                ..SceneOptions::default()
            };
            let sim = SimOptions {
                seed: set.seed,
                samples,
                ..SimOptions::default()
            };
            let group = PathBuf::from(format!("{}-{}", set.kind, set.geometry));
            for mut planned in seed_run(&base, &sim, set.seed, set.count) {
                planned.folder = group.join(&planned.folder);
                if scenes
                    .iter()
                    .any(|s: &PlannedScene| s.folder == planned.folder)
                {
                    return Err(format!(
                        "{}: scene {} is also in an earlier set",
                        at("seed"),
                        planned.folder.display()
                    ));
                }
                scenes.push(planned);
            }
        }
        Ok(scenes)
    }

    /// Every scene, the sets taken in turn: the first scene of each set,
    /// then the second of each, ...; so the first N scenes mix the sets
    /// (what `matscan bench --scenes N` renders).
    pub fn interleaved(&self) -> Result<Vec<PlannedScene>, String> {
        let mut by_set: Vec<std::collections::VecDeque<PlannedScene>> = Vec::new();
        let mut all = self.scenes()?.into_iter();
        for set in &self.sets {
            by_set.push(all.by_ref().take(set.count as usize).collect());
        }
        let mut out = Vec::new();
        while by_set.iter().any(|s| !s.is_empty()) {
            out.extend(by_set.iter_mut().filter_map(|s| s.pop_front()));
        }
        Ok(out)
    }

    /// The scenes of `shard` (all of them without one).
    pub fn shard(&self, shard: Option<Shard>) -> Result<Vec<PlannedScene>, String> {
        let scenes = self.scenes()?;
        Ok(match shard {
            None => scenes,
            Some(s) => scenes
                .into_iter()
                .enumerate()
                .filter(|(i, _)| i % s.count == s.index)
                .map(|(_, p)| p)
                .collect(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RECIPE: &str = r#"
description = "test"
size = 16
positions = 1
samples = 2

[[set]]
kind = "2mat"
geometry = "sphere"
count = 3
seed = 100

[[set]]
kind = "3mat"
geometry = "torus"
count = 2
seed = 200
size = 24
"#;

    fn shipped(name: &str) -> Recipe {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../data/recipes")
            .join(name);
        Recipe::read(&path).unwrap_or_else(|e| panic!("{e}"))
    }

    fn geometries(r: &Recipe) -> std::collections::BTreeSet<String> {
        r.sets.iter().map(|s| s.geometry.clone()).collect()
    }

    #[test]
    fn the_heldout_yardstick_holds_its_promises() {
        let heldout = shipped("heldout.toml");
        let scenes = heldout.scenes().unwrap();
        assert!(scenes.len() >= 60, "{} scenes", scenes.len());
        assert_eq!(
            (heldout.size, heldout.positions, heldout.samples),
            (256, 3, 32)
        );
        let realworld = scenes
            .iter()
            .filter(|s| s.scene.kind == SceneKind::RealWorld)
            .count();
        assert!(realworld >= 10, "{realworld} realworld scenes");
        for kind in [
            "2mat",
            "3mat",
            "multimat",
            "multimat-noenv",
            "2mat-transmission",
            "sweep-subsurface",
        ] {
            assert!(heldout.sets.iter().any(|s| s.kind == kind), "no {kind}");
        }
        // Shapes never used for training or tuning, but the leaves (the one
        // shape with thin transmissive sheets).
        let seen: std::collections::BTreeSet<String> = geometries(&shipped("train.toml"))
            .into_iter()
            .chain(geometries(&shipped("tune.toml")))
            .collect();
        let shared: Vec<String> = geometries(&heldout)
            .intersection(&seen)
            .filter(|g| g.as_str() != "leaves")
            .cloned()
            .collect();
        assert!(shared.is_empty(), "held-out shapes also seen: {shared:?}");
        let unseen = geometries(&heldout).len() - 1;
        assert!(unseen >= 4, "{unseen} unseen shapes");
    }

    #[test]
    fn interleaving_takes_the_sets_in_turn_and_keeps_every_scene() {
        let recipe: Recipe = toml::from_str(RECIPE).unwrap();
        let folders: Vec<String> = recipe
            .interleaved()
            .unwrap()
            .iter()
            .map(|s| s.folder.display().to_string())
            .collect();
        assert_eq!(
            folders,
            [
                "2mat-sphere/scene-000100",
                "3mat-torus/scene-000200",
                "2mat-sphere/scene-000101",
                "3mat-torus/scene-000201",
                "2mat-sphere/scene-000102",
            ]
        );
    }

    #[test]
    fn a_recipe_names_every_scene_with_its_seed_and_folder() {
        let recipe: Recipe = toml::from_str(RECIPE).unwrap();
        let scenes = recipe.scenes().unwrap();
        let folders: Vec<String> = scenes
            .iter()
            .map(|s| s.folder.display().to_string())
            .collect();
        assert_eq!(
            folders,
            [
                "2mat-sphere/scene-000100",
                "2mat-sphere/scene-000101",
                "2mat-sphere/scene-000102",
                "3mat-torus/scene-000200",
                "3mat-torus/scene-000201"
            ]
        );
        assert_eq!(scenes[4].scene.seed, 201);
        assert_eq!(scenes[4].scene.width, 24);
        assert_eq!(scenes[0].scene.width, 16);
        // The renderer's seed is the set's first seed, as `--dataset` uses it.
        assert_eq!(scenes[2].sim.seed, 100);
        assert_eq!(scenes[2].sim.samples, 2);
    }

    #[test]
    fn shards_are_disjoint_and_their_union_is_the_set() {
        let recipe: Recipe = toml::from_str(RECIPE).unwrap();
        let all = recipe.shard(None).unwrap();
        let mut union: Vec<PlannedScene> = (0..3)
            .flat_map(|k| recipe.shard(Some(Shard { index: k, count: 3 })).unwrap())
            .collect();
        assert_eq!(union.len(), all.len());
        union.sort_by(|a, b| a.folder.cmp(&b.folder));
        assert_eq!(union, all);
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
        assert!("4/4".parse::<Shard>().is_err());
        assert!("x".parse::<Shard>().is_err());
    }

    #[test]
    fn a_bad_recipe_names_its_set_and_key() {
        let bad = RECIPE.replace("\"torus\"", "\"teapot\"");
        let recipe: Recipe = toml::from_str(&bad).unwrap();
        let e = recipe.scenes().unwrap_err();
        assert!(
            e.contains("set 2") && e.contains("`geometry`") && e.contains("teapot"),
            "{e}"
        );
        let twice = RECIPE
            .replace("seed = 200", "seed = 101")
            .replace("\"3mat\"", "\"2mat\"")
            .replace("\"torus\"", "\"sphere\"")
            .replace("size = 24\n", "");
        let recipe: Recipe = toml::from_str(&twice).unwrap();
        let e = recipe.scenes().unwrap_err();
        assert!(e.contains("also in an earlier set"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.toml");
        std::fs::write(&path, "description = 1\n").unwrap();
        let e = Recipe::read(&path).unwrap_err().to_string();
        assert!(e.contains("r.toml"), "{e}");
    }

    #[test]
    fn the_shipped_recipes_parse() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/recipes");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                let recipe = Recipe::read(&path).unwrap_or_else(|e| panic!("{e}"));
                assert!(!recipe.scenes().unwrap().is_empty());
                n += 1;
            }
        }
        assert!(
            n >= 5,
            "expected the held-out (two), tuning, test and training recipes"
        );
    }
}
