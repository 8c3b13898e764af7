//! How far light travels under the surface, as the flashes show it: per
//! lit view, the light at object pixels the view's light does not reach
//! (shadowed or facing away) against the light at pixels it lights, both
//! per unit of the light's white-Lambertian radiance where lit. Light at an
//! unlit pixel came there inside the object (or off the rig). Printed per
//! scan beside the truth's subsurface and transmission (medians over the
//! object). A development probe for the subsurface measurement, not part
//! of the product.
//!
//!   cargo run --release -p matscan-estimate --example glow_probe -- DIR

use matscan_calib::photos::{luma, quantile};
use matscan_estimate::refine::observe::calibrated_lighting;
use matscan_scan::Param;
use std::path::Path;

mod support;

fn main() -> Result<(), support::Error> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(args.get(1).ok_or("usage: glow_probe DIR")?);
    println!("scan | subsurface | transmission | per view: dark/lit ratio (dark px)");
    for dir in matscan_scan::bundle::find_bundles(root)? {
        let scan = support::open(&dir)?;
        let (bundle, calibration, inputs) = (&scan.bundle, &scan.calibration, &scan.inputs);
        let (ss, tr) = (
            scan.truth(Param::Subsurface)?,
            scan.truth(Param::Transmission)?,
        );
        let mask = &inputs.mask.data;
        let median = |v: &[f32]| {
            let mut s: Vec<f32> = v
                .iter()
                .zip(mask)
                .filter(|(_, &m)| m)
                .map(|(x, _)| *x)
                .collect();
            quantile(&mut s, 0.5).unwrap_or(f32::NAN)
        };
        let mut line = format!(
            "{} | {:.2} | {:.2} |",
            dir.display(),
            median(&ss),
            median(&tr)
        );
        for planes in &inputs.views {
            let Some(l) =
                calibrated_lighting(bundle, calibration, &inputs.reference, planes, 0.99)?
            else {
                continue;
            };
            let (mut dark, mut nd, mut lit, mut nl, mut light) =
                (0.0f64, 0usize, 0.0f64, 0usize, 0.0f64);
            for (i, &inside) in mask.iter().enumerate() {
                if !inside || planes.mask.get(i).is_none_or(|&m| m < 0.5) {
                    continue;
                }
                let obs = planes.lit()[i];
                let amb = planes.ambient()[i];
                let value = f64::from(luma([obs[0] - amb[0], obs[1] - amb[1], obs[2] - amb[2]]));
                if !value.is_finite() {
                    continue;
                }
                let cos_nl = planes.cos_nl()[i];
                if l.lit[i] <= 0.0 || cos_nl <= 0.0 {
                    dark += value;
                    nd += 1;
                } else if l.lit[i] >= 1.0 && cos_nl > 0.3 {
                    lit += value;
                    nl += 1;
                    light += f64::from(luma(l.light[i])) * f64::from(cos_nl);
                }
            }
            if nd >= 20 && light > 0.0 {
                let lit_albedo = lit / light;
                line.push_str(&format!(
                    " {}/{}:{:.3}({nd}; albedo {:.2})",
                    planes.view.position,
                    planes.view.capture,
                    (dark / nd as f64) / (lit / nl.max(1) as f64).max(1e-9),
                    lit_albedo
                ));
            }
        }
        println!("{line}");
    }
    Ok(())
}
