use matscan_scan::image_io::*;
use matscan_scan::manifest::Encoding;
use matscan_scan::raster::Raster;
use rand::{Rng, SeedableRng};
use std::io::Write;

#[test]
fn probe() {
    let dir = tempfile::tempdir().unwrap();
    let img = Raster::from_fn(9, 5, |x, y| [x as f32 * 0.1, y as f32 * 0.2, 0.3]);
    let mask = Raster::from_fn(9, 5, |x, y| (x + y) % 2 == 0);
    let paths = ["half.exr", "float.exr", "photo.png", "mask.png"].map(|n| dir.path().join(n));
    write_rgb_exr(&paths[0], &img, Precision::Half).unwrap();
    write_rgb_exr(&paths[1], &img, Precision::Float).unwrap();
    write_rgb_png16(&paths[2], &img, Encoding::Srgb).unwrap();
    write_mask_png(&paths[3], &mask).unwrap();
    let files: Vec<Vec<u8>> = paths.iter().map(|p| std::fs::read(p).unwrap()).collect();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    for case in 0..3000 {
        let which = rng.gen_range(0..4);
        let mut bytes = files[which].clone();
        let span = if rng.gen() { bytes.len().min(400) } else { bytes.len() };
        let mut flips = vec![];
        for _ in 0..rng.gen_range(1..6) {
            let i = rng.gen_range(0..span);
            let b: u8 = rng.gen();
            bytes[i] = b;
            flips.push((i, b));
        }
        let ext = if which < 2 { "exr" } else { "png" };
        let p = dir.path().join(format!("probe.{ext}"));
        std::fs::write(&p, &bytes).unwrap();
        eprintln!("case {case} which {which} flips {flips:?}");
        std::io::stderr().flush().unwrap();
        let t = std::time::Instant::now();
        if which < 2 { let _ = read_rgb_exr(&p); let _ = read_scalar_exr(&p); } else { let _ = read_rgb_png(&p, Encoding::Srgb); let _ = read_mask_png(&p); }
        if t.elapsed().as_millis() > 200 { eprintln!("SLOW {:?}", t.elapsed()); }
    }
}
