//! A recipe rendered in shards is the recipe rendered whole: every photo,
//! mask and truth map bit-identical, every manifest equal up to its
//! creation time, and no scene in two shards.

use matscan_sim::dataset::{render_scenes, Recipe, Shard};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const RECIPE: &str = r#"
description = "shard test: five tiny scenes in two sets"
size = 12
positions = 1
samples = 1

[[set]]
kind = "2mat"
geometry = "sphere"
count = 3
seed = 500

[[set]]
kind = "3mat"
geometry = "torus"
count = 2
seed = 600
"#;

/// Every file under `dir`, by path relative to it, with its bytes; a
/// manifest's `created` line is left out (the one thing a later render may
/// change).
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
                continue;
            }
            let mut bytes = std::fs::read(&path).unwrap();
            if path.file_name().is_some_and(|n| n == "scan.toml") {
                let text = String::from_utf8(bytes).unwrap();
                bytes = text
                    .lines()
                    .filter(|l| !l.starts_with("created"))
                    .collect::<Vec<_>>()
                    .join("\n")
                    .into_bytes();
            }
            out.insert(path.strip_prefix(root).unwrap().to_path_buf(), bytes);
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

#[test]
fn the_union_of_shards_is_the_whole_set_bit_for_bit() {
    let tmp = tempfile::tempdir().unwrap();
    let recipe_path = tmp.path().join("shards.toml");
    std::fs::write(&recipe_path, RECIPE).unwrap();
    let recipe = Recipe::read(&recipe_path).unwrap();
    let whole = tmp.path().join("whole");
    let all = recipe.shard(None).unwrap();
    let summary = render_scenes(&all, &whole, false, &mut |_, _| {}).unwrap();
    assert_eq!(summary.rendered, 5);

    let sharded = tmp.path().join("sharded");
    let mut counts = Vec::new();
    for index in 0..2 {
        let scenes = recipe.shard(Some(Shard { index, count: 2 })).unwrap();
        counts.push(scenes.len());
        render_scenes(&scenes, &sharded, false, &mut |_, _| {}).unwrap();
    }
    assert_eq!(counts, [3, 2], "scenes 0, 2, 4 and 1, 3");

    let (a, b) = (files(&whole), files(&sharded));
    assert!(a.len() > 5 * 5, "photos, masks and truth of five scenes");
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (path, bytes) in &a {
        assert!(b[path] == *bytes, "{} differs", path.display());
    }

    // A resumed shard renders nothing again.
    let again = recipe.shard(Some(Shard { index: 0, count: 2 })).unwrap();
    let summary = render_scenes(&again, &sharded, false, &mut |_, _| {}).unwrap();
    assert_eq!((summary.rendered, summary.present), (0, 3));
}
