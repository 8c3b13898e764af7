//! The trivial baseline of an evaluation: the mean truth of a set, read
//! through `Bundle::truth_mask` and `Bundle::truth_param`.

use anyhow::Result;
use matscan_scan::{Bundle, Param};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Mean masked truth value per parameter over every position of `scans`
/// (each position's mask read once for all parameters).
pub fn mean_truth(scans: &[PathBuf]) -> Result<BTreeMap<Param, f64>> {
    let mut sums: BTreeMap<Param, (f64, usize)> = BTreeMap::new();
    for scan in scans {
        let bundle = Bundle::open(scan)?;
        for position in &bundle.manifest.positions {
            let Some(mask) = bundle.truth_mask(&position.name)? else {
                continue;
            };
            for kind in matscan_estimate::PIPELINE_ORDER {
                let Some(truth) = bundle.truth_param(&position.name, kind)? else {
                    continue;
                };
                let (values, channels) = truth.flat();
                let entry = sums.entry(kind).or_default();
                for (i, _) in mask.data.iter().enumerate().filter(|(_, m)| **m) {
                    for v in &values[i * channels..(i + 1) * channels] {
                        if v.is_finite() {
                            entry.0 += f64::from(*v);
                            entry.1 += 1;
                        }
                    }
                }
            }
        }
    }
    Ok(sums
        .into_iter()
        .filter(|(_, (_, n))| *n > 0)
        .map(|(k, (s, n))| (k, s / n as f64))
        .collect())
}
