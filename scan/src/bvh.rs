//! Ray casting against a [`Mesh`]: closest hit, any hit (shadows), and the
//! offsets that keep secondary rays from hitting the surface they start on.
//!
//! The [`Bvh`] is a binary bounding volume hierarchy built with the binned
//! surface area heuristic (16 bins per axis, all three axes tried, at most
//! [`MAX_LEAF`] triangles per leaf). Nodes are flattened into one array,
//! the two children of a node side by side in one 64-byte cache line;
//! triangles are copied into leaf order. Traversal uses a fixed stack,
//! visits the nearer child first and skips popped nodes that start beyond
//! the closest hit so far; occlusion stops at the first hit. The triangle
//! test is the watertight test of Woop, Benthin and Wald (JCGT 2013): rays
//! through a shared edge or vertex of a closed mesh never slip between its
//! triangles (double-precision fallback on exact zeros). Boxes are widened
//! per ray by a few ulps of the ray's and the scene's magnitude, so culling
//! never drops a hit the triangle test would report: [`Bvh::intersect`]
//! equals a brute-force loop over [`intersect_triangle`] (tested, including
//! rays aimed at vertices and edges). Triangles are two-sided. Zero-area
//! and non-finite triangles are left out at build time.
//!
//! Offsets: a hit point is only known to within a few ulps of the
//! coordinates involved, so a ray starting exactly there can hit its own
//! triangle again. [`offset_origin`] moves a point along the normal by
//! `2^-15 · max(|p|∞, 1e-3)` (about 256 ulps); [`offset_origin_scaled`] and
//! [`RayCaster`] use the scene's magnitude instead of `1e-3`, which also
//! covers points near the world origin on large triangles. Both hold at
//! scene scales 1e-3 to 1e3 (tested).
//!
//! Measured with `cargo run --release -p matscan-scan --example
//! raycast_bench` on a 2-core CI-class machine shared with other jobs
//! (load 4 to 6), 524 172-triangle displaced sphere, medians of 5 runs,
//! single-thread rates in on-CPU time (wall time was up to 2x worse under
//! that load):
//!
//! | what | figure |
//! | --- | --- |
//! | build (single thread) | 0.48 to 0.50 s on-CPU, 0.69 to 0.75 s wall |
//! | primary rays, closest hit (56% hit) | 2.5 Mrays/s |
//! | random rays, closest hit (85% hit) | 0.6 Mrays/s |
//! | shadow rays from primary hits, occlusion | 1.9 Mrays/s |
//! | random rays, occlusion | 0.8 Mrays/s |
//!
//! Both cores (`std::thread::scope`, two chunks; rayon is not a dependency
//! of this crate) scaled 1.9x to 2.1x in the least loaded run (random
//! closest 0.69 to 1.42 Mrays/s wall). Incoherent rays are bound by memory
//! latency: nodes and leaf triangles take 37 MB for this mesh. Binary PLY
//! reads in 30 ms, OBJ in 0.34 s.
//!
//! Boundaries: geometry only. Cameras make rays ([`crate::camera`]); shading
//! and sampling belong to the renderer.

use crate::mesh::{Mesh, SurfacePoint};
use glam::{DVec2, Vec3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Unit length.
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    pub fn segment(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Self {
            origin,
            dir,
            t_min,
            t_max,
        }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Closest intersection: distance along the ray, triangle, barycentrics
/// (point = (1-u-v) a + u b + v c).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub u: f32,
    pub v: f32,
}

/// Most triangles in one leaf.
pub const MAX_LEAF: usize = 4;
const BINS: usize = 16;
/// Cost of one node visit relative to one triangle test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;
/// Beyond this depth nodes split at the median, so depth (and the fixed
/// traversal stack) stays bounded whatever the triangle distribution.
const SAH_MAX_DEPTH: usize = 64;
/// `SAH_MAX_DEPTH` plus log2 of the largest triangle count, plus margin.
const STACK_SIZE: usize = 128;
/// Relative offset of [`offset_origin`]: 2^-15, about 256 ulps.
const OFFSET_REL: f32 = 1.0 / 32768.0;
/// Smallest magnitude [`offset_origin`] assumes, the smallest scene scale
/// supported.
const OFFSET_MIN_MAGNITUDE: f32 = 1e-3;
/// `1 + 2 γ(3)` (PBRT's bound on three f32 roundings): box exits are pushed
/// out by this factor so rounding cannot cull a hit.
const BOX_PAD: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
/// The watertight test is exact in its decisions but works on rounded
/// sheared coordinates, so it can accept a ray that passes a few ulps (of
/// the ray origin's and the vertices' magnitudes) outside the triangle.
/// Boxes are widened per ray by this many ulps of that magnitude so that
/// culling never drops such a hit (bound with a margin: about 5 roundings
/// of the shear and edge functions, times sqrt(3) for norms).
const BOX_SLACK_ULPS: f32 = 16.0;

/// One flattened node: 32 bytes. A leaf has `count > 0` triangles from
/// `first` (leaf order); an inner node has `count == 0` and children
/// `first` and `first + 1`.
#[derive(Debug, Clone, Copy)]
struct Node {
    min: Vec3,
    first: u32,
    max: Vec3,
    count: u32,
}

/// Two sibling nodes in one 64-byte cache line: traversal tests both
/// children of a node together, so one line fetch serves both. Node `i` is
/// `pairs[i / 2].0[i % 2]`; the root is node 0 and node 1 is unused.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct NodePair([Node; 2]);

#[derive(Clone)]
pub struct Bvh {
    pairs: Vec<NodePair>,
    /// Vertices of each triangle in leaf order.
    tris: Vec<[Vec3; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    ids: Vec<u32>,
    /// Largest absolute coordinate of the root bounds (0 when empty).
    magnitude: f32,
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh")
            .field("nodes", &self.node_count())
            .field("triangles", &self.tris.len())
            .field("bounds", &self.bounds())
            .finish()
    }
}

/// A triangle during the build: its bounds and mesh index.
#[derive(Debug, Clone, Copy)]
struct PrimRef {
    min: Vec3,
    max: Vec3,
    id: u32,
}

impl PrimRef {
    fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

#[derive(Debug, Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    fn grow(&mut self, min: Vec3, max: Vec3) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// Where to split a node: bins `0..=bin` on `axis` go left.
#[derive(Debug, Clone, Copy)]
struct Split {
    axis: usize,
    bin: usize,
    cost: f32,
}

impl Bvh {
    /// Builds the hierarchy over every triangle of `mesh` that can be hit
    /// (finite, non-zero area, indices in range).
    pub fn build(mesh: &Mesh) -> Self {
        let mut refs: Vec<PrimRef> = Vec::with_capacity(mesh.triangles.len());
        let mut tris_by_id: Vec<[Vec3; 3]> = Vec::with_capacity(mesh.triangles.len());
        for (id, tri) in mesh.triangles.iter().enumerate() {
            let fetch = |i: u32| mesh.positions.get(i as usize).copied();
            let (Some(a), Some(b), Some(c)) = (fetch(tri[0]), fetch(tri[1]), fetch(tri[2])) else {
                tris_by_id.push([Vec3::ZERO; 3]);
                continue;
            };
            tris_by_id.push([a, b, c]);
            if !hittable(&[a, b, c]) {
                continue;
            }
            refs.push(PrimRef {
                min: a.min(b).min(c),
                max: a.max(b).max(c),
                id: id as u32,
            });
        }
        let mut pairs = Vec::with_capacity(refs.len() / 2 + 1);
        if !refs.is_empty() {
            let blank = Node {
                min: Vec3::ZERO,
                first: 0,
                max: Vec3::ZERO,
                count: 0,
            };
            pairs.push(NodePair([blank; 2]));
            fn at(pairs: &mut [NodePair], i: usize) -> &mut Node {
                &mut pairs[i / 2].0[i % 2]
            }
            let mut work = vec![(0usize, 0usize, refs.len(), 0usize)];
            while let Some((node, start, end, depth)) = work.pop() {
                let (bounds, centroids) = range_bounds(&refs[start..end]);
                at(&mut pairs, node).min = bounds.min;
                at(&mut pairs, node).max = bounds.max;
                let count = end - start;
                let split = if depth < SAH_MAX_DEPTH {
                    best_split(&refs[start..end], &centroids)
                } else {
                    None
                };
                let leaf_cost = count as f32 * bounds.half_area();
                let mid = match split {
                    Some(s)
                        if count > MAX_LEAF
                            || TRAVERSAL_COST * bounds.half_area() + s.cost < leaf_cost =>
                    {
                        partition(&mut refs[start..end], &centroids, s)
                    }
                    _ if count > MAX_LEAF => median_split(&mut refs[start..end], &centroids),
                    _ => {
                        at(&mut pairs, node).first = start as u32;
                        at(&mut pairs, node).count = count as u32;
                        continue;
                    }
                };
                let left = 2 * pairs.len();
                at(&mut pairs, node).first = left as u32;
                at(&mut pairs, node).count = 0;
                pairs.push(NodePair([blank; 2]));
                // Right first on the work stack, so the left subtree is built
                // (and laid out) first.
                work.push((left + 1, start + mid, end, depth + 1));
                work.push((left, start, start + mid, depth + 1));
            }
        }
        let tris = refs.iter().map(|r| tris_by_id[r.id as usize]).collect();
        let ids = refs.iter().map(|r| r.id).collect();
        let magnitude = pairs.first().map_or(0.0, |p| {
            p.0[0].min.abs().max(p.0[0].max.abs()).max_element()
        });
        Self {
            pairs,
            tris,
            ids,
            magnitude,
        }
    }

    /// Bounds of every triangle that can be hit; `None` when there are none.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.pairs.first().map(|p| (p.0[0].min, p.0[0].max))
    }

    /// Number of nodes (inner and leaves).
    pub fn node_count(&self) -> usize {
        (2 * self.pairs.len()).saturating_sub(1)
    }

    #[inline]
    fn node(&self, i: usize) -> &Node {
        &self.pairs[i / 2].0[i % 2]
    }

    /// Closest hit with `t` in `(ray.t_min, ray.t_max)`; `None` for a miss or
    /// a ray with a non-finite origin or a zero or non-finite direction.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let pre = Prepared::new(ray, self.magnitude)?;
        let mut t_max = ray.t_max;
        let mut best = None;
        let root = &self.pairs.first()?.0[0];
        pre.hit_box(root, ray.t_min, t_max)?;
        let mut stack = [(0u32, 0f32); STACK_SIZE];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            let n = self.node(node);
            if n.count > 0 {
                let first = n.first as usize;
                for i in first..first + n.count as usize {
                    if let Some((t, u, v)) = pre.hit_triangle(&self.tris[i], ray.t_min, t_max) {
                        t_max = t;
                        best = Some(Hit {
                            t,
                            triangle: self.ids[i],
                            u,
                            v,
                        });
                    }
                }
            } else {
                let left = n.first as usize;
                let hl = pre.hit_box(self.node(left), ray.t_min, t_max);
                let hr = pre.hit_box(self.node(left + 1), ray.t_min, t_max);
                match (hl, hr) {
                    (Some(tl), Some(tr)) => {
                        let (near, far, t_far) = if tl <= tr {
                            (left, left + 1, tr)
                        } else {
                            (left + 1, left, tl)
                        };
                        stack[sp] = (far as u32, t_far);
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = left;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = left + 1;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (next, t_near) = stack[sp];
                if t_near <= t_max {
                    node = next as usize;
                    break;
                }
            }
        }
    }

    /// Whether anything lies at `t` in `(ray.t_min, ray.t_max)`; stops at
    /// the first hit found. `false` for a ray that [`Bvh::intersect`] rejects.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(pre) = Prepared::new(ray, self.magnitude) else {
            return false;
        };
        let Some(root) = self.pairs.first().map(|p| &p.0[0]) else {
            return false;
        };
        if pre.hit_box(root, ray.t_min, ray.t_max).is_none() {
            return false;
        }
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0;
        let mut node = 0usize;
        loop {
            let n = self.node(node);
            if n.count > 0 {
                let first = n.first as usize;
                let leaf = &self.tris[first..first + n.count as usize];
                if leaf
                    .iter()
                    .any(|tri| pre.hit_triangle(tri, ray.t_min, ray.t_max).is_some())
                {
                    return true;
                }
            } else {
                let left = n.first as usize;
                let hl = pre.hit_box(self.node(left), ray.t_min, ray.t_max);
                let hr = pre.hit_box(self.node(left + 1), ray.t_min, ray.t_max);
                match (hl.is_some(), hr.is_some()) {
                    (true, true) => {
                        stack[sp] = (left + 1) as u32;
                        sp += 1;
                        node = left;
                        continue;
                    }
                    (true, false) => {
                        node = left;
                        continue;
                    }
                    (false, true) => {
                        node = left + 1;
                        continue;
                    }
                    (false, false) => {}
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack[sp] as usize;
        }
    }
}

/// The watertight two-sided test [`Bvh`] uses, on one triangle: `(t, u, v)`
/// with `t` in `(ray.t_min, ray.t_max)` and the point at
/// `(1-u-v) a + u b + v c`. For brute-force references and one-off tests;
/// `None` also for rays [`Bvh::intersect`] rejects.
pub fn intersect_triangle(ray: &Ray, tri: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    if !hittable(tri) {
        return None;
    }
    Prepared::new(ray, 0.0)?.hit_triangle(tri, ray.t_min, ray.t_max)
}

/// Finite with a non-zero (f32) cross product. Zero-area triangles are left
/// out rather than tested: rounding in the sheared frame could report hits
/// on them, with no meaningful normal.
fn hittable([a, b, c]: &[Vec3; 3]) -> bool {
    a.is_finite() && b.is_finite() && c.is_finite() && (*b - *a).cross(*c - *a) != Vec3::ZERO
}

/// Bounds of the triangles and of their centroids.
fn range_bounds(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let mut bounds = Aabb::EMPTY;
    let mut centroids = Aabb::EMPTY;
    for r in refs {
        bounds.grow(r.min, r.max);
        let c = r.centroid();
        centroids.grow(c, c);
    }
    (bounds, centroids)
}

/// Bin of centroid coordinate `c` on an axis starting at `lo` with
/// `scale = BINS / extent`; shared by binning and partitioning so both agree.
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// The cheapest binned SAH split over all three axes, as
/// `area_left * count_left + area_right * count_right` (half areas); `None`
/// when the centroids coincide.
fn best_split(refs: &[PrimRef], centroids: &Aabb) -> Option<Split> {
    let extent = centroids.max - centroids.min;
    let mut best: Option<Split> = None;
    for axis in 0..3 {
        if !(extent[axis] > 0.0 && extent[axis].is_finite()) {
            continue;
        }
        let lo = centroids.min[axis];
        let scale = BINS as f32 / extent[axis];
        let mut bins = [(Aabb::EMPTY, 0u32); BINS];
        for r in refs {
            let b = &mut bins[bin_of(r.centroid()[axis], lo, scale)];
            b.0.grow(r.min, r.max);
            b.1 += 1;
        }
        // Right-to-left sweep: cost contribution of bins b+1..BINS.
        let mut right_cost = [0f32; BINS];
        let mut acc = Aabb::EMPTY;
        let mut n = 0u32;
        for b in (1..BINS).rev() {
            acc.grow(bins[b].0.min, bins[b].0.max);
            n += bins[b].1;
            right_cost[b - 1] = if n > 0 {
                acc.half_area() * n as f32
            } else {
                f32::INFINITY
            };
        }
        let mut acc = Aabb::EMPTY;
        let mut n = 0u32;
        for b in 0..BINS - 1 {
            acc.grow(bins[b].0.min, bins[b].0.max);
            n += bins[b].1;
            if n == 0 {
                continue;
            }
            let cost = acc.half_area() * n as f32 + right_cost[b];
            if cost.is_finite() && best.is_none_or(|s| cost < s.cost) {
                best = Some(Split { axis, bin: b, cost });
            }
        }
    }
    best
}

/// Moves the triangles of bins `0..=split.bin` to the front; returns how
/// many went left (never 0 or all: the split has triangles on both sides).
fn partition(refs: &mut [PrimRef], centroids: &Aabb, split: Split) -> usize {
    let lo = centroids.min[split.axis];
    let scale = BINS as f32 / (centroids.max[split.axis] - lo);
    let goes_left = |r: &PrimRef| bin_of(r.centroid()[split.axis], lo, scale) <= split.bin;
    let mut i = 0;
    let mut j = refs.len();
    while i < j {
        if goes_left(&refs[i]) {
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
        }
    }
    if i == 0 || i == refs.len() {
        // Only reachable if binning and partitioning disagreed; a median
        // split keeps the tree valid regardless.
        return median_split(refs, centroids);
    }
    i
}

/// Splits at the median centroid of the widest centroid axis.
fn median_split(refs: &mut [PrimRef], centroids: &Aabb) -> usize {
    let extent = centroids.max - centroids.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = refs.len() / 2;
    refs.select_nth_unstable_by(mid, |a, b| {
        a.centroid()[axis].total_cmp(&b.centroid()[axis])
    });
    mid
}

/// Per-ray constants of the box and watertight triangle tests.
struct Prepared {
    origin: Vec3,
    inv_dir: Vec3,
    /// `-origin` moved by the box slack: box `[min, max]` is tested as
    /// `[min + low_shift, max + high_shift]` relative to the origin.
    low_shift: Vec3,
    high_shift: Vec3,
    /// Rows of the shear that maps the ray onto +z: with `kz` the axis of
    /// the largest direction component and `kx`, `ky` the two others,
    /// `shear_x · p = p[kx] - sx p[kz]`, `shear_y · p = p[ky] - sy p[kz]`
    /// and `shear_z · p = p[kz]`. The zero entries add exact zeros, so these
    /// dot products round exactly like the paper's permuted form.
    shear_x: Vec3,
    shear_y: Vec3,
    shear_z: Vec3,
    /// `1 / dir[kz]`.
    sz: f32,
}

impl Prepared {
    /// `magnitude`: the largest absolute coordinate of the triangles tested.
    fn new(ray: &Ray, magnitude: f32) -> Option<Self> {
        let d = ray.dir;
        if !ray.origin.is_finite() || !d.is_finite() || d == Vec3::ZERO || ray.t_min.is_nan() {
            return None;
        }
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let slack = BOX_SLACK_ULPS * f32::EPSILON * (ray.origin.abs().max_element() + magnitude);
        let axis = |k: usize, scale: f32| {
            let mut v = Vec3::ZERO;
            v[k] = 1.0;
            v[kz] = -scale;
            v
        };
        let mut shear_z = Vec3::ZERO;
        shear_z[kz] = 1.0;
        Some(Self {
            origin: ray.origin,
            inv_dir: d.recip(),
            low_shift: -ray.origin - Vec3::splat(slack),
            high_shift: -ray.origin + Vec3::splat(slack),
            shear_x: axis(kx, d[kx] / d[kz]),
            shear_y: axis(ky, d[ky] / d[kz]),
            shear_z,
            sz: 1.0 / d[kz],
        })
    }

    /// Entry distance if the ray meets the node's box within
    /// `[t_min, t_max]`. NaN slab distances (origin on a slab plane of an
    /// axis the ray runs parallel to) are ignored by `f32::min`/`max`, which
    /// counts that slab as passed: conservative, never a missed hit.
    #[inline]
    fn hit_box(&self, node: &Node, t_min: f32, t_max: f32) -> Option<f32> {
        let t0 = (node.min + self.low_shift) * self.inv_dir;
        let t1 = (node.max + self.high_shift) * self.inv_dir;
        let near = t0.min(t1);
        let far = t0.max(t1);
        let t_near = t_min.max(near.x).max(near.y).max(near.z);
        let t_far = t_max.min(far.x).min(far.y).min(far.z) * BOX_PAD;
        (t_near <= t_far).then_some(t_near)
    }

    /// Watertight two-sided ray/triangle test: `(t, u, v)` with `t` in
    /// `(t_min, t_max)`.
    #[inline]
    fn hit_triangle(&self, tri: &[Vec3; 3], t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let a = tri[0] - self.origin;
        let b = tri[1] - self.origin;
        let c = tri[2] - self.origin;
        let (ax, ay) = (self.shear_x.dot(a), self.shear_y.dot(a));
        let (bx, by) = (self.shear_x.dot(b), self.shear_y.dot(b));
        let (cx, cy) = (self.shear_x.dot(c), self.shear_y.dot(c));
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            // Exact zeros decide edge ownership: redo the 2x2 determinants
            // with exact products so the sign is right.
            let edge = |p: DVec2, q: DVec2| (p.x * q.y - p.y * q.x) as f32;
            let (pa, pb, pc) = (
                DVec2::new(ax.into(), ay.into()),
                DVec2::new(bx.into(), by.into()),
                DVec2::new(cx.into(), cy.into()),
            );
            u = edge(pc, pb);
            v = edge(pa, pc);
            w = edge(pb, pa);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (az, bz, cz) = (
            self.shear_z.dot(a),
            self.shear_z.dot(b),
            self.shear_z.dot(c),
        );
        let t_scaled = self.sz * (u * az + v * bz + w * cz);
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        (t > t_min && t < t_max && t.is_finite()).then_some((t, v * inv, w * inv))
    }
}

/// `p` moved off its surface along `n` (any length; the side `n` points to)
/// by `2^-15 · max(|p|∞, 1e-3)`, enough to clear the rounding error of a hit
/// point computed from triangles whose coordinates are within about ten
/// times that magnitude. Returns `p` unchanged when `n` is zero or
/// non-finite. Near the world origin on triangles larger than that, use
/// [`offset_origin_scaled`] with the scene's magnitude (as [`RayCaster`]
/// does).
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_origin_scaled(p, n, OFFSET_MIN_MAGNITUDE)
}

/// [`offset_origin`] with `magnitude` (typically the largest absolute
/// coordinate of the scene's bounds) as the smallest magnitude assumed:
/// the offset is `2^-15 · max(|p|∞, magnitude)`.
pub fn offset_origin_scaled(p: Vec3, n: Vec3, magnitude: f32) -> Vec3 {
    let Some(n) = n.try_normalize() else {
        return p;
    };
    p + n * offset_distance(p, magnitude)
}

fn offset_distance(p: Vec3, magnitude: f32) -> f32 {
    let m = p.abs().max_element().max(magnitude);
    if m.is_finite() {
        OFFSET_REL * m
    } else {
        0.0
    }
}

/// A mesh with its hierarchy: closest hits with surface data, visibility
/// between points, scene-scaled offsets. Rebuild with [`RayCaster::new`]
/// after changing `mesh`; `bvh` must be the hierarchy of `mesh`.
#[derive(Debug, Clone)]
pub struct RayCaster {
    pub mesh: Mesh,
    pub bvh: Bvh,
}

impl RayCaster {
    pub fn new(mesh: Mesh) -> Self {
        let bvh = Bvh::build(&mesh);
        Self { mesh, bvh }
    }

    /// Closest hit and the surface data there.
    pub fn closest(&self, ray: &Ray) -> Option<(Hit, SurfacePoint)> {
        let hit = self.bvh.intersect(ray)?;
        // Guards a mesh changed after the build; never true otherwise.
        if hit.triangle as usize >= self.mesh.triangles.len() {
            return None;
        }
        Some((hit, self.mesh.surface(hit.triangle, hit.u, hit.v)))
    }

    /// Largest absolute coordinate of the scene (0 when empty).
    pub fn magnitude(&self) -> f32 {
        self.bvh
            .bounds()
            .map_or(0.0, |(lo, hi)| lo.abs().max(hi.abs()).max_element())
    }

    /// `p` moved off the surface along `n` by an offset scaled to the
    /// scene (see [`offset_origin_scaled`]): a ray from the result into the
    /// half space `n` points to does not hit the surface `p` lies on.
    pub fn offset(&self, p: Vec3, n: Vec3) -> Vec3 {
        offset_origin_scaled(p, n, self.magnitude())
    }

    /// Whether nothing lies on the segment between `from` and `to`, leaving
    /// out a scene-scaled distance at both ends so that end points on
    /// surfaces (a hit point, a light on a wall) do not occlude themselves.
    /// For a surface point seen at grazing angles, offset it first with
    /// [`RayCaster::offset`]. `false` for non-finite points.
    pub fn visible(&self, from: Vec3, to: Vec3) -> bool {
        let d = to - from;
        let len = d.length();
        if !len.is_finite() {
            return false;
        }
        let magnitude = self.magnitude();
        let t0 = offset_distance(from, magnitude);
        let t1 = len - offset_distance(to, magnitude);
        if t1 <= t0 {
            return true;
        }
        !self.bvh.occluded(&Ray::segment(from, d / len, t0, t1))
    }
}
