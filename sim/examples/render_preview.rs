//! Renders one position of a generated scene and writes a contact sheet of
//! its captures (8-bit sRGB previews, side by side), for looking at the
//! renderer's output.
//!
//! `cargo run --release -p matscan-sim --example render_preview -- OUT.png [kind] [seed] [size] [samples]`

use matscan_scan::raster::RgbRaster;
use matscan_sim::render::{RenderOptions, Renderer};
use matscan_sim::scene::kinds::SceneKind;
use matscan_sim::scene::{generate, SceneOptions};
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(out) = args.get(1).map(PathBuf::from) else {
        eprintln!("usage: render_preview OUT.png [kind] [seed] [size] [samples]");
        return;
    };
    let kind: SceneKind = args
        .get(2)
        .and_then(|k| k.parse().ok())
        .unwrap_or(SceneKind::Multimat);
    let seed: u64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let size: u32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(128);
    let samples: u32 = args.get(5).and_then(|s| s.parse().ok()).unwrap_or(32);
    let scene = generate(&SceneOptions {
        seed,
        kind,
        width: size,
        height: size,
        positions: 1,
        ..SceneOptions::default()
    });
    let rig = &scene.rig.positions[0];
    let flash_names: Vec<&str> = rig.flashes.iter().map(|f| f.name.as_str()).collect();
    let mut specs = vec![matscan_sim::render::CaptureSpec::new("ambient", &[], None)];
    for f in &flash_names {
        specs.push(matscan_sim::render::CaptureSpec::new(f, &[f], None));
    }
    let projector = rig.projector.name.as_str();
    specs.push(matscan_sim::render::CaptureSpec::new(
        "projector",
        &[projector],
        Some(matscan_scan::Pattern::Uniform { level: 0.5 }),
    ));
    specs.push(matscan_sim::render::CaptureSpec::new(
        "backlight",
        &[rig.backlight.name.as_str()],
        None,
    ));
    let (small, large) = matscan_sim::render::bundle_writer::checker_periods(&scene);
    for period in [small, large] {
        specs.push(matscan_sim::render::CaptureSpec::new(
            "checker",
            &[projector],
            Some(matscan_scan::Pattern::Checker {
                period_px: period as f64,
                phase_px: [0.0, 0.0],
                low: 0.0,
                high: 1.0,
            }),
        ));
    }
    let result = Renderer::new(&scene).and_then(|r| {
        let opts = RenderOptions {
            samples,
            ..RenderOptions::default()
        };
        let images = r.render_position(0, &specs, &opts)?;
        let illum = r.render_illum(0, &specs[1..2], &opts)?;
        Ok((images, illum))
    });
    let (images, illum) = match result {
        Ok(x) => x,
        Err(e) => {
            eprintln!("render failed: {e}");
            return;
        }
    };
    let mut tiles: Vec<&RgbRaster> = images.photos.iter().collect();
    tiles.extend(illum.iter());
    let sheet = RgbRaster::from_fn(size * tiles.len() as u32, size, |x, y| {
        *tiles[(x / size) as usize].get(x % size, y)
    });
    match matscan_scan::image_io::write_preview_png(&out, &sheet) {
        Ok(()) => println!(
            "{}: {} ({}), captures: {}, then illum_{}",
            out.display(),
            scene.name,
            scene.kind,
            specs
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(" "),
            flash_names.first().unwrap_or(&"")
        ),
        Err(e) => eprintln!("cannot write {}: {e}", out.display()),
    }
}
