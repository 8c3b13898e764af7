//! Checks the physical fit's forward model against a simulated scan: for
//! the pixels of one truth material (selected by roughness and metallic),
//! the brightest observations and what the model predicts for them at the
//! truth. A development probe, not part of the product.
//!
//!   cargo run --release -p matscan-estimate --example fit_probe -- SCAN RMAX METALLIC

use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_estimate::fit::linear::responses;
use matscan_estimate::fit::samples;
use matscan_estimate::pipeline::inputs::SceneInputs;
use matscan_estimate::pipeline::views::{select_views, ViewFilter};
use matscan_estimate::refine::model::Fixed;
use matscan_estimate::refine::observe::calibrated_lighting;
use matscan_scan::{Bundle, Param};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scan = std::path::Path::new(&args[1]);
    let rmax: f32 = args[2].parse()?;
    let metal: f32 = args[3].parse()?;
    let bundle = Bundle::open(scan)?;
    let calibration = calibrate_bundle(&bundle, &CalibOptions::default())?;
    let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default())?;
    let inputs = SceneInputs::assemble(&bundle, &calibration, &set)?;
    let lighting: Vec<_> = inputs
        .views
        .iter()
        .map(|p| calibrated_lighting(&bundle, &calibration, &inputs.reference, p, 0.99))
        .collect::<Result<_, _>>()?;
    let truth = |k: Param| bundle.truth_param(&inputs.reference, k);
    let bc: Vec<[f32; 3]> = truth(Param::Basecolor)?
        .ok_or("no truth")?
        .flat()
        .0
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let r = truth(Param::Roughness)?
        .ok_or("no truth")?
        .flat()
        .0
        .to_vec();
    let m = truth(Param::Metallic)?.ok_or("no truth")?.flat().0.to_vec();
    let mut rows = Vec::new();
    for i in 0..inputs.pixels() {
        if !inputs.mask.data[i] || r[i] > rmax || (m[i] - metal).abs() > 0.5 {
            continue;
        }
        let s = samples(&inputs, &lighting, i);
        let resp = responses(&s, r[i], m[i], &Fixed::default());
        for (k, (s, p)) in s.iter().zip(&resp).enumerate() {
            let x = f64::from(bc[i][0]);
            let pred = p.a[0] + x * (p.b[0] + x * p.q[0]);
            rows.push((
                s.observation.observed[0],
                pred,
                i,
                k,
                s.clipped[0],
                s.footprint,
            ));
        }
    }
    let total_obs: f64 = rows.iter().map(|r| f64::from(r.0)).sum();
    let total_pred: f64 = rows.iter().map(|r| r.1).sum();
    println!(
        "{} observations; sum observed {total_obs:.2}, predicted at truth {total_pred:.2}",
        rows.len()
    );
    type Row = (f32, f64, usize, usize, bool, f32);
    let print = |title: &str, rows: &[Row]| {
        println!("{title}:");
        for r in rows.iter().take(15) {
            println!(
                "  px ({},{}) view {} obs {:.3} pred {:.3} clipped {} fp {:.5}",
                r.2 % inputs.width,
                r.2 / inputs.width,
                r.3,
                r.0,
                r.1,
                r.4,
                r.5
            );
        }
    };
    rows.sort_by(|a, b| b.0.total_cmp(&a.0));
    print("brightest observed", &rows);
    rows.sort_by(|a, b| b.1.total_cmp(&a.1));
    print("brightest predicted", &rows);
    Ok(())
}
