//! How an estimate's metallic splits between pixels a call decided (0 or
//! 1 exactly: a material's call or a window's) and pixels the networks'
//! fractional map answers: per scan, each class's share of the object,
//! its mean absolute error, its truth's metal share, and the error the
//! networks' class would have rounded at 0.5. A development probe for
//! the per-pixel metallic of materials that hold metal and dielectric
//! alike (multimat), not part of the product.
//!
//!   cargo run --release -p matscan-estimate --example metallic_calls -- data/tune ESTIMATES

use matscan_estimate::pipeline::output::ResultFile;
use matscan_scan::estimate_maps::read_position_maps;
use matscan_scan::{Bundle, Param};
use std::path::Path;

mod support;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(args.get(1).ok_or("usage: metallic_calls DIR ESTIMATES")?);
    let estimates = Path::new(args.get(2).ok_or("usage: metallic_calls DIR ESTIMATES")?);
    println!("scan | object px | called: share MAD truth-metal | networks: share MAD truth-metal rounded-MAD");
    for scan in matscan_scan::bundle::find_bundles(root)? {
        let bundle = Bundle::open(&scan)?;
        let name = support::scan_name(&scan);
        let est_dir = estimates.join(&name);
        let Ok(text) = std::fs::read_to_string(est_dir.join("result.toml")) else {
            continue;
        };
        let reference = ResultFile::parse(&text)?.reference_position;
        let Some(maps) = read_position_maps(&est_dir, &reference)? else {
            continue;
        };
        let truth = bundle
            .truth_param(&reference, Param::Metallic)?
            .ok_or("no truth")?;
        let truth = truth.flat().0.to_vec();
        let est = maps.get(Param::Metallic).ok_or("no metallic map")?;
        let est = est.values().flat().0.to_vec();
        let mask = bundle.truth_mask(&reference)?.ok_or("no truth mask")?;
        // (pixels, abs error, truth metal, rounded abs error) per class.
        let mut called = (0usize, 0.0f64, 0usize);
        let mut open = (0usize, 0.0f64, 0usize, 0.0f64);
        for (i, &m) in mask.data.iter().enumerate() {
            if !m {
                continue;
            }
            let (e, t) = (est[i], truth[i]);
            let metal = usize::from(t >= 0.5);
            if e == 0.0 || e == 1.0 {
                called.0 += 1;
                called.1 += f64::from((e - t).abs());
                called.2 += metal;
            } else {
                open.0 += 1;
                open.1 += f64::from((e - t).abs());
                open.2 += metal;
                let r = if e >= 0.5 { 1.0 } else { 0.0 };
                open.3 += f64::from((r - t).abs());
            }
        }
        let total = (called.0 + open.0).max(1) as f64;
        let per = |s: f64, n: usize| if n > 0 { s / n as f64 } else { f64::NAN };
        println!(
            "{name} | {:6} | {:.2} {:.3} {:.2} | {:.2} {:.3} {:.2} {:.3}",
            called.0 + open.0,
            called.0 as f64 / total,
            per(called.1, called.0),
            per(called.2 as f64, called.0),
            open.0 as f64 / total,
            per(open.1, open.0),
            per(open.2 as f64, open.0),
            per(open.3, open.0),
        );
    }
    Ok(())
}
