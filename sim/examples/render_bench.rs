//! Renderer benchmark.
//!
//! (a) A full simulated scan (3 positions, 256 x 256, every capture plus
//!     truth, written as a bundle) at the default sample count: wall time.
//! (b) Render time against noise for several sample counts on one position
//!     at 128 x 128: RMSE of the photos against a reference with 16 times
//!     the default samples.
//!
//! `cargo run --release -p matscan-sim --example render_bench [seed] [threads] [--noise-only | --scan-only] [--kind=KIND] [--samples=N]`

use matscan_sim::render::{
    write_scan_bundle, CaptureSpec, RenderOptions, Renderer, SimOptions, DEFAULT_SAMPLES,
};
use matscan_sim::scene::kinds::SceneKind;
use matscan_sim::scene::{generate, SceneOptions};
use std::time::Instant;

fn main() {
    let all: Vec<String> = std::env::args().collect();
    let noise_only = all.iter().any(|a| a == "--noise-only");
    let scan_only = all.iter().any(|a| a == "--scan-only");
    let kind: Option<SceneKind> = all
        .iter()
        .find_map(|a| a.strip_prefix("--kind="))
        .and_then(|k| k.parse().ok());
    let samples: u32 = all
        .iter()
        .find_map(|a| a.strip_prefix("--samples="))
        .and_then(|k| k.parse().ok())
        .unwrap_or(DEFAULT_SAMPLES);
    let args: Vec<String> = all.into_iter().filter(|a| !a.starts_with("--")).collect();
    let seed: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(7);
    let threads: Option<usize> = args.get(2).and_then(|s| s.parse().ok());
    if let Some(n) = threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("cannot size the thread pool: {e}");
        }
    }
    println!(
        "threads: {}, default samples: {DEFAULT_SAMPLES}",
        rayon::current_num_threads()
    );

    let kind = kind.unwrap_or(SceneKind::Multimat);
    if !noise_only {
        full_scan(seed, kind, samples);
    }
    if !scan_only {
        time_against_noise(seed, kind);
    }
}

/// (a) The full scan.
fn full_scan(seed: u64, kind: SceneKind, samples: u32) {
    let scene = generate(&SceneOptions {
        seed,
        kind,
        ..SceneOptions::default()
    });
    let dir = std::env::temp_dir().join(format!("matscan-render-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let start = Instant::now();
    let opts = SimOptions {
        samples,
        ..SimOptions::default()
    };
    let result = write_scan_bundle(&scene, &opts, &dir);
    let secs = start.elapsed().as_secs_f64();
    match result {
        Ok(bundle) => println!(
            "full scan `{}` ({}), {samples} spp: {} positions x {} captures at {}x{} + truth: {secs:.1} s",
            scene.name,
            scene.kind,
            bundle.manifest.positions.len(),
            bundle.manifest.positions[0].captures.len(),
            bundle.manifest.camera.width,
            bundle.manifest.camera.height,
        ),
        Err(e) => println!("full scan failed after {secs:.1} s: {e}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// (b) Time against noise.
fn time_against_noise(seed: u64, kind: SceneKind) {
    let scene = generate(&SceneOptions {
        seed,
        kind,
        width: 128,
        height: 128,
        positions: 1,
        ..SceneOptions::default()
    });
    let renderer = match Renderer::new(&scene) {
        Ok(r) => r,
        Err(e) => {
            println!("cannot render: {e}");
            return;
        }
    };
    let captures = [
        CaptureSpec::new("ambient", &[], None),
        CaptureSpec::new("flash0", &["flash0"], None),
        CaptureSpec::new("flash1", &["flash1"], None),
        CaptureSpec::new(
            "projector",
            &["projector"],
            Some(matscan_scan::Pattern::Uniform { level: 0.5 }),
        ),
        CaptureSpec::new("backlight", &["backlight"], None),
    ];
    let render = |samples: u32, seed: u64| {
        let opts = RenderOptions {
            samples,
            seed,
            ..RenderOptions::default()
        };
        let start = Instant::now();
        let images = renderer.render_position(0, &captures, &opts);
        (images, start.elapsed().as_secs_f64())
    };
    let reference_samples = DEFAULT_SAMPLES * 16;
    let (reference, ref_secs) = render(reference_samples, 1_000);
    let Ok(reference) = reference else {
        println!("reference render failed");
        return;
    };
    println!(
        "\none position, 128x128, {} captures; reference {reference_samples} spp ({ref_secs:.1} s)",
        captures.len()
    );
    let mean: f64 = reference
        .photos
        .iter()
        .flat_map(|p| p.data.iter().flatten())
        .map(|&v| v as f64)
        .sum::<f64>()
        / (reference.photos.len() * 128 * 128 * 3) as f64;
    println!("mean photo value {mean:.4}");
    let (_, photos_secs) = render(DEFAULT_SAMPLES, 1);
    let start = Instant::now();
    let illum = renderer.render_illum(0, &captures[1..4], &RenderOptions::default());
    let illum_secs = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let truth = renderer.render_truth(0);
    let truth_secs = start.elapsed().as_secs_f64();
    if illum.is_ok() && truth.is_ok() {
        println!(
            "at {DEFAULT_SAMPLES} spp: photo pass {photos_secs:.2} s, illum pass {illum_secs:.2} s, truth {truth_secs:.3} s"
        );
    }
    let names: Vec<&str> = captures.iter().map(|c| c.name.as_str()).collect();
    println!(
        "{:>6} {:>8} {:>10} {:>11}   relative RMSE per capture: {}",
        "spp",
        "time s",
        "RMSE",
        "RMSE/mean",
        names.join(" ")
    );
    for samples in [4, 8, 16, 32, 64] {
        let (images, secs) = render(samples, 1);
        let Ok(images) = images else {
            println!("{samples:>6} failed");
            continue;
        };
        let (mut sq, mut n) = (0.0f64, 0usize);
        let mut per_capture = Vec::new();
        for (a, b) in images.photos.iter().zip(&reference.photos) {
            let (mut csq, mut cmean) = (0.0f64, 0.0f64);
            for (pa, pb) in a.data.iter().zip(&b.data) {
                for c in 0..3 {
                    let d = (pa[c] - pb[c]) as f64;
                    csq += d * d;
                    cmean += pb[c] as f64;
                }
            }
            let m = (a.data.len() * 3) as f64;
            per_capture.push(format!("{:.3}", (csq / m).sqrt() / (cmean / m).max(1e-12)));
            sq += csq;
            n += a.data.len() * 3;
        }
        let rmse = (sq / n as f64).sqrt();
        println!(
            "{samples:>6} {secs:>8.2} {rmse:>10.5} {:>11.4}   {}",
            rmse / mean.max(1e-12),
            per_capture.join(" ")
        );
    }
}
