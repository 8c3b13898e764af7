//! Subsurface by re-rendering: per scan, the reference position's flash
//! photos against `sim`'s renders of the scan's own mesh with one
//! homogeneous material (the truth's basecolor and roughness over its
//! scattering pixels) at a range of subsurface values; prints, per value,
//! the relative residual after a free gain per channel and the
//! root-mean-square difference of each flash's share of a cell. The
//! development probe of `matscan_estimate::fit::scattering`.
//!
//!   cargo run --release -p matscan-estimate --example scatter_probe -- DIR [CELLS] [SPP] [GREY]
//!
//! `AUTO=1` also gives each subsurface the basecolor whose render matches
//! the photos' level. `PANEL=RECIPE` renders with the simulator's
//! backlight panel of each scene (regenerated from the recipe that
//! rendered it), which the product cannot know. Results: docs/results.md,
//! "Subsurface by rendering the scan's own object" and "Subsurface across
//! the whole sweep".

use glam::Vec3;
use matscan_bsdf::material::{Material, DEFAULT_SUBSURFACE_RADIUS};
use matscan_estimate::fit::scattering::FlashRender;
use matscan_scan::camera::PinholeCamera;
use matscan_scan::Param;
use matscan_sim::render::world::ObjectGeometry;
use matscan_sim::scene::model::PointLight;
use std::path::Path;

mod support;
use support::median;

const GRID: [f32; 10] = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0];

fn main() -> Result<(), support::Error> {
    let args: Vec<String> = std::env::args().collect();
    let root = Path::new(
        args.get(1)
            .ok_or("usage: scatter_probe DIR [CELLS] [SPP] [GREY]")?,
    );
    let size: usize = args.get(2).map_or(Ok(64), |s| s.parse())?;
    let spp: u32 = args.get(3).map_or(Ok(16), |s| s.parse())?;
    // A fixed grey in place of the truth's basecolor: how much the answer
    // leans on knowing the colour.
    let grey: Option<f32> = args.get(4).map(|s| s.parse()).transpose()?;
    // Whether each subsurface gets the basecolor that matches the photos'
    // level (two renders place it), before its residual.
    let auto = std::env::var("AUTO").is_ok();
    let panel_recipe = std::env::var("PANEL")
        .ok()
        .map(|p| matscan_sim::dataset::Recipe::read(Path::new(&p)))
        .transpose()?;
    for dir in matscan_scan::bundle::find_bundles(root)? {
        let scan = support::open(&dir)?;
        let (bundle, inputs) = (&scan.bundle, &scan.inputs);
        let name = dir
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().to_string());
        let ss = scan.truth(Param::Subsurface)?;
        let mt = scan.truth(Param::Metallic)?;
        let tr = scan.truth(Param::Transmission)?;
        let bc = scan.truth(Param::Basecolor)?;
        let ro = scan.truth(Param::Roughness)?;
        let n = inputs.pixels();
        let sel: Vec<bool> = (0..n)
            .map(|i| inputs.mask.data[i] && mt[i] < 0.5 && tr[i] < 0.05 && ss[i] > 0.05)
            .collect();
        let count = sel.iter().filter(|&&s| s).count();
        if count < 200 {
            println!("{name}: {count} scattering pixels, skipped");
            continue;
        }
        let pick = |v: &[f32]| median((0..n).filter(|&i| sel[i]).map(|i| v[i]).collect());
        let basecolor = grey.map_or_else(
            || {
                Vec3::from_array(std::array::from_fn(|c| {
                    median((0..n).filter(|&i| sel[i]).map(|i| bc[3 * i + c]).collect())
                }))
            },
            Vec3::splat,
        );
        let (truth_ss, roughness) = (pick(&ss), pick(&ro));
        let (w, h) = (inputs.width, inputs.height);
        let f = w / size;
        let (sw, sh) = (w / f, h / f);
        let mesh = bundle.read_mesh()?;
        let object = ObjectGeometry::new(&mesh);
        let reference = bundle.camera(&inputs.reference)?;
        let camera = PinholeCamera::new(
            reference.intrinsics.scaled_to(sw as u32, sh as u32),
            reference.camera_to_world,
        );
        let position = bundle.position(&inputs.reference)?;
        // PANEL=RECIPE: the simulator's backlight panel of this scene (the
        // recipe's scene regenerated), which reflects flash light back
        // onto the object in the photos; the product renders without it.
        let panel = match &panel_recipe {
            Some(recipe) => simulated_panel(recipe, &dir, &inputs.reference, camera.center())?,
            None => None,
        };
        // cells wholly of the selection
        let cell_ok: Vec<bool> = (0..sw * sh)
            .map(|k| {
                let (cx, cy) = (k % sw, k / sw);
                (0..f * f).all(|j| sel[(cy * f + j / f) * w + cx * f + j % f])
            })
            .collect();
        let mut line = format!(
            "{name}: truth ss {truth_ss:.2} bc {:.2} r {roughness:.2} cells {}",
            basecolor.x,
            cell_ok.iter().filter(|&&c| c).count()
        );
        // The reference position's flash views: photo cells and the light.
        let mut photos = Vec::new();
        let mut flashes = Vec::new();
        for view in inputs
            .views
            .iter()
            .filter(|v| v.view.position == inputs.reference)
        {
            let Some(flash) = position
                .light(&view.view.light)
                .and_then(PointLight::from_manifest)
            else {
                continue;
            };
            let photo: Vec<[f64; 3]> = (0..sw * sh)
                .map(|k| {
                    let (cx, cy) = (k % sw, k / sw);
                    let mut acc = [0.0f64; 3];
                    for j in 0..f * f {
                        let i = (cy * f + j / f) * w + cx * f + j % f;
                        for (c, a) in acc.iter_mut().enumerate() {
                            *a += f64::from(view.lit()[i][c] - view.ambient()[i][c]);
                        }
                    }
                    acc.map(|a| a / (f * f) as f64)
                })
                .collect();
            photos.push(photo);
            flashes.push(flash);
        }
        let exposure = inputs
            .views
            .iter()
            .find(|v| v.view.position == inputs.reference)
            .map_or(1.0, |v| v.ambient_exposure()) as f32;
        let cells: Vec<usize> = (0..sw * sh).filter(|&k| cell_ok[k]).collect();
        let render = |s: f32, basecolor: Vec3| {
            let m = Material {
                basecolor,
                roughness,
                metallic: 0.0,
                transmission: 0.0,
                subsurface: s,
                subsurface_radius: DEFAULT_SUBSURFACE_RADIUS,
            };
            let img = FlashRender {
                object: &object,
                panel: panel.as_ref(),
                camera,
                flashes: &flashes,
                cells: None,
                samples: spp,
                seed: 7,
            }
            .images(&m);
            img.slots
                .iter()
                .map(|slot| {
                    slot.data
                        .iter()
                        .map(|v| v.map(|x| x * exposure))
                        .collect::<Vec<[f32; 3]>>()
                })
                .collect::<Vec<_>>()
        };
        // Per channel, the photos' light over the render's on the cells.
        let gain = |r: &[Vec<[f32; 3]>]| -> Vec3 {
            Vec3::from_array(std::array::from_fn(|c| {
                let (mut p, mut q) = (0.0f64, 0.0f64);
                for (photo, slot) in photos.iter().zip(r) {
                    for &k in &cells {
                        p += photo[k][c];
                        q += f64::from(slot[k][c]);
                    }
                }
                (p / q.max(1e-30)) as f32
            }))
        };
        let ratio_residual = |r: &[Vec<[f32; 3]>]| -> f64 {
            if photos.len() != 2 {
                return f64::NAN;
            }
            let (mut sum, mut n) = (0.0f64, 0usize);
            for &k in &cells {
                let light = |v: [f32; 3]| f64::from(v[0] + v[1] + v[2]);
                let p0: f64 = photos[0][k].iter().sum();
                let p1: f64 = photos[1][k].iter().sum();
                let (r0, r1) = (light(r[0][k]), light(r[1][k]));
                if p0 + p1 > 0.0 && r0 + r1 > 0.0 {
                    sum += (p0 / (p0 + p1) - r0 / (r0 + r1)).powi(2);
                    n += 1;
                }
            }
            (sum / n.max(1) as f64).sqrt()
        };
        let mut gain_totals = vec![0.0f64; GRID.len()];
        let mut ratio_totals = vec![0.0f64; GRID.len()];
        let mut auto_totals = vec![0.0f64; GRID.len()];
        let mut auto_colour = vec![Vec3::ZERO; GRID.len()];
        let t = std::time::Instant::now();
        for (g, &s) in GRID.iter().enumerate() {
            let r = render(s, basecolor);
            for (photo, slot) in photos.iter().zip(&r) {
                for c in 0..3 {
                    let (mut pr, mut rr, mut pp) = (0.0f64, 0.0f64, 0.0f64);
                    for &k in &cells {
                        let (p, q) = (photo[k][c], f64::from(slot[k][c]));
                        pr += p * q;
                        rr += q * q;
                        pp += p * p;
                    }
                    gain_totals[g] += 1.0 - pr * pr / (rr * pp).max(1e-30);
                }
            }
            ratio_totals[g] = ratio_residual(&r);
            if auto {
                // The basecolor that gives this subsurface the photos'
                // level: the level is close to a power of the basecolor
                // (specular light and light lost through the object make
                // it far from linear), so two renders place it.
                let (lo, hi) = (0.25f32, 0.75f32);
                let (g_lo, g_hi) = (
                    gain(&render(s, Vec3::splat(lo))),
                    gain(&render(s, Vec3::splat(hi))),
                );
                let corrected = Vec3::from_array(std::array::from_fn(|c| {
                    let k = (g_lo[c] / g_hi[c]).max(1e-6).ln() / (hi / lo).ln();
                    let b = (lo.ln() + g_lo[c].max(1e-6).ln() / k.max(0.05)).exp();
                    b.clamp(0.01, 1.0)
                }));
                let r = render(s, corrected);
                auto_totals[g] = ratio_residual(&r);
                auto_colour[g] = corrected;
            }
        }
        let best = |v: &[f64]| {
            v.iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                .map_or(0, |b| b.0)
        };
        let fmt = |v: &[f64]| {
            v.iter()
                .map(|t| format!("{t:.4}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        line += &format!(
            " | gain best {:.2} [{}] | ratio best {:.2} [{}] | auto best {:.2} bc {:.2} [{}] | {:.2} s",
            GRID[best(&gain_totals)],
            fmt(&gain_totals),
            GRID[best(&ratio_totals)],
            fmt(&ratio_totals),
            GRID[best(&auto_totals)],
            auto_colour[best(&auto_totals)].x,
            fmt(&auto_totals),
            t.elapsed().as_secs_f64()
        );
        println!("{line}");
    }
    Ok(())
}

/// The backlight panel `recipe` rendered for the scan in `dir` at
/// `position` (p0, p1, ...), seen from `camera_center`.
fn simulated_panel(
    recipe: &matscan_sim::dataset::Recipe,
    dir: &Path,
    position: &str,
    camera_center: glam::DVec3,
) -> Result<Option<matscan_sim::render::lights::Panel>, support::Error> {
    let planned = recipe.scenes()?;
    let Some(scene) = planned.iter().find(|p| dir.ends_with(&p.folder)) else {
        return Ok(None);
    };
    let scene = matscan_sim::scene::generate(&scene.scene);
    let Some(at) = scene.rig.positions.iter().find(|p| p.name == position) else {
        return Ok(None);
    };
    Ok(matscan_sim::render::lights::Panel::new(
        &at.backlight,
        camera_center.as_vec3(),
    ))
}
