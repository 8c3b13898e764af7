//! Where an estimate's error sits, truth material by truth material: for
//! every simulated scan under a folder that holds an estimate (its
//! `estimate/` folder, or `ESTIMATES/<scan name>`), the pixels of the
//! estimate's reference position (its `result.toml`) grouped by their truth material (basecolor,
//! roughness, metallic, transmission and subsurface rounded to 0.01), and
//! per group of at least 2 % of the object its truth, the estimate's
//! median and the group's mean absolute error per parameter, then the
//! truth's basecolor and the estimate's median per channel. A
//! development probe for choosing what to measure next, not part of the
//! product; per-pixel kinds (multimat, realworld) split into many small
//! groups and are skipped.
//!
//!   cargo run --release -p matscan-estimate --example material_errors -- data/tune [ESTIMATES]

use matscan_estimate::pipeline::metrics::error_metrics;
use matscan_estimate::pipeline::output::ResultFile;
use matscan_scan::estimate_maps::read_position_maps;
use matscan_scan::{Bundle, Param};
use std::collections::BTreeMap;
use std::path::Path;

mod support;
use support::median;

/// The truth of one pixel as a hashable key (hundredths).
type Key = [i32; 7];

fn key(truth: &[Vec<f32>], i: usize) -> Key {
    let q = |v: f32| (v * 100.0).round() as i32;
    [
        q(truth[0][3 * i]),
        q(truth[0][3 * i + 1]),
        q(truth[0][3 * i + 2]),
        q(truth[1][i]),
        q(truth[2][i]),
        q(truth[3][i]),
        q(truth[4][i]),
    ]
}

const ORDER: [Param; 5] = [
    Param::Basecolor,
    Param::Roughness,
    Param::Metallic,
    Param::Transmission,
    Param::Subsurface,
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(
        args.get(1)
            .ok_or("usage: material_errors DIR [ESTIMATES]")?,
    );
    let estimates = args.get(2).map(Path::new);
    println!(
        "scan | pixels | truth bc r m t s | estimate bc r m t s | MAD bc r m t s | rgb truth / estimate"
    );
    for scan in matscan_scan::bundle::find_bundles(root)? {
        let bundle = Bundle::open(&scan)?;
        let name = support::scan_name(&scan);
        let est_dir = match estimates {
            Some(d) => d.join(&name),
            None => scan.join("estimate"),
        };
        let Ok(text) = std::fs::read_to_string(est_dir.join("result.toml")) else {
            continue;
        };
        let reference = ResultFile::parse(&text)?.reference_position;
        let Some(maps) = read_position_maps(&est_dir, &reference)? else {
            continue;
        };
        let mut truth = Vec::new();
        let mut est = Vec::new();
        for p in ORDER {
            let t = bundle.truth_param(&reference, p)?.ok_or("no truth")?;
            truth.push(t.flat().0.to_vec());
            let e = maps.get(p).ok_or("estimate lacks a map")?;
            est.push(e.values().flat().0.to_vec());
        }
        let mask = bundle.truth_mask(&reference)?.ok_or("no truth mask")?;
        let mut groups: BTreeMap<Key, Vec<usize>> = BTreeMap::new();
        let mut total = 0usize;
        for (i, &m) in mask.data.iter().enumerate() {
            if m {
                total += 1;
                groups.entry(key(&truth, i)).or_default().push(i);
            }
        }
        let kind = scan
            .parent()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        for (k, px) in &groups {
            if px.len() * 50 < total {
                continue;
            }
            let mut in_group = vec![false; mask.data.len()];
            px.iter().for_each(|&i| in_group[i] = true);
            let mut med = Vec::new();
            let mut mad = Vec::new();
            for (j, p) in ORDER.iter().enumerate() {
                let ch = p.channels();
                let metrics = error_metrics(&est[j], &truth[j], &in_group, ch);
                mad.push(metrics.map_or(f64::NAN, |m| m.mad));
                med.push(median(
                    px.iter()
                        .map(|&i| est[j][ch * i..ch * (i + 1)].iter().sum::<f32>() / ch as f32)
                        .collect(),
                ));
            }
            let bc = (k[0] + k[1] + k[2]) as f32 / 300.0;
            let rgb: Vec<f32> = (0..3)
                .map(|c| median(px.iter().map(|&i| est[0][3 * i + c]).collect()))
                .collect();
            println!(
                "{kind}/{name} | {:5} | {:.2} {:.2} {:.0} {:.2} {:.2} | {:.2} {:.2} {:.2} {:.2} {:.2} | {:.3} {:.3} {:.3} {:.3} {:.3} | rgb {:.2} {:.2} {:.2} / {:.2} {:.2} {:.2}",
                px.len(),
                bc,
                k[3] as f32 / 100.0,
                k[4] as f32 / 100.0,
                k[5] as f32 / 100.0,
                k[6] as f32 / 100.0,
                med[0], med[1], med[2], med[3], med[4],
                mad[0], mad[1], mad[2], mad[3], mad[4],
                k[0] as f32 / 100.0,
                k[1] as f32 / 100.0,
                k[2] as f32 / 100.0,
                rgb[0],
                rgb[1],
                rgb[2],
            );
        }
    }
    Ok(())
}
