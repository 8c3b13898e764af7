//! The backlight measurement against the truth on every simulated scan
//! under a folder: per scan, over object pixels facing the camera
//! (`cos_nv > 0.5`), the median of the truth transmission, of the
//! measured per-crossing transmittance `q = t · basecolor` (luma), of the
//! truth's `t · basecolor`, and the median absolute error of `q / basecolor`
//! (truth basecolor) against the truth transmission. A development probe
//! for the transmission measurement, not part of the product.
//!
//!   cargo run --release -p matscan-estimate --example backlight_probe -- DIR

use matscan_calib::photos::luma;
use matscan_calib::{calibrate_bundle, CalibOptions};
use matscan_estimate::fit::backlight::{measure_backlight, BacklightOptions};
use matscan_estimate::pipeline::inputs::SceneInputs;
use matscan_estimate::pipeline::views::{select_views, ViewFilter};
use matscan_scan::{Bundle, Param};
use std::path::{Path, PathBuf};

fn scans(dir: &Path, out: &mut Vec<PathBuf>) {
    if dir.join("scan.toml").exists() {
        out.push(dir.to_path_buf());
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut dirs: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    for d in dirs {
        scans(&d, out);
    }
}

fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return f32::NAN;
    }
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(args.get(1).ok_or("usage: backlight_probe DIR")?);
    let mut list = Vec::new();
    scans(root, &mut list);
    for scan in &list {
        let bundle = Bundle::open(scan)?;
        let calibration = calibrate_bundle(&bundle, &CalibOptions::default())?;
        let set = select_views(&bundle.manifest, &calibration, &ViewFilter::default())?;
        let inputs = SceneInputs::assemble(&bundle, &calibration, &set)?;
        let name = scan
            .strip_prefix(root)
            .unwrap_or(scan)
            .display()
            .to_string();
        let m = match measure_backlight(&bundle, &inputs, &BacklightOptions::default())? {
            Ok(m) => m,
            Err(why) => {
                println!("{name:44} {why}");
                continue;
            }
        };
        let t = bundle
            .truth_param(&inputs.reference, Param::Transmission)?
            .ok_or("no truth")?
            .flat()
            .0
            .to_vec();
        let b = bundle
            .truth_param(&inputs.reference, Param::Basecolor)?
            .ok_or("no truth")?
            .flat()
            .0
            .to_vec();
        let mut tt = Vec::new();
        let mut qq = Vec::new();
        let mut tb = Vec::new();
        let mut err = Vec::new();
        let mut ks = [0usize; 5];
        for i in 0..inputs.pixels() {
            let Some(q) = m.transmittance[i] else {
                continue;
            };
            let base = [b[3 * i], b[3 * i + 1], b[3 * i + 2]];
            ks[(m.crossings[i] as usize).min(4)] += 1;
            tt.push(t[i]);
            qq.push(luma(q));
            tb.push(t[i] * luma(base));
            let est = (luma(q) / luma(base).max(1e-3)).min(1.0);
            err.push((est - t[i]).abs());
        }
        // Raw ratio luma(backlit - ambient) / luma(panel), binned by cos_nv
        // and by truth transmission (0 or above 0.3).
        let planes = inputs
            .views
            .iter()
            .find(|v| v.view.position == inputs.reference && v.backlit().is_some())
            .ok_or("no backlit")?;
        let bl = planes.backlit().ok_or("no backlit")?;
        let mut bins: Vec<Vec<f32>> = vec![Vec::new(); 8];
        for i in 0..inputs.pixels() {
            if !inputs.mask.data[i] {
                continue;
            }
            let cos = planes.cos_nv()[i];
            let cb = if cos > 0.97 { 3 } else if cos > 0.9 { 2 } else if cos > 0.7 { 1 } else { 0 };
            let tb = if t[i] <= 0.01 { 0 } else if t[i] > 0.3 { 4 } else { continue };
            let d = [0, 1, 2].map(|c| bl[i][c] - planes.ambient()[i][c]);
            bins[cb + tb].push(luma(d) / luma(m.panel));
        }
        // Global share of the projector's uniform light (what the checker
        // separation measured) per class: transmissive, subsurface, plain.
        let ss = bundle
            .truth_param(&inputs.reference, Param::Subsurface)?
            .ok_or("no truth")?
            .flat()
            .0
            .to_vec();
        if let Ok(g) = matscan_estimate::fit::separation::global_light(&bundle, &calibration, &inputs.reference)? {
            let uv = inputs.views.iter().find(|v| v.view.position == inputs.reference && v.view.light == g.projector);
            if let Some(uv) = uv {
                let level = bundle.capture(&inputs.reference, &uv.view.capture)?.uniform_level().unwrap_or(1.0) as f32;
                let mut cls: Vec<Vec<f32>> = vec![Vec::new(); 3];
                let mut rat: Vec<Vec<f32>> = vec![Vec::new(); 3];
                for i in 0..inputs.pixels() {
                    if !inputs.mask.data[i] || planes.cos_nv()[i] < 0.5 { continue; }
                    let tot = luma([0,1,2].map(|c| uv.lit()[i][c] - uv.ambient()[i][c])) / level;
                    let gl = luma(g.rgb.data[i]);
                    if !(tot > 1e-4 && gl.is_finite()) { continue; }
                    let k = if t[i] > 0.3 { 0 } else if ss[i] > 0.3 { 1 } else if t[i] < 0.01 && ss[i] < 0.05 { 2 } else { continue };
                    cls[k].push(gl / tot);
                    let d = [0, 1, 2].map(|c| bl[i][c] - planes.ambient()[i][c]);
                    rat[k].push(luma(d) / luma(m.panel));
                }
                let mut sb: Vec<Vec<f32>> = vec![Vec::new(); 6];
                for i in 0..inputs.pixels() {
                    if !inputs.mask.data[i] || planes.cos_nv()[i] < 0.5 || t[i] > 0.01 { continue; }
                    let tot = luma([0,1,2].map(|c| uv.lit()[i][c] - uv.ambient()[i][c])) / level;
                    let gl = luma(g.rgb.data[i]);
                    if !(tot > 1e-4 && gl.is_finite()) { continue; }
                    let k = if ss[i] < 0.02 { 0 } else if ss[i] < 0.1 { 1 } else if ss[i] < 0.25 { 2 } else if ss[i] < 0.5 { 3 } else if ss[i] < 0.75 { 4 } else { 5 };
                    sb[k].push(gl / tot);
                }
                let sbm: Vec<String> = sb.iter().map(|v| format!("{:.2}({})", median(v.clone()), v.len())).collect();
                println!("{name:44} SSBINS <.02 <.1 <.25 <.5 <.75 >=.75: {}", sbm.join(" "));
                let f = |v: &Vec<f32>| format!("{:.3}({})", median(v.clone()), v.len());
                println!("{name:44} global share  trans {}  subsurf {}  plain {}   backlit ratio trans {} subsurf {} plain {}",
                    f(&cls[0]), f(&cls[1]), f(&cls[2]), f(&rat[0]), f(&rat[1]), f(&rat[2]));
            }
        }
        let meds: Vec<String> = bins
            .into_iter()
            .map(|b| format!("{:.3}({})", median(b.clone()), b.len()))
            .collect();
        println!("{name:44} opaque by cos <.7 .7-.9 .9-.97 >.97: {:?}  t>.3: {:?}", &meds[0..4], &meds[4..8]);
        println!(
            "{name:44} px {:6} crossings {:?} L {:.3?}  truth t {:.3}  q {:.3}  t*b {:.3}  |q/b - t| {:.3}",
            tt.len(),
            ks,
            m.panel,
            median(tt),
            median(qq),
            median(tb),
            median(err)
        );
    }
    Ok(())
}
