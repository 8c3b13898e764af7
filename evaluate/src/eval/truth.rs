//! The simulated truth of a scan as the evaluation reads it: the object
//! mask, a parameter's values at a position, and the trivial baseline (the
//! mean truth of a set).

use anyhow::Result;
use matscan_scan::{Bundle, Param};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The object mask of `position`'s truth; `None` without one.
pub fn truth_mask(bundle: &Bundle, position: &str) -> Result<Option<Vec<bool>>> {
    Ok(bundle.truth_mask(position)?.map(|m| m.data))
}

/// One parameter's truth at one position: values (pixel-major) and
/// channels per pixel; `None` without a truth map for it.
pub fn truth_values(
    bundle: &Bundle,
    position: &str,
    param: Param,
) -> Result<Option<(Vec<f32>, usize)>> {
    Ok(bundle.truth_param(position, param)?.map(|v| {
        let (values, channels) = v.flat();
        (values.to_vec(), channels)
    }))
}

/// Mean masked truth value per parameter over every position of `scans`
/// (each position's mask read once for all parameters).
pub fn mean_truth(scans: &[PathBuf]) -> Result<BTreeMap<Param, f64>> {
    let mut sums: BTreeMap<Param, (f64, usize)> = BTreeMap::new();
    for scan in scans {
        let bundle = Bundle::open(scan)?;
        for position in &bundle.manifest.positions {
            let Some(mask) = truth_mask(&bundle, &position.name)? else {
                continue;
            };
            for kind in matscan_estimate::PIPELINE_ORDER {
                let Some((values, channels)) = truth_values(&bundle, &position.name, kind)? else {
                    continue;
                };
                let entry = sums.entry(kind).or_default();
                for (i, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
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
