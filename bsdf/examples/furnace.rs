//! White-furnace directional albedo of matscan's Principled BSDF, for the
//! comparison with Mitsuba 3 in `docs/renderers.md` (`tools/mitsuba/furnace.py`
//! computes the same grid with Mitsuba's `principled`).
//!
//! A plane under a uniform environment of radiance 1 reflects (and
//! transmits) its directional albedo: the mean of `f cos / pdf` over
//! `Bsdf::sample`. Grid: roughness {0.05, 0.25, 0.5, 0.75, 1} x metallic
//! {0, 1} x transmission {0, 1} x view {0, 45, 75} degrees, base colour
//! white; plus base colour black for the dielectric (the specular lobe alone,
//! or the glass lobe's reflection alone). Prints JSON on stdout.
//!
//! ```text
//! cargo run --release -p matscan-bsdf --example furnace [-- SAMPLES]
//! ```

use glam::{DVec3, Vec3};
use matscan_bsdf::{Bsdf, LobeKind, Material};
use rand::Rng;
use rand_pcg::Pcg32;

const ROUGHNESS: [f32; 5] = [0.05, 0.25, 0.5, 0.75, 1.0];
const VIEW_DEG: [f32; 3] = [0.0, 45.0, 75.0];

/// Mean and standard error of reflected and transmitted `f cos / pdf`.
struct Albedo {
    reflect: Vec3,
    transmit: Vec3,
    stderr: Vec3,
}

fn albedo(mat: &Material, view_deg: f32, n: usize, rng: &mut Pcg32) -> Albedo {
    let theta = view_deg.to_radians();
    let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
    let bsdf = Bsdf::new(mat, Vec3::Z, Vec3::Z);
    // f64 sums: a variance from f32 sums of 4e5 samples cancels to nothing.
    let (mut reflect, mut transmit, mut sum2) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for _ in 0..n {
        let u = [rng.gen::<f32>(), rng.gen::<f32>(), rng.gen::<f32>()];
        let Some(s) = bsdf.sample(wo, u) else {
            continue;
        };
        // Subsurface is off in this grid; an entry would count as its walk's
        // expected return, the base colour.
        let w = match s.kind {
            LobeKind::SubsurfaceEntry => s.weight * mat.basecolor,
            _ => s.weight,
        }
        .as_dvec3();
        match s.kind {
            LobeKind::Transmission => transmit += w,
            _ => reflect += w,
        }
        sum2 += w * w;
    }
    let nf = n as f64;
    let (reflect, transmit) = (reflect / nf, transmit / nf);
    let mean = reflect + transmit;
    let var = (sum2 / nf - mean * mean).max(DVec3::ZERO);
    Albedo {
        reflect: reflect.as_vec3(),
        transmit: transmit.as_vec3(),
        stderr: (var / nf).powf(0.5).as_vec3(),
    }
}

fn vec(v: Vec3) -> String {
    format!("[{:.5}, {:.5}, {:.5}]", v.x, v.y, v.z)
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(400_000);
    let mut rng = Pcg32::new(0x853c_49e6_748f_ea9b, 0xda3e_39cb_94b9_5bdb);
    let mut rows = Vec::new();
    let cases = [
        (1.0, 0.0, 0.0),
        (1.0, 1.0, 0.0),
        (1.0, 0.0, 1.0),
        (1.0, 1.0, 1.0),
        (0.0, 0.0, 0.0),
        (0.0, 0.0, 1.0),
    ];
    for &(base, metallic, transmission) in &cases {
        for &roughness in &ROUGHNESS {
            let mat = Material {
                basecolor: Vec3::splat(base),
                roughness,
                metallic,
                transmission,
                subsurface: 0.0,
                subsurface_radius: Vec3::ONE,
            };
            for &view in &VIEW_DEG {
                let a = albedo(&mat, view, n, &mut rng);
                rows.push(format!(
                    "    {{\"basecolor\": {base:.1}, \"roughness\": {roughness}, \"metallic\": {metallic:.1}, \
                     \"transmission\": {transmission:.1}, \"view_deg\": {view:.0}, \"albedo\": {}, \
                     \"reflect\": {}, \"transmit\": {}, \"stderr\": {}}}",
                    vec(a.reflect + a.transmit),
                    vec(a.reflect),
                    vec(a.transmit),
                    vec(a.stderr)
                ));
            }
        }
    }
    println!(
        "{{\n  \"renderer\": \"matscan-bsdf\",\n  \"samples\": {n},\n  \"rows\": [\n{}\n  ]\n}}",
        rows.join(",\n")
    );
}
