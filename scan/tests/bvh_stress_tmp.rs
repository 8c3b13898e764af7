use glam::Vec3;
use matscan_scan::bvh::{intersect_triangle, Bvh, Ray};
use matscan_scan::Mesh;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
#[test]
fn stress() {
    let mut rng = Pcg64::seed_from_u64(99);
    let mut bad = 0;
    let mut total = 0;
    for scale in [1e-3f32, 1.0, 1e3] {
        for round in 0..3 {
        let n = 3000;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        let centre_off = Vec3::splat(if round == 2 { 5.0 * scale } else { 0.0 });
        for i in 0..n {
            let c = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * scale + centre_off;
            let s = scale * 10f32.powf(rng.gen_range(-3.0..-0.5));
            let r = |rng: &mut Pcg64| Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)) * s;
            let base = positions.len() as u32;
            positions.extend([c + r(&mut rng), c + r(&mut rng), c + r(&mut rng)]);
            triangles.push([base, base + 1, base + 2]);
            if i % 2 == 0 && base > 0 { triangles.push([base - 1, base, base + 1]); }
        }
        let mesh = Mesh { positions, normals: None, uvs: None, triangles };
        let bvh = Bvh::build(&mesh);
        for k in 0..100000 {
            let dist = scale * [1.5f32, 10.0, 1000.0][k % 3];
            let o = Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)).normalize() * dist + centre_off;
            let tri = mesh.triangles[rng.gen_range(0..mesh.triangles.len())];
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            let target = match k % 4 { 0 => a, 1 => (a + b) * 0.5, 2 => a + (c - a) * rng.gen_range(0.0..1.0), _ => b };
            let ray = Ray::new(o, (target - o).normalize());
            let mut best: Option<(f32, u32)> = None;
            let mut r = ray;
            for (t, tri) in mesh.triangles.iter().enumerate() {
                let v = tri.map(|i| mesh.positions[i as usize]);
                if let Some((th, _, _)) = intersect_triangle(&r, &v) { r.t_max = th; best = Some((th, t as u32)); }
            }
            let got = bvh.intersect(&ray).map(|h| h.t);
            total += 1;
            if got != best.map(|b| b.0) { bad += 1; if bad < 5 { println!("scale {scale} dist {dist} {got:?} vs {best:?}"); } }
            if bvh.occluded(&ray) != best.is_some() { bad += 1; }
        }
        }
    }
    println!("bad {bad} / {total}");
    assert_eq!(bad, 0);
}
