//! How much of a rendered board's corner error is the renderer's noise:
//! the simulated rig's board at its reference placement (the rig of
//! `matscan calib board --seed 1`, 1024 px, 16 paths per pixel) rendered
//! three times with different seeds of the path tracer, its corners found
//! in each, and the differences' RMS between every two renders. The
//! per-photo figure (the difference over the square root of two, per
//! coordinate) is the noise `board_design` puts on its synthetic corners.
//!
//! ```sh
//! cargo run --release -p matscan-rigcal --example render_noise
//! ```
use matscan_rigcal::detect::find_board;
use matscan_sim::calib_target::{
    board_for, board_rig, board_scene, reference_placement, BoardBundleOptions, INNER_CORNERS,
};
use matscan_sim::render::{CaptureSpec, RenderOptions, Renderer};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (rig, _) = board_rig(&BoardBundleOptions::default());
    let board = board_for(&rig, INNER_CORNERS);
    let scene = board_scene(&board, reference_placement(&board, &rig), &rig);
    let renderer = Renderer::new(&scene)?;
    let capture = [CaptureSpec::new("board", &["flash0", "flash1"], None)];
    let mut found = Vec::new();
    for seed in [1u64, 2, 3] {
        let opts = RenderOptions {
            samples: 16,
            seed,
            ..RenderOptions::default()
        };
        let photo = renderer
            .render_position(0, &capture, &opts)?
            .photos
            .remove(0);
        found.push(find_board(&photo, &board, Path::new("render"))?);
    }
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        let d: Vec<f64> = found[a]
            .iter()
            .zip(&found[b])
            .map(|(p, q)| (p.pixel - q.pixel).length_squared())
            .collect();
        let rms = (d.iter().sum::<f64>() / d.len() as f64).sqrt();
        println!(
            "seeds {a} {b}: corner difference RMS {rms:.4} px (per photo {:.4} px per coordinate)",
            rms / 2f64.sqrt() / 2f64.sqrt()
        );
    }
    Ok(())
}
