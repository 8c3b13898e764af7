//! The mesh's UV atlas rasterized at the texture's size: for every texel
//! centre, the triangle whose UV image covers it, so that the texel maps
//! to one surface point.
//!
//! Triangles are rasterized one by one in UV space, so vertices split at
//! UV seams need no special care: each chart is drawn from its own
//! triangles. Where charts overlap (mirrored or stacked UVs), the lowest
//! triangle index wins, which keeps the result deterministic. Around every
//! chart a gutter of a few texels is assigned to the nearest triangle of a
//! neighbouring texel, evaluated at the closest point of that triangle: a
//! bilinear (or mip-mapped) lookup across a chart border then reads
//! measured surface values instead of whatever lies outside the chart.
//! UVs are used as they are (no wrapping): texels exist for `[0, 1]^2`.
//!
//! Boundaries: UV space only; what a texel sees is [`crate::fuse`]'s job.

use glam::Vec2;
use matscan_scan::{Mesh, SurfacePoint};
use rayon::prelude::*;

/// What a texel is in the atlas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TexelKind {
    /// No triangle covers it or lies within the gutter.
    Outside,
    /// Its centre lies on a triangle.
    Inside,
    /// Within the gutter of a chart: mapped to the closest point of a
    /// neighbouring texel's triangle.
    Gutter,
}

/// The rasterized atlas.
#[derive(Debug, Clone)]
pub struct Atlas {
    width: u32,
    height: u32,
    /// Triangle per texel, [`NO_TRIANGLE`] for [`TexelKind::Outside`].
    triangle: Vec<u32>,
    kind: Vec<TexelKind>,
}

const NO_TRIANGLE: u32 = u32::MAX;

/// Barycentric tolerance: texel centres on a shared edge belong to both
/// triangles (the lower index wins) rather than to neither.
const EDGE_EPS: f32 = 1e-5;

impl Atlas {
    /// Rasterizes `uvs` (per vertex of `mesh`, origin bottom left) at
    /// `width` x `height` with a gutter of `gutter` texels.
    pub fn rasterize(mesh: &Mesh, uvs: &[Vec2], width: u32, height: u32, gutter: u32) -> Atlas {
        let (w, h) = (width as usize, height as usize);
        let texel_space = |uv: Vec2| {
            Vec2::new(
                uv.x * width as f32 - 0.5,
                (1.0 - uv.y) * height as f32 - 0.5,
            )
        };
        let corners: Vec<Option<[Vec2; 3]>> = mesh
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(|i| uvs.get(i as usize).copied().map(texel_space));
                match c {
                    [Some(a), Some(b), Some(c)] if [a, b, c].iter().all(|p| p.is_finite()) => {
                        Some([a, b, c])
                    }
                    _ => None,
                }
            })
            .collect();
        // Per row of texels, the triangles whose bounds reach it.
        let mut rows: Vec<Vec<u32>> = vec![Vec::new(); h];
        for (t, c) in corners.iter().enumerate() {
            let Some([a, b, c]) = c else { continue };
            if cross(*b - *a, *c - *a) == 0.0 {
                continue;
            }
            let (lo, hi) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
            let (y0, y1) = (lo.ceil().max(0.0), hi.floor().min(h as f32 - 1.0));
            if y0 > y1 {
                continue;
            }
            for row in &mut rows[y0 as usize..=y1 as usize] {
                row.push(t as u32);
            }
        }
        let mut triangle = vec![NO_TRIANGLE; w * h];
        triangle
            .par_chunks_mut(w)
            .zip(rows.par_iter())
            .enumerate()
            .for_each(|(y, (out, tris))| {
                let py = y as f32;
                for &t in tris {
                    let Some([a, b, c]) = corners[t as usize] else {
                        continue;
                    };
                    let (lo, hi) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
                    let (x0, x1) = (lo.ceil().max(0.0), hi.floor().min(w as f32 - 1.0));
                    if x0 > x1 {
                        continue;
                    }
                    let span = &mut out[x0 as usize..=x1 as usize];
                    for (x, texel) in (x0 as usize..).zip(span.iter_mut()) {
                        if *texel <= t {
                            continue;
                        }
                        let (u, v) = barycentric(Vec2::new(x as f32, py), a, b, c);
                        if u >= -EDGE_EPS && v >= -EDGE_EPS && u + v <= 1.0 + EDGE_EPS {
                            *texel = t;
                        }
                    }
                }
            });
        let mut kind: Vec<TexelKind> = triangle
            .iter()
            .map(|&t| {
                if t == NO_TRIANGLE {
                    TexelKind::Outside
                } else {
                    TexelKind::Inside
                }
            })
            .collect();
        for _ in 0..gutter {
            let before = triangle.clone();
            let grown: Vec<(usize, u32)> = (0..h)
                .into_par_iter()
                .flat_map_iter(|y| {
                    let before = &before;
                    let corners = &corners;
                    (0..w).filter_map(move |x| {
                        if before[y * w + x] != NO_TRIANGLE {
                            return None;
                        }
                        let p = Vec2::new(x as f32, y as f32);
                        let mut best: Option<(f32, u32)> = None;
                        for (dx, dy) in NEIGHBOURS {
                            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                                continue;
                            }
                            let t = before[ny as usize * w + nx as usize];
                            let Some(Some([a, b, c])) = corners.get(t as usize) else {
                                continue;
                            };
                            let (_, _, d) = closest_barycentric(p, *a, *b, *c);
                            if best.is_none_or(|(bd, bt)| d < bd || (d == bd && t < bt)) {
                                best = Some((d, t));
                            }
                        }
                        best.map(|(_, t)| (y * w + x, t))
                    })
                })
                .collect();
            if grown.is_empty() {
                break;
            }
            for (i, t) in grown {
                triangle[i] = t;
                kind[i] = TexelKind::Gutter;
            }
        }
        Atlas {
            width,
            height,
            triangle,
            kind,
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub fn kind(&self, x: u32, y: u32) -> TexelKind {
        self.kind[self.index(x, y)]
    }

    /// The triangle a texel maps to, `None` outside every chart and gutter.
    pub fn triangle(&self, x: u32, y: u32) -> Option<u32> {
        let t = self.triangle[self.index(x, y)];
        (t != NO_TRIANGLE).then_some(t)
    }

    /// Number of texels inside a chart (not counting the gutter).
    pub fn inside_count(&self) -> usize {
        self.kind
            .iter()
            .filter(|&&k| k == TexelKind::Inside)
            .count()
    }

    /// The surface point of texel (`x`, `y`): the point of its triangle
    /// whose UV is closest to the texel centre's (the centre itself inside
    /// a chart). `uvs` must be the ones the atlas was rasterized from.
    pub fn surface(&self, mesh: &Mesh, uvs: &[Vec2], x: u32, y: u32) -> Option<SurfacePoint> {
        let t = self.triangle(x, y)?;
        let [ia, ib, ic] = *mesh.triangles.get(t as usize)?;
        let uv = |i: u32| uvs.get(i as usize).copied();
        let (a, b, c) = (uv(ia)?, uv(ib)?, uv(ic)?);
        let p = crate::textures::texel_uv(x, y, self.width, self.height);
        let (u, v, _) = closest_barycentric(p, a, b, c);
        let sp = mesh.surface(t, u, v);
        (sp.position.is_finite() && sp.shading_normal.is_finite()).then_some(sp)
    }

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }
}

const NEIGHBOURS: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

fn cross(a: Vec2, b: Vec2) -> f32 {
    a.x * b.y - a.y * b.x
}

/// (u, v) with `p = (1-u-v) a + u b + v c`; the triangle must not be
/// degenerate.
fn barycentric(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> (f32, f32) {
    let d = cross(b - a, c - a);
    let ap = p - a;
    (cross(ap, c - a) / d, cross(b - a, ap) / d)
}

/// Barycentrics (u, v) of the point of triangle `abc` closest to `p`, and
/// its distance; degenerate triangles reduce to their longest edge.
pub(crate) fn closest_barycentric(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> (f32, f32, f32) {
    if cross(b - a, c - a).abs() > f32::MIN_POSITIVE {
        let (u, v) = barycentric(p, a, b, c);
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && u.is_finite() && v.is_finite() {
            return (u, v, 0.0);
        }
    }
    // Closest point on each edge, as (distance, u, v).
    let edge = |s: Vec2, e: Vec2| {
        let d = e - s;
        let len2 = d.length_squared();
        let t = if len2 > 0.0 {
            ((p - s).dot(d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p.distance(s + d * t), t)
    };
    let (dab, tab) = edge(a, b);
    let (dbc, tbc) = edge(b, c);
    let (dca, tca) = edge(c, a);
    if dab <= dbc && dab <= dca {
        (tab, 0.0, dab)
    } else if dbc <= dca {
        (1.0 - tbc, tbc, dbc)
    } else {
        (0.0, 1.0 - tca, dca)
    }
}
