//! What the backlit photo shows through each kind of truth material, on
//! every simulated scan under a folder: per scan, at its reference
//! position, each truth material's median backlight and global share;
//! the checker's global share of the projector's light and the
//! backlight's share of the panel's radiance (median / 80th / 95th
//! percentile, pixel count) over dielectric pixels whose truth has
//! transmission only, subsurface only, both or neither; then, for
//! subsurface-only pixels, the backlight share against the chord the
//! camera ray cuts through the object (bins of 0.1 scene units); and for
//! transmission-only pixels, the transmission the share gives through two
//! clear crossings with the truth's diffuse albedo, against the truth. A
//! development probe behind docs/results.md's backlight table, not part
//! of the product.
//!
//!   cargo run --release -p matscan-estimate --example backlight_probe -- data/tune

use matscan_calib::photos::luma;
use matscan_estimate::fit::backlight::{measure_backlight, BacklightOptions};
use matscan_scan::bvh::{Ray, RayCaster};
use matscan_scan::Param;
use std::collections::BTreeMap;
use std::path::Path;

/// Per truth material: basecolor lumas, backlight shares, global shares.
type Pools = (Vec<f32>, Vec<f32>, Vec<f32>);

mod support;
use support::median;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(args.get(1).ok_or("usage: backlight_probe DIR")?);
    let list = matscan_scan::bundle::find_bundles(root)?;
    for scan in &list {
        let opened = support::open(scan)?;
        let (bundle, calibration, inputs) = (&opened.bundle, &opened.calibration, &opened.inputs);
        let name = scan.file_name().map_or_else(
            || scan.display().to_string(),
            |n| n.to_string_lossy().to_string(),
        );
        let m = match measure_backlight(inputs, &BacklightOptions::default()) {
            Ok(m) => m,
            Err(why) => {
                println!("{name:14} {why}");
                continue;
            }
        };
        let truth = |p: Param| opened.truth(p);
        let (t, b, ss, mt) = (
            truth(Param::Transmission)?,
            truth(Param::Basecolor)?,
            truth(Param::Subsurface)?,
            truth(Param::Metallic)?,
        );
        let caster = RayCaster::new(bundle.read_mesh()?);
        let camera = bundle.camera(&inputs.reference)?;
        let w = inputs.width;
        // chord bins 0-.1,.1-.2,... up to 1.2
        let mut bins: Vec<Vec<f32>> = vec![Vec::new(); 12];
        let (mut sst, mut bl) = (Vec::new(), Vec::new());
        for i in 0..inputs.pixels() {
            let s = m.share[i];
            if !s.is_finite() || mt[i] > 0.5 || t[i] * (1.0 - mt[i]) > 0.01 || ss[i] < 0.05 {
                continue;
            }
            let ray = camera.pixel_ray((i % w) as u32, (i / w) as u32);
            let Some((h1, sp)) = caster.closest(&ray) else {
                continue;
            };
            let _ = h1;
            let o = caster.offset(
                sp.position,
                if sp.geometric_normal.dot(ray.dir) > 0.0 {
                    sp.geometric_normal
                } else {
                    -sp.geometric_normal
                },
            );
            let r2 = Ray::new(o, ray.dir);
            let Some((_, sp2)) = caster.closest(&r2) else {
                continue;
            };
            let d = (sp2.position - sp.position).length();
            let k = ((d / 0.1) as usize).min(11);
            bins[k].push(s);
            sst.push(ss[i]);
            bl.push(luma([b[3 * i], b[3 * i + 1], b[3 * i + 2]]));
        }
        // Global share of the projector's uniform light and backlight share
        // per class: t only, ss only, both, neither (dielectrics).
        if let Ok(g) =
            matscan_estimate::fit::separation::global_light(bundle, calibration, &inputs.reference)?
        {
            if let Some(uv) = inputs
                .views
                .iter()
                .find(|v| v.view.position == inputs.reference && v.view.light == g.projector)
            {
                let level = bundle
                    .capture(&inputs.reference, &uv.view.capture)?
                    .uniform_level()
                    .unwrap_or(1.0) as f32;
                // Transmission inverted from the share through two
                // crossings of a clear path: share = (1 - F)^2 (t b)^2 per
                // channel's luma, with the diffuse albedo rho = (1 - t) b the
                // flashes show, t = q / (q + rho).
                let fp = (1.0
                    - matscan_bsdf::fresnel_dielectric_cos(1.0, matscan_bsdf::material::IOR))
                .powi(2);
                let (mut tt, mut te) = (Vec::new(), Vec::new());
                for i in 0..inputs.pixels() {
                    let s = m.share[i];
                    if !s.is_finite() || mt[i] > 0.5 || t[i] < 0.05 || ss[i] > 0.05 {
                        continue;
                    }
                    let rho = (1.0 - t[i]) * luma([b[3 * i], b[3 * i + 1], b[3 * i + 2]]);
                    let q = (s / fp).sqrt();
                    tt.push(t[i]);
                    te.push(if q + rho > 0.0 {
                        q / (q + rho)
                    } else {
                        f32::NAN
                    });
                }
                if !tt.is_empty() {
                    let err: Vec<f32> = tt.iter().zip(&te).map(|(a, b)| (a - b).abs()).collect();
                    println!(
                        "{name:14} t-only: truth {:.3} inverted {:.3} |err| {:.3} ({})",
                        median(tt.clone()),
                        median(te.clone()),
                        median(err),
                        tt.len()
                    );
                }
                // Each truth material (metallic, transmission, subsurface to
                // 0.01): pixels, luma basecolor, median backlight and
                // global share.
                let mut combos: BTreeMap<(i32, i32, i32), Pools> = BTreeMap::new();
                for i in 0..inputs.pixels() {
                    if !inputs.mask.data[i] || uv.cos_nv()[i] < 0.5 {
                        continue;
                    }
                    let key = (
                        (mt[i] * 100.0).round() as i32,
                        (t[i] * 100.0).round() as i32,
                        (ss[i] * 100.0).round() as i32,
                    );
                    let e = combos.entry(key).or_default();
                    e.0.push(luma([b[3 * i], b[3 * i + 1], b[3 * i + 2]]));
                    if m.share[i].is_finite() {
                        e.1.push(m.share[i]);
                    }
                    let tot = luma([0, 1, 2].map(|c| uv.lit()[i][c] - uv.ambient()[i][c])) / level;
                    let gl = luma(g.rgb.data[i]);
                    if tot > 1e-4 && gl.is_finite() {
                        e.2.push(gl / tot);
                    }
                }
                for (k, v) in &combos {
                    if v.0.len() < 200 {
                        continue;
                    }
                    println!("{name:14} material m {:.2} t {:.2} ss {:.2}: {} px, b {:.2}, backlight {:.3} ({} px), global {:.2}",
                        k.0 as f32 / 100.0, k.1 as f32 / 100.0, k.2 as f32 / 100.0, v.0.len(), median(v.0.clone()), median(v.1.clone()), v.1.len(), median(v.2.clone()));
                }
                let mut gs: Vec<Vec<f32>> = vec![Vec::new(); 4];
                let mut bs: Vec<Vec<f32>> = vec![Vec::new(); 4];
                let mut tv: Vec<Vec<f32>> = vec![Vec::new(); 4];
                for i in 0..inputs.pixels() {
                    if !inputs.mask.data[i] || mt[i] > 0.5 || uv.cos_nv()[i] < 0.5 {
                        continue;
                    }
                    let tot = luma([0, 1, 2].map(|c| uv.lit()[i][c] - uv.ambient()[i][c])) / level;
                    let gl = luma(g.rgb.data[i]);
                    if !(tot > 1e-4 && gl.is_finite()) {
                        continue;
                    }
                    let k = match (t[i] > 0.05, ss[i] > 0.05) {
                        (true, false) => 0,
                        (false, true) => 1,
                        (true, true) => 2,
                        (false, false) => 3,
                    };
                    gs[k].push(gl / tot);
                    if m.share[i].is_finite() {
                        bs[k].push(m.share[i]);
                    }
                    tv[k].push(t[i]);
                }
                let f = |v: &Vec<f32>| {
                    let mut w = v.clone();
                    w.sort_by(f32::total_cmp);
                    let q = |p: f32| {
                        w.get(((w.len() as f32 - 1.0) * p) as usize)
                            .copied()
                            .unwrap_or(f32::NAN)
                    };
                    format!("{:.3}/{:.3}/{:.3}({})", q(0.5), q(0.8), q(0.95), v.len())
                };
                println!("{name:14} global: t {} ss {} both {} none {}   backlight: t {} ss {} both {} none {}   t: {} {}",
                    f(&gs[0]), f(&gs[1]), f(&gs[2]), f(&gs[3]), f(&bs[0]), f(&bs[1]), f(&bs[2]), f(&bs[3]), f(&tv[0]), f(&tv[2]));
            }
        }
        if sst.is_empty() {
            continue;
        }
        let f = bins
            .iter()
            .map(|b| {
                if b.is_empty() {
                    "   -   ".to_string()
                } else {
                    format!("{:.3}({})", median(b.clone()), b.len())
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
        println!("{name:14} ss {:.2} b {:.2}: {f}", median(sst), median(bl));
    }
    Ok(())
}
