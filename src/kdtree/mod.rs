//! SAH kd-tree with ropes over the scene's triangles (docs/DESIGN.md §1).
//!
//! Build ([`build`]): the top `log2(cores)` levels split at the object median
//! of the longest axis, one subtree per core; each subtree is a full SAH
//! sweep over sorted split events, O(n log n) (Wald & Havran 2006, "On
//! building fast kd-trees for ray tracing, and on doing that in O(N log N)"):
//! events are sorted once per subtree and kept sorted through every split,
//! only the triangles that straddle a split get new, clipped events.
//! Deviations: straddling triangles are clipped by their bounding box, not
//! by the exact polygon ("perfect splits"), which gives slightly looser
//! leaves. The cost of a leaf counts blocks of `leaf_block` triangles:
//! four for the CPU walk, which tests four at once
//! ([`triangle::intersect4`]), one for the GPU shader
//! ([`KdBuildParams::for_gpu`]). On `conference`, against
//! counting triangles with the old defaults (traversal 1, test 1.5), this
//! gave 57% fewer leaves, a 19% faster build and 21% more rays/s; counting
//! triangles with a traversal cost of 4 did about as well.
//!
//! Entering a leaf: the rope walk locates the entry point with the exit
//! plane's own coordinate on that axis, never the rounded `o + t d`, which
//! can land beyond a leaf one ulp thick (the slab of a flat triangle) and
//! skip it. Before this, 9 of 89,717 `tearoom` rays returned a farther hit
//! than brute force.
//!
//! Crack-free traversal: a triangle touching a split plane only with an
//! edge or vertex is kept on its own side (as in pbrt), so a ray leaving a
//! leaf exactly through a leaf edge or corner (two or three exit distances
//! equal) could skip the diagonal neighbour holding the triangle it meets
//! there. The traversal then also tests the leaves across the other tied
//! faces. Known limitation: a ray through a mesh vertex that lies exactly on
//! two split planes of a region the ray enters through a third face can
//! still slip through (seen only with grid-aligned test geometry; the closed
//! room and furnace tests lose no rays). Likewise a ray that meets a
//! triangle exactly on the edge that lies in a split plane, at a point a
//! rounding error from where it enters that plane's region, can be sent to
//! the other side and return a farther hit: brute force over every solver
//! ray of `tearoom` found none of 1.1 M at 256 rays per vertex and at least one of
//! 0.8 M at 64. Putting touching triangles on both
//! sides closes this too but made leaves 3x fuller and tracing 3.5x slower.
//!
//! Ropes ([`ropes`]): every leaf stores, for each of its six faces, the
//! node across that face, pushed down the tree as far as it goes (Popov et al.
//! 2007, "Stackless kd-tree traversal for high performance GPU ray tracing").
//! Traversal ([`traverse`]) walks leaf to leaf along ropes with no stack.
//!
//! The flattened layout ([`KdNode`], [`KdLeaf`], [`KdTriangle`]) is
//! `#[repr(C)]` `bytemuck::Pod` data shared with the WGSL shader. The CPU
//! walk reads the leaves from a CPU-only copy ([`accel`]) laid out for its
//! caches; it holds the same numbers. Lengths are
//! metres (world space); costs are unitless SAH weights.

pub mod accel;
pub mod build;
pub mod ropes;
pub mod traverse;
pub mod triangle;
pub mod validate;

pub use accel::CpuAccel;
use bytemuck::{Pod, Zeroable};
use crate::trace::ray::KdTriangle;
use glam::Vec3;


/// `KdNode::kind` of a leaf; 0, 1 and 2 are the split axis of an inner node.
pub const LEAF: u32 = 3;
/// A rope that leaves the scene's bounds.
pub const NO_ROPE: u32 = u32::MAX;

/// One node of the flattened tree (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct KdNode {
    /// Split plane position along `kind` (inner nodes), metres.
    pub split: f32,
    /// 0, 1, 2: split axis of an inner node; [`LEAF`]: a leaf.
    pub kind: u32,
    /// Inner: left child (below the plane). Leaf: index into the leaf array.
    pub a: u32,
    /// Inner: right child (above the plane). Leaf: unused (0).
    pub b: u32,
}

/// A leaf: its box, its triangle range and its six ropes (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct KdLeaf {
    /// Minimum corner of the leaf's box, metres.
    pub min: [f32; 3],
    /// First entry in the tree's triangle index list.
    pub first: u32,
    /// Maximum corner of the leaf's box, metres.
    pub max: [f32; 3],
    /// Number of triangle indices.
    pub count: u32,
    /// Node across faces -x, +x, -y, +y, -z, +z, or [`NO_ROPE`].
    pub ropes: [u32; 6],
    /// Padding to 64 bytes.
    pub _pad: [u32; 2],
}

/// Build parameters of the SAH kd-tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdBuildParams {
    /// Cost of one traversal step (leaf to leaf along a rope, or one node
    /// down), in the units of `intersect_cost`.
    pub traversal_cost: f32,
    /// Cost of testing one block of up to `leaf_block` triangles (a leaf of
    /// `n` triangles costs `intersect_cost * ceil(n / leaf_block)`).
    pub intersect_cost: f32,
    /// Triangles the walk that will use the tree tests at once: 4 for the
    /// CPU walk (`triangle::intersect4`), 1 for the WGSL shader, which
    /// tests one per step ([`KdBuildParams::for_gpu`]). Hits do not depend
    /// on it, only speed.
    pub leaf_block: u32,
    /// Fraction of the cost waived for splits that cut off empty space, in [0, 1).
    pub empty_bonus: f32,
    /// Depth limit; `None`: `8 + 1.3 log2(n)` as in pbrt.
    pub max_depth: Option<u32>,
    /// Object-median levels at the top, whose subtrees are built in
    /// parallel (default 1: two subtrees). Fixed, not derived from the
    /// thread count: the rope walk's ties depend on the tree, so a tree that
    /// followed the machine's cores gave other links on another machine
    /// (the Cornell box's `E_i` differed between 1 and 2 threads). Not 3:
    /// with three object-median levels the rope walk misses a hit at
    /// `t = 1.3e-5` from a tearoom vertex that brute force finds
    /// (`tests/kdtree.rs::solver_rays_on_tearoom_agree_across_trees`), a
    /// latent walk bug left for its own fix. `None`: `ceil(log2(threads))`.
    pub parallel_levels: Option<u32>,
}

impl KdBuildParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: KdBuildParams = Self {
        traversal_cost: 1.5,
        intersect_cost: 1.5,
        leaf_block: 4,
        empty_bonus: 0.2,
        max_depth: None,
        parallel_levels: Some(1),
    };
}

impl Default for KdBuildParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl KdBuildParams {
    /// Costs for a tree the GPU shader walks: triangles counted one by one
    /// with a traversal cost of 1 (the tree this project used before the CPU
    /// walk tested four at once; not yet timed on a hardware GPU).
    pub const fn for_gpu() -> Self {
        Self { traversal_cost: 1.0, leaf_block: 1, ..Self::DEFAULT }
    }

    /// Blocks of `leaf_block` triangles that hold `n` triangles.
    #[inline]
    pub fn blocks(&self, n: usize) -> f32 {
        n.div_ceil(self.leaf_block.max(1) as usize) as f32
    }
}

/// Figures describing a built tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct KdStats {
    /// Nodes, inner and leaf.
    pub nodes: usize,
    /// Leaves, empty ones included.
    pub leaves: usize,
    /// Leaves with no triangle.
    pub empty_leaves: usize,
    /// Mean triangle references per non-empty leaf.
    pub mean_leaf_triangles: f32,
    /// Depth of the deepest node.
    pub max_depth: u32,
    /// Expected cost of a random ray by the surface area heuristic, in units
    /// of `intersect_cost`-weighted operations.
    pub sah_cost: f32,
    /// Build time, ms.
    pub build_ms: f64,
}

/// A built kd-tree: flattened nodes, leaves with ropes, triangle index list
/// and the triangles themselves (in scene order).
#[derive(Clone, Debug)]
pub struct KdTree {
    /// The flattened nodes; the root is node 0.
    pub nodes: Vec<KdNode>,
    /// The leaves, indexed by a leaf node's `a`.
    pub leaves: Vec<KdLeaf>,
    /// Triangle ids referenced by leaves.
    pub leaf_triangles: Vec<u32>,
    /// The triangles with their corners, in scene order.
    pub triangles: Vec<KdTriangle>,
    /// CPU-only copy of the leaves and their triangles for the rope walk
    /// (derived from the fields above; see [`accel`]).
    pub accel: CpuAccel,
    /// Scene bounds (the root's box).
    pub min: Vec3,
    /// Maximum corner of the scene bounds.
    pub max: Vec3,
    /// The parameters the tree was built with.
    pub params: KdBuildParams,
    /// Figures of the build.
    pub stats: KdStats,
}

/// Axis-aligned box, metres: the kd-tree build and validation use it, and
/// so do selective updates ([`crate::scene::motion`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner, metres.
    pub min: Vec3,
    /// Maximum corner, metres.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min at +infinity, max at -infinity), the identity of [`Aabb::union`] and [`Aabb::grow`].
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The smallest box holding `points` ([`Aabb::EMPTY`] when there are none).
    pub fn of_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, p| Aabb { min: b.min.min(*p), max: b.max.max(*p) })
    }

    /// Surface area, m^2 (0 for an empty or inverted box).
    pub fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The overlap of the two boxes (empty, with `min > max` on some axis, where they do not overlap).
    pub fn intersect(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.max(o.min), max: self.max.min(o.max) }
    }

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box holding both boxes.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// True if `min > max` on some axis (or a coordinate is NaN).
    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    /// The box grown by `margin` metres on every side.
    pub fn expanded(self, margin: f32) -> Aabb {
        Aabb { min: self.min - Vec3::splat(margin), max: self.max + Vec3::splat(margin) }
    }

    /// A margin that keeps a box conservative under float rounding of
    /// points computed near it: `1e-5` of its largest coordinate magnitude
    /// plus `1e-6` m.
    pub fn rounding_margin(&self) -> f32 {
        1e-5 * self.min.abs().max(self.max.abs()).max_element() + 1e-6
    }

    /// True if the segment `o + t d`, `t` in `[t0, t1]`, meets the box
    /// (slab test; `inv_d` = `1 / d` per component, infinities allowed).
    #[inline]
    pub fn meets_segment(&self, o: Vec3, inv_d: Vec3, t0: f32, t1: f32) -> bool {
        let a = (self.min - o) * inv_d;
        let b = (self.max - o) * inv_d;
        // NaN (0 * inf, a ray in the slab's plane) falls to the non-NaN side in min/max.
        let near = a.min(b).max_element().max(t0);
        let far = a.max(b).min_element().min(t1);
        near <= far
    }

    /// True if every corner lies strictly below the plane through `o` with
    /// normal `n`, by more than `margin` (no ray leaving `o` into the upper
    /// hemisphere can reach the box).
    pub fn below_plane(&self, o: Vec3, n: Vec3, margin: f32) -> bool {
        // The corner farthest along n.
        let c = Vec3::select(n.cmpge(Vec3::ZERO), self.max, self.min);
        (c - o).dot(n) < -margin
    }

    /// Splits at `pos` along `axis` into (below, above).
    pub fn split(&self, axis: usize, pos: f32) -> (Aabb, Aabb) {
        let mut l = *self;
        let mut r = *self;
        l.max[axis] = pos;
        r.min[axis] = pos;
        (l, r)
    }
}

impl KdTree {
    /// Builds the tree over `triangles` (solver vertex ids into `positions`).
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], params: &KdBuildParams) -> KdTree {
        build::build(positions, triangles, params)
    }

    /// Node boxes of every node (computed from the root box and splits).
    pub fn node_boxes(&self) -> Vec<Aabb> {
        let mut boxes = vec![Aabb::EMPTY; self.nodes.len()];
        if self.nodes.is_empty() {
            return boxes;
        }
        let mut stack = vec![(0u32, Aabb { min: self.min, max: self.max })];
        while let Some((n, b)) = stack.pop() {
            boxes[n as usize] = b;
            let node = self.nodes[n as usize];
            if node.kind != LEAF {
                let (l, r) = b.split(node.kind as usize, node.split);
                stack.push((node.a, l));
                stack.push((node.b, r));
            }
        }
        boxes
    }

    /// Bytes of the flattened structure (nodes, leaves, index list,
    /// triangles) as the GPU holds it; the CPU-only copy adds
    /// `accel.bytes()`.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.leaves.as_slice())
            + std::mem::size_of_val(self.leaf_triangles.as_slice())
            + std::mem::size_of_val(self.triangles.as_slice())
    }
}
