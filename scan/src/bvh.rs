//! Ray casting against a [`Mesh`]: closest hit, any hit (shadows), and the
//! offsets that keep secondary rays from hitting the surface they start on.
//!
//! The [`Bvh`] is a compressed 8-wide BVH (CWBVH, Ylitie et al. 2017) in the
//! layout of the [`obvhs`] crate (0.4): 80-byte nodes whose eight child
//! boxes are quantized to 8 bits against the node's origin and a
//! power-of-two scale, leaves of 1 to [`MAX_LEAF`] (3) triangles, children
//! ordered so that the ray's octant gives a near-to-far visiting order. The
//! build is in two steps: a binary tree built here with the binned surface
//! area heuristic (16 bins per axis, all three axes tried, down to one
//! triangle per leaf; beyond depth 64 nodes split at the median, so the
//! depth stays below 96 whatever the triangles), then obvhs's
//! `bvh2_to_cwbvh` collapses it into wide nodes by its SAH cost (it is given
//! boxes scaled by a power of two to magnitude 1: its surface areas overflow
//! f32 for extents beyond about 1e19, and its cost table then holds no valid
//! choice: a debug assertion of obvhs fails, and a release build would index
//! with the invalid marker). Every node's origin, scale and child boxes are
//! then re-quantized here from the exact boxes in f64, so that each
//! dequantized box contains its triangles exactly (obvhs takes the scale
//! from `log2`/`exp2` in f32, which comes out one binade short for some
//! extents just above `255 · 2^k`, in 404 of 3840 tried, and then clamps the
//! top plane inside the box). Triangles are copied into leaf order with
//! their mesh indices, so [`Hit::triangle`] is the index in the caller's
//! mesh.
//!
//! Traversal is obvhs's `traverse!` macro (its stack-based CWBVH walk) with
//! this module's two tests plugged in:
//!
//! - the child boxes: slab test against the dequantized planes, widened per
//!   ray by a few ulps of the ray's and the scene's magnitude and the exit
//!   padded by three roundings, from the ray's own `t_min`, NaN slabs
//!   counted as passed. Culling therefore never drops a hit the triangle
//!   test would report: [`Bvh::intersect`] equals a brute-force loop over
//!   [`intersect_triangle`] (tested, including rays aimed at vertices and
//!   edges and hits closer than 1e-4). obvhs's own box test does not hold
//!   this: it starts every ray at a fixed `t = 1e-4` (all hits of a
//!   1e-5-sized object are lost) and has no rounding slack (with it, rays
//!   through the shared edges and vertices of a closed sphere escaped, and
//!   4 of this crate's BVH tests failed);
//! - the triangles: the watertight test of Woop, Benthin and Wald (JCGT
//!   2013): rays through a shared edge or vertex of a closed mesh never
//!   slip between its triangles (double-precision fallback on exact
//!   zeros). obvhs's `Triangle::intersect` (Möller–Trumbore) is not
//!   watertight: on the benchmark mesh below, 3 of 524 288 random rays went
//!   through edges where this test hits.
//!
//! The stack has 128 entries (one per wide level at most; the build checks
//! the depth), where obvhs's own holds 32 and overwrites its top entry when
//! full. Triangles are two-sided. Zero-area and non-finite triangles are
//! left out at build time; an empty mesh gives an empty hierarchy.
//!
//! Why obvhs, and why not all of it. Measured with `cargo run --release -p
//! matscan-scan --example raycast_bench` (524 172-triangle displaced
//! sphere) on a 2-core machine shared with other jobs, the previous binary
//! SAH BVH (pairs of nodes per cache line, up to 4 triangles per leaf) and
//! this one run alternately, 3 runs each of the example's median of 5,
//! the median of those; single-thread rates in on-CPU time, Mrays/s:
//!
//! | what | binary SAH BVH | CWBVH (this) |
//! | --- | --- | --- |
//! | build (single thread) | 0.70 s | 0.90 s |
//! | primary rays, closest hit (56% hit) | 1.66 | 2.12 (1.28x) |
//! | random rays, closest hit (85% hit) | 0.49 | 0.69 (1.41x) |
//! | shadow rays from primary hits, occlusion | 1.20 | 1.53 (1.28x) |
//! | random rays, occlusion | 0.65 | 0.87 (1.34x) |
//! | both cores, random closest (wall) | 0.91 | 1.38 |
//! | memory (nodes, leaf triangles, indices) | 39 MB | 25 MB |
//!
//! Rates vary by up to 20% between runs on that machine. The wide nodes
//! (49 701 of them, 8 levels for this mesh) cut the node fetches of
//! incoherent rays, which are bound by memory latency.
//!
//! In the same session obvhs's complete CPU path (a standalone comparison
//! outside this repository on the same mesh and rays: its
//! PLOC builder with `medium_build`, its SSE box test, its Möller–Trumbore
//! test) built in 0.40 s and traced 2.30, 0.74, 1.97 and 1.07 Mrays/s on
//! the four rows: this module keeps 92% of that on closest hits and about
//! 80% on occlusion. The difference is the box test (this module's against
//! obvhs's, same tree and triangle test, alternating runs: 15 to 25% fewer
//! rays) and the builder. obvhs's PLOC builder is not used although it
//! builds twice as fast: its merge rounds degrade to one merge each on
//! ties and on nested scales, so 3000 copies of one triangle took 0.42 s,
//! 30 000 copies 39 s and a row of 10 000 equal triangles 2.1 s
//! (quadratic; this build: 27 ms and 11 ms), with a tree as deep as
//! the triangle count (3000 levels, 429 wide ones), which its recursive
//! CWBVH conversion has to descend and its 32-entry traversal stack cannot
//! hold. The SAH tree also traced closest hits faster (primary 1.70 against
//! 1.24 Mrays/s, random 0.57 against 0.47, with this module's tests;
//! occlusion about equal). Without PLOC, obvhs's `parallel` feature
//! (rayon) would speed up nothing used here and is off; for PLOC itself it
//! gained 10% on 2 cores (0.36 s against 0.40 s).
//!
//! In the renderer (`matscan simulate --seed 5 --kind 3mat --geometry
//! sphere`, a 65 024-triangle mesh) the gain is small: 128 px, 2
//! positions, 8 samples took 1.06 s before and 0.96 s after; 256 px, 3
//! positions, 32 samples 12.6 s and 11.6 s (wall, medians of 3, both
//! cores; the spread between runs is as large). Ray casting is still
//! about 56% of its time, but its 45 million queries per render are
//! cheap: half miss the mesh's bounds, the rest visit 6 to 7 wide nodes
//! and about 3 triangles.
//!
//! Offsets: a hit point is only known to within a few ulps of the
//! coordinates involved, so a ray starting exactly there can hit its own
//! triangle again. [`offset_origin`] moves a point along the normal by
//! `2^-15 · max(|p|∞, 1e-3)` (about 256 ulps); [`offset_origin_scaled`] and
//! [`RayCaster`] use the scene's magnitude instead of `1e-3`, which also
//! covers points near the world origin on large triangles. Both hold at
//! scene scales 1e-3 to 1e3 (tested).
//!
//! Boundaries: geometry only. Cameras make rays ([`crate::camera`]); shading
//! and sampling belong to the renderer.

use crate::mesh::{Mesh, SurfacePoint};
use glam::{DVec2, Vec3};
// The glam obvhs is built on; the traversal macro names its `UVec2`.
use glam_obvhs::{UVec2, Vec3A as OVec3A};
use obvhs::aabb::Aabb as OAabb;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::node::{extract_byte64, CwBvhNode};
use obvhs::faststack::StackStack;

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

/// Most triangles in one leaf (a CWBVH leaf holds 1 to 3).
pub const MAX_LEAF: usize = 3;
const BINS: usize = 16;
/// Beyond this depth nodes split at the median, so the depth of the binary
/// tree (and of the wide tree made from it) stays below
/// `SAH_MAX_DEPTH + 32` whatever the triangle distribution.
const SAH_MAX_DEPTH: usize = 64;
/// Traversal stack: one entry per level of the wide tree at most, and that
/// depth is below `SAH_MAX_DEPTH + 32` (checked at build).
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
/// Further widening for the dequantized child boxes: a box plane is
/// `p + q e` (`q e` exact), and forming `p + q e - origin ± slack` in f32
/// takes three roundings of values below about twice that magnitude.
const DEQUANTIZE_SLACK_ULPS: f32 = 8.0;

/// The hierarchy: obvhs's compressed 8-wide nodes (CWBVH, 80 bytes each,
/// child boxes quantized to 8 bits against the node's origin `p` and
/// power-of-two scale `e`), re-quantized here so that every child box
/// contains its triangles exactly, with the triangles copied into leaf
/// order.
#[derive(Clone)]
pub struct Bvh {
    nodes: Vec<CwBvhNode>,
    /// Vertices of each triangle in leaf order.
    tris: Vec<[Vec3; 3]>,
    /// Mesh triangle index of each entry of `tris`.
    ids: Vec<u32>,
    /// Exact bounds of every hittable triangle.
    bounds: Option<(Vec3, Vec3)>,
    /// Largest absolute coordinate of `bounds` (0 when empty).
    magnitude: f32,
    /// Wide nodes plus leaves.
    node_count: usize,
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

/// Traversal state in the shape obvhs's `traverse!` macro reads, with a
/// stack deep enough for any tree [`Bvh::build`] makes.
struct Traversal {
    stack: StackStack<UVec2, STACK_SIZE>,
    current_group: UVec2,
    primitive_group: UVec2,
    oct_inv4: u32,
    primitive_id: u32,
    hitmask: u32,
}

impl Traversal {
    /// At the root, children ordered for a ray with direction `d`.
    fn new(d: Vec3) -> Self {
        // obvhs's octant code (its `ray_get_octant_inv4`, not public).
        let oct_inv4 = (if d.x < 0.0 { 0 } else { 0x0404_0404 })
            | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
            | (if d.z < 0.0 { 0 } else { 0x0101_0101 });
        Self {
            stack: StackStack::default(),
            current_group: UVec2::new(0, 0x8000_0000),
            primitive_group: UVec2::ZERO,
            oct_inv4,
            primitive_id: 0,
            hitmask: 0,
        }
    }
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
        if refs.is_empty() {
            return Self {
                nodes: Vec::new(),
                tris: Vec::new(),
                ids: Vec::new(),
                bounds: None,
                magnitude: 0.0,
                node_count: 0,
            };
        }
        let bvh2 = sah_bvh2(&mut refs);
        // Leaves of up to 3 triangles (obvhs's limit), children in octant
        // order.
        let mut cw = bvh2_to_cwbvh(&bvh2, MAX_LEAF as u32, true, false);
        drop(bvh2);
        let order: Vec<PrimRef> = cw
            .primitive_indices
            .iter()
            .map(|&i| refs[i as usize])
            .collect();
        let exact = exact_boxes(&cw.nodes, &order);
        requantize(&mut cw.nodes, &exact, &order);
        let bounds = (exact[0].min, exact[0].max);
        let leaves = cw
            .nodes
            .iter()
            .map(|n| {
                (0..8)
                    .filter(|&c| n.is_leaf(c) && !n.is_child_empty(c))
                    .count()
            })
            .sum::<usize>();
        let depth = wide_depth(&cw.nodes);
        // By construction (binary depth < SAH_MAX_DEPTH + 32); a deeper
        // tree would overflow the traversal stack.
        assert!(depth < STACK_SIZE, "BVH depth {depth}");
        Self {
            node_count: cw.nodes.len() + leaves,
            nodes: cw.nodes,
            tris: order.iter().map(|r| tris_by_id[r.id as usize]).collect(),
            ids: order.iter().map(|r| r.id).collect(),
            bounds: Some(bounds),
            magnitude: bounds.0.abs().max(bounds.1.abs()).max_element(),
        }
    }

    /// Bounds of every triangle that can be hit; `None` when there are none.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.bounds
    }

    /// Number of nodes: 8-wide inner nodes plus leaves (of 1 to
    /// [`MAX_LEAF`] triangles).
    pub fn node_count(&self) -> usize {
        self.node_count
    }

    /// Closest hit with `t` in `(ray.t_min, ray.t_max)`; `None` for a miss or
    /// a ray with a non-finite origin or a zero or non-finite direction.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let bounds = self.bounds?;
        let pre = Prepared::new(ray, self.magnitude)?;
        if !pre.hit_box(bounds, ray.t_min, ray.t_max) {
            return None;
        }
        let t_min = ray.t_min;
        let mut t_max = ray.t_max;
        let mut best = None;
        let mut state = Traversal::new(ray.dir);
        let mut node: &CwBvhNode;
        obvhs::traverse!(
            self,
            node,
            state,
            pre.hit_children(node, state.oct_inv4, t_min, t_max),
            {
                let i = state.primitive_id as usize;
                if let Some((t, u, v)) = pre.hit_triangle(&self.tris[i], t_min, t_max) {
                    t_max = t;
                    best = Some(Hit {
                        t,
                        triangle: self.ids[i],
                        u,
                        v,
                    });
                }
            }
        );
        best
    }

    /// Whether anything lies at `t` in `(ray.t_min, ray.t_max)`; stops at
    /// the first hit found. `false` for a ray that [`Bvh::intersect`] rejects.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let (Some(bounds), Some(pre)) = (self.bounds, Prepared::new(ray, self.magnitude)) else {
            return false;
        };
        if !pre.hit_box(bounds, ray.t_min, ray.t_max) {
            return false;
        }
        let (t_min, t_max) = (ray.t_min, ray.t_max);
        let mut state = Traversal::new(ray.dir);
        let mut node: &CwBvhNode;
        let mut hit = false;
        'traversal: {
            obvhs::traverse!(
                self,
                node,
                state,
                pre.hit_children(node, state.oct_inv4, t_min, t_max),
                {
                    let tri = &self.tris[state.primitive_id as usize];
                    if pre.hit_triangle(tri, t_min, t_max).is_some() {
                        hit = true;
                        break 'traversal;
                    }
                }
            );
        }
        hit
    }
}

/// Binary tree for obvhs's CWBVH conversion, built with the binned surface
/// area heuristic (16 bins, all three axes) down to one triangle per leaf
/// (the conversion chooses the leaves of 1 to 3 by its own cost). Reorders
/// `refs`; leaf `first_index` values index the reordered `refs`.
fn sah_bvh2(refs: &mut [PrimRef]) -> Bvh2 {
    // The boxes obvhs sees are scaled by a power of two that brings the
    // scene's magnitude into [1, 2): its costs are surface areas, which
    // overflow f32 beyond extents of about 1e19 (its conversion then finds
    // no valid choice and asserts in debug builds). Only costs and child
    // order use them; the quantized boxes come from the exact ones
    // (`requantize`).
    let magnitude = refs
        .iter()
        .map(|r| r.min.abs().max(r.max.abs()).max_element())
        .fold(0f32, f32::max);
    let exponent = ((magnitude.to_bits() >> 23) & 0xff) as i32 - 127;
    let scale = 2f64.powi(-exponent);
    let scaled = |v: Vec3| OVec3A::from_array(v.to_array().map(|c| (f64::from(c) * scale) as f32));
    let aabb = |b: &Aabb| OAabb::new(scaled(b.min), scaled(b.max));
    let mut nodes = Vec::with_capacity(2 * refs.len() - 1);
    nodes.push(Bvh2Node::default());
    let mut work = vec![(0usize, 0usize, refs.len(), 0usize)];
    let mut max_depth = 0;
    while let Some((node, start, end, depth)) = work.pop() {
        max_depth = max_depth.max(depth + 1);
        let (bounds, centroids) = range_bounds(&refs[start..end]);
        if end - start == 1 {
            nodes[node] = Bvh2Node::new(aabb(&bounds), 1, start as u32);
            continue;
        }
        let split = if depth < SAH_MAX_DEPTH {
            best_split(&refs[start..end], &centroids)
        } else {
            None
        };
        let mid = match split {
            Some(s) => partition(&mut refs[start..end], &centroids, s),
            None => median_split(&mut refs[start..end], &centroids),
        };
        let left = nodes.len();
        nodes[node] = Bvh2Node::new(aabb(&bounds), 0, left as u32);
        nodes.push(Bvh2Node::default());
        nodes.push(Bvh2Node::default());
        work.push((left + 1, start + mid, end, depth + 1));
        work.push((left, start, start + mid, depth + 1));
    }
    Bvh2 {
        nodes,
        primitive_indices: (0..refs.len() as u32).collect(),
        max_depth,
        ..Bvh2::default()
    }
}

/// Re-derives every node's origin, scale and child boxes from the exact
/// boxes (`exact[i]`: node `i`'s, from [`exact_boxes`]; leaves: their
/// triangles in `order`, the leaf order), so that each dequantized child
/// box `p + q e` contains its triangles exactly. obvhs quantized the scaled
/// boxes of [`sah_bvh2`], and in f32 (a rounded `min - p` before the floor,
/// and `e` from `log2`/`exp2`, which can come out one binade short so that
/// the top plane is clamped inside the box); here `e` is the smallest
/// power of two with `255 e` covering the node's extent and the planes
/// come from f64 arithmetic, whose error is 2^-29 of an f32 ulp.
fn requantize(nodes: &mut [CwBvhNode], exact: &[Aabb], order: &[PrimRef]) {
    for (slot, own) in nodes.iter_mut().zip(exact) {
        let node = *slot;
        let p = own.min;
        let extent = own.max.as_dvec3() - p.as_dvec3();
        let mut out = node;
        out.p = glam_obvhs::Vec3::from_array(p.to_array());
        let mut scale = [0f64; 3];
        for k in 0..3 {
            out.e[k] = scale_exponent(extent[k]);
            scale[k] = f64::from(f32::from_bits(u32::from(out.e[k]) << 23));
        }
        for c in 0..8 {
            if node.is_child_empty(c) {
                continue;
            }
            let (lo, hi) = if node.is_leaf(c) {
                let (first, count) = node.child_primitives(c);
                let mut b = Aabb::EMPTY;
                for r in &order[first as usize..(first + count) as usize] {
                    b.grow(r.min, r.max);
                }
                (b.min, b.max)
            } else {
                let b = exact[node.child_node_index(c) as usize];
                (b.min, b.max)
            };
            let q = |v: f32, k: usize, up: bool| {
                let x = (f64::from(v) - f64::from(p[k])) / scale[k];
                let x = if up { x.ceil() } else { x.floor() };
                x.clamp(0.0, 255.0) as u8
            };
            out.child_min_x[c] = q(lo.x, 0, false);
            out.child_min_y[c] = q(lo.y, 1, false);
            out.child_min_z[c] = q(lo.z, 2, false);
            out.child_max_x[c] = q(hi.x, 0, true);
            out.child_max_y[c] = q(hi.y, 1, true);
            out.child_max_z[c] = q(hi.z, 2, true);
        }
        *slot = out;
    }
}

/// Biased exponent (1 to 254) of the smallest power of two `e` with
/// `255 e >= extent` (a normal, finite f32; 1 for a flat axis).
fn scale_exponent(extent: f64) -> u8 {
    let covers = |b: i32| 255.0 * 2f64.powi(b - 127) >= extent;
    let mut b = ((extent / 255.0).log2().ceil() + 127.0).clamp(1.0, 254.0) as i32;
    while b > 1 && covers(b - 1) {
        b -= 1;
    }
    while b < 254 && !covers(b) {
        b += 1;
    }
    b as u8
}

/// Exact bounds of the triangles under each wide node, from the leaves
/// up (children always come after their parent).
fn exact_boxes(nodes: &[CwBvhNode], order: &[PrimRef]) -> Vec<Aabb> {
    let mut boxes = vec![Aabb::EMPTY; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let node = &nodes[i];
        let mut b = Aabb::EMPTY;
        for c in 0..8 {
            if node.is_child_empty(c) {
                continue;
            }
            if node.is_leaf(c) {
                let (first, count) = node.child_primitives(c);
                for r in &order[first as usize..(first + count) as usize] {
                    b.grow(r.min, r.max);
                }
            } else {
                let child = boxes[node.child_node_index(c) as usize];
                b.grow(child.min, child.max);
            }
        }
        boxes[i] = b;
    }
    boxes
}

/// Levels of wide nodes below and including the root.
fn wide_depth(nodes: &[CwBvhNode]) -> usize {
    let mut deepest = 0;
    let mut work = vec![(0usize, 1usize)];
    while let Some((i, depth)) = work.pop() {
        deepest = deepest.max(depth);
        let n = &nodes[i];
        for c in 0..8 {
            if !n.is_leaf(c) && !n.is_child_empty(c) {
                work.push((n.child_node_index(c) as usize, depth + 1));
            }
        }
    }
    deepest
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
    /// Per axis, `-origin` moved outward by the box slack for the plane a
    /// box is entered through (its low plane where the direction's sign
    /// bit is clear, its high plane where it is set) and for the plane it
    /// is left through: box `[min, max]` is tested as
    /// `[min - slack, max + slack]` relative to the origin.
    near_shift: Vec3,
    far_shift: Vec3,
    /// Whether the direction's sign bit is set, per axis (-0 included).
    negative: [bool; 3],
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
        let slack = (BOX_SLACK_ULPS + DEQUANTIZE_SLACK_ULPS)
            * f32::EPSILON
            * (ray.origin.abs().max_element() + magnitude);
        let axis = |k: usize, scale: f32| {
            let mut v = Vec3::ZERO;
            v[k] = 1.0;
            v[kz] = -scale;
            v
        };
        let mut shear_z = Vec3::ZERO;
        shear_z[kz] = 1.0;
        let negative = [
            d.x.is_sign_negative(),
            d.y.is_sign_negative(),
            d.z.is_sign_negative(),
        ];
        let low = -ray.origin - Vec3::splat(slack);
        let high = -ray.origin + Vec3::splat(slack);
        let pick = |near: bool| {
            Vec3::from_array(std::array::from_fn(|k| {
                if negative[k] == near {
                    high[k]
                } else {
                    low[k]
                }
            }))
        };
        Some(Self {
            origin: ray.origin,
            inv_dir: d.recip(),
            near_shift: pick(true),
            far_shift: pick(false),
            negative,
            shear_x: axis(kx, d[kx] / d[kz]),
            shear_y: axis(ky, d[ky] / d[kz]),
            shear_z,
            sz: 1.0 / d[kz],
        })
    }

    /// Whether the ray meets the box `[lo, hi]` within `[t_min, t_max]`:
    /// the test of [`Prepared::hit_children`] on one exact box (the root's,
    /// so that rays missing the whole mesh skip the first wide node).
    #[inline]
    fn hit_box(&self, (lo, hi): (Vec3, Vec3), t_min: f32, t_max: f32) -> bool {
        let mut near = t_min;
        let mut far = t_max;
        for k in 0..3 {
            let (n, f) = if self.negative[k] {
                (hi[k], lo[k])
            } else {
                (lo[k], hi[k])
            };
            let tn = (n + self.near_shift[k]) * self.inv_dir[k];
            let tf = (f + self.far_shift[k]) * self.inv_dir[k];
            near = if tn > near { tn } else { near };
            far = if tf < far { tf } else { far };
        }
        near <= far * BOX_PAD
    }

    /// The children of `node` the ray meets within `[t_min, t_max]`, as the
    /// hit mask obvhs's `traverse!` reads (its `CwBvhNode::intersect_ray`
    /// with the box test of this module: planes widened by the slack, the
    /// ray's own `t_min`, the exit padded by [`BOX_PAD`]). Zero direction
    /// components give infinite slab distances, or NaN where a widened
    /// plane passes exactly through the origin; `f32::min`/`max` ignore
    /// NaN, which counts that slab as passed: conservative, never a missed
    /// hit.
    #[inline(always)]
    fn hit_children(&self, node: &CwBvhNode, oct_inv4: u32, t_min: f32, t_max: f32) -> u32 {
        // `if t > acc { t } else { acc }`: NaN-ignoring like `f32::max` when
        // `acc` is never NaN, and one `maxps` per four children.
        let mut near = [t_min; 8];
        let mut far = [t_max; 8];
        let planes = [
            (&node.child_min_x, &node.child_max_x),
            (&node.child_min_y, &node.child_max_y),
            (&node.child_min_z, &node.child_max_z),
        ];
        for (k, (lo, hi)) in planes.into_iter().enumerate() {
            let e = f32::from_bits(u32::from(node.e[k]) << 23);
            let (qn, qf) = if self.negative[k] { (hi, lo) } else { (lo, hi) };
            let pn = node.p[k] + self.near_shift[k];
            let pf = node.p[k] + self.far_shift[k];
            let inv = self.inv_dir[k];
            for c in 0..8 {
                let tn = (f32::from(qn[c]) * e + pn) * inv;
                let tf = (f32::from(qf[c]) * e + pf) * inv;
                near[c] = if tn > near[c] { tn } else { near[c] };
                far[c] = if tf < far[c] { tf } else { far[c] };
            }
        }
        let (child_bits, bit_index) = node.get_child_and_index_bits(oct_inv4);
        let mut mask = 0;
        for c in 0..8 {
            if near[c] <= far[c] * BOX_PAD {
                mask |= extract_byte64(child_bits, c) << extract_byte64(bit_index, c);
            }
        }
        mask
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact bounds of the triangles under child `c` of node `i`, checking
    /// on the way down that every dequantized child box (in f64) contains
    /// them; collects the leaf triangles' indices into `seen`.
    fn check(bvh: &Bvh, i: usize, seen: &mut Vec<usize>) -> (Vec3, Vec3) {
        let node = &bvh.nodes[i];
        let e = node.compute_extent().to_array().map(f64::from);
        let p = node.p.to_array().map(f64::from);
        let mut all = Aabb::EMPTY;
        for c in 0..8 {
            if node.is_child_empty(c) {
                continue;
            }
            let (lo, hi) = if node.is_leaf(c) {
                let (first, count) = node.child_primitives(c);
                let mut b = Aabb::EMPTY;
                for t in first as usize..(first + count) as usize {
                    seen.push(t);
                    for v in bvh.tris[t] {
                        b.grow(v, v);
                    }
                }
                (b.min, b.max)
            } else {
                check(bvh, node.child_node_index(c) as usize, seen)
            };
            let q_lo = [
                node.child_min_x[c],
                node.child_min_y[c],
                node.child_min_z[c],
            ];
            let q_hi = [
                node.child_max_x[c],
                node.child_max_y[c],
                node.child_max_z[c],
            ];
            for k in 0..3 {
                let box_lo = p[k] + f64::from(q_lo[k]) * e[k];
                let box_hi = p[k] + f64::from(q_hi[k]) * e[k];
                assert!(
                    box_lo <= f64::from(lo[k]) && f64::from(hi[k]) <= box_hi,
                    "node {i} child {c} axis {k}: [{box_lo}, {box_hi}] misses [{}, {}]",
                    lo[k],
                    hi[k]
                );
            }
            all.grow(lo, hi);
        }
        (all.min, all.max)
    }

    fn soup(seed: u64, count: usize, scale: f32, offset: Vec3) -> Mesh {
        // Small LCG: no dev-dependency needed in unit tests.
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..count as u32 {
            let centre = Vec3::new(next(), next(), next());
            let size = 10f32.powf(-3.0 + 2.7 * (next() * 0.5 + 0.5));
            for _ in 0..3 {
                let v = centre + Vec3::new(next(), next(), next()) * size;
                positions.push(offset + v * scale);
            }
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        Mesh {
            positions,
            normals: None,
            uvs: None,
            triangles,
        }
    }

    #[test]
    fn quantized_child_boxes_contain_their_triangles_exactly() {
        for (seed, count, scale, offset) in [
            (1, 1, 1.0, Vec3::ZERO),
            (2, 9, 1.0, Vec3::ZERO),
            (3, 2000, 1.0, Vec3::ZERO),
            (4, 2000, 1e-3, Vec3::splat(2e-3)),
            (5, 2000, 1e3, Vec3::new(700.0, -300.0, 200.0)),
            (6, 2000, 1e-6, Vec3::ZERO),
            (7, 200, 1e37, Vec3::ZERO),
            (8, 200, 1.5e38, Vec3::ZERO),
        ] {
            let mesh = soup(seed, count, scale, offset);
            let bvh = Bvh::build(&mesh);
            let mut seen = Vec::new();
            let (lo, hi) = check(&bvh, 0, &mut seen);
            assert_eq!(bvh.bounds(), Some((lo, hi)));
            seen.sort_unstable();
            assert_eq!(seen, (0..bvh.tris.len()).collect::<Vec<_>>());
            let mut ids = bvh.ids.clone();
            ids.sort_unstable();
            ids.dedup();
            assert_eq!(ids.len(), bvh.tris.len());
            for (t, &id) in bvh.tris.iter().zip(&bvh.ids) {
                assert_eq!(*t, mesh.triangle_vertices(id));
            }
            assert!(wide_depth(&bvh.nodes) < STACK_SIZE);
        }
    }
}
