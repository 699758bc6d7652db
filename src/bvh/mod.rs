//! 8-wide BVH for the CPU path (docs/DESIGN.md §1b): the structure the CPU
//! traces link rays, shadow rays, reference paths and fallback renders
//! with. The kd-tree with ropes ([`crate::kdtree`]) stays the GPU shader's
//! structure and its CPU oracle.
//!
//! Build ([`build`]): a binary BVH by binned SAH over triangle boxes
//! (Wald 2007, "On fast construction of SAH-based bounding volume
//! hierarchies"), subtrees built in parallel with `rayon::join`, then
//! collapsed into 8-wide nodes by repeatedly opening the child of largest
//! surface area (as Embree's and tinybvh's BVH8 collapses). The cost of a
//! leaf counts blocks of eight triangles (`ceil(n / 8)`), the unit the CPU
//! tests at once. Regular meshes (the built-in rooms'
//! grids of equal triangles) are where greedy builders degrade; binning over
//! centroid bounds and a median split where every centroid falls in one bin
//! keep the tree sound there (the SAH cost is in [`BvhStats`] and checked
//! against the kd-tree's in the tests).
//!
//! Nodes ([`Node8`], 256 bytes): the eight child boxes as structure of
//! arrays, so one SIMD operation per axis and side tests all eight slabs
//! ([`traverse`]: AVX-512 and AVX2 builds chosen at run time, a portable
//! fallback, all with the same arithmetic and so the same hits). Leaves
//! hold their triangles in blocks of eight ([`Block8`], tested in one pass
//! of 8-lane operations, [`leaf`]) with the same watertight test as the
//! kd-tree ([`crate::trace::ray::intersect`]); hits equal the
//! kd-tree's and brute force's (nearest `t`, ties by triangle id).
//!
//! Deforming meshes ([`refit`]): with unchanged topology the boxes are
//! refitted bottom-up in O(n); when the refitted SAH cost exceeds
//! [`BvhBuildParams::rebuild_factor`] times the fresh build's, the tree is
//! rebuilt.
//!
//! Units: lengths in metres (world space); SAH costs are unitless (in units
//! of one block test); times in ms.

pub mod build;
pub mod leaf;
pub mod packet;
pub mod query;
pub mod refit;
pub mod stream;
pub mod traverse;
pub mod validate;

pub use leaf::Block8;
pub use traverse::Isa;

use glam::Vec3;

/// A child slot with nothing in it.
pub const EMPTY: u32 = u32::MAX;
/// Flag of a child that is a leaf: bits 0..27 first block, bits 27..31 blocks - 1.
pub const LEAF_BIT: u32 = 0x8000_0000;
/// Most blocks one leaf can name (4 bits of the child word).
pub const MAX_LEAF_BLOCKS: u32 = 16;
/// Mask of a leaf child's first block.
pub const FIRST_MASK: u32 = (1 << 27) - 1;

/// Encodes a leaf child: `blocks` blocks from `first`.
#[inline]
pub fn leaf_ref(first: u32, blocks: u32) -> u32 {
    debug_assert!((1..=MAX_LEAF_BLOCKS).contains(&blocks) && first <= FIRST_MASK);
    LEAF_BIT | (blocks - 1) << 27 | first
}

/// `(first block, block count)` of a leaf child.
#[inline(always)]
pub fn leaf_range(child: u32) -> (u32, u32) {
    (child & FIRST_MASK, (child >> 27 & 0xf) + 1)
}

/// True for a leaf child (not [`EMPTY`]).
#[inline(always)]
pub fn is_leaf(child: u32) -> bool {
    child & LEAF_BIT != 0 && child != EMPTY
}

/// One 8-wide node (256 bytes): child boxes as structure of arrays
/// (`bounds[0..3]`: minimum x, y, z of each child; `bounds[3..6]`:
/// maximum), the children (a node index, a leaf, or [`EMPTY`], whose box is
/// inverted, `+inf..-inf`, so no ray enters it), and the visiting order per
/// ray octant: bits `3o..3o+3` of `perm[i]` name the slot visited `i`-th
/// from the back for octant `o` (bit `a` of `o` set where the direction's
/// axis `a` is negative).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Node8 {
    /// Child boxes, metres: `bounds[axis][slot]` for the minima (axes 0-2) and maxima (axes 3-5).
    pub bounds: [[f32; 8]; 6],
    /// Per slot: a node index, a leaf ([`LEAF_BIT`] set, see [`leaf_range`]) or [`EMPTY`].
    pub child: [u32; 8],
    /// Visiting order per ray octant, three bits per octant (see the type's doc).
    pub perm: [u32; 8],
}

impl Node8 {
    /// A node with eight empty slots (inverted boxes, no children).
    pub const EMPTY: Node8 = Node8 {
        bounds: [
            [f32::INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::NEG_INFINITY; 8],
            [f32::NEG_INFINITY; 8],
        ],
        child: [EMPTY; 8],
        perm: [0; 8],
    };

    /// Box of slot `i` as `(min, max)`.
    #[inline]
    pub fn slot_box(&self, i: usize) -> (Vec3, Vec3) {
        let b = &self.bounds;
        (Vec3::new(b[0][i], b[1][i], b[2][i]), Vec3::new(b[3][i], b[4][i], b[5][i]))
    }

    /// Orders the slots per octant back to front: by the dot product of
    /// the box centre with the octant's direction signs, largest first
    /// (empty slots first of all; no ray enters them).
    pub fn set_order(&mut self) {
        self.perm = [0; 8];
        for o in 0..8u32 {
            let s = Vec3::new(
                if o & 1 == 0 { 1.0 } else { -1.0 },
                if o & 2 == 0 { 1.0 } else { -1.0 },
                if o & 4 == 0 { 1.0 } else { -1.0 },
            );
            let key = |i: usize| {
                if self.child[i] == EMPTY {
                    return f32::INFINITY;
                }
                let (lo, hi) = self.slot_box(i);
                ((lo + hi) * 0.5).dot(s)
            };
            let mut slots: [usize; 8] = [0, 1, 2, 3, 4, 5, 6, 7];
            slots.sort_by(|&a, &b| key(b).total_cmp(&key(a)).then(a.cmp(&b)));
            for (i, &slot) in slots.iter().enumerate() {
                self.perm[i] |= (slot as u32) << (3 * o);
            }
        }
    }

    /// Sets slot `i` to `child` with box `(min, max)`.
    #[inline]
    pub fn set_slot(&mut self, i: usize, child: u32, min: Vec3, max: Vec3) {
        for a in 0..3 {
            self.bounds[a][i] = min[a];
            self.bounds[3 + a][i] = max[a];
        }
        self.child[i] = child;
    }
}

/// Build parameters of the BVH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhBuildParams {
    /// Cost of testing one 8-wide node, in units of one block test.
    pub traversal_cost: f32,
    /// Cost of testing one block of eight triangles.
    pub intersect_cost: f32,
    /// Bins per axis of the binned SAH.
    pub bins: usize,
    /// Most triangles a leaf holds (at most 128); the SAH makes leaves of
    /// fewer where that is cheaper. The default, 8, is one block.
    pub max_leaf_triangles: usize,
    /// Subtrees with more triangles than this are built in parallel.
    pub parallel_threshold: usize,
    /// A refit whose SAH cost exceeds this factor times the last fresh
    /// build's is replaced by a rebuild (`Bvh::update`).
    pub rebuild_factor: f32,
}

impl BvhBuildParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: BvhBuildParams = Self {
        traversal_cost: 1.0,
        intersect_cost: 1.0,
        bins: 16,
        max_leaf_triangles: 8,
        parallel_threshold: 4096,
        rebuild_factor: 1.5,
    };
}

impl Default for BvhBuildParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Figures describing a built (or refitted) BVH.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// 8-wide nodes.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Blocks of eight triangle slots.
    pub blocks: usize,
    /// Mean triangles per leaf.
    pub mean_leaf_triangles: f32,
    /// Depth of the deepest leaf in 8-wide levels (root children: 1).
    pub max_depth: u32,
    /// Expected cost of a random ray by the surface area heuristic (units of one block test).
    pub sah_cost: f32,
    /// SAH cost right after the last full build.
    pub fresh_sah_cost: f32,
    /// Build time, ms.
    pub build_ms: f64,
    /// Time of the last refit, ms (0 if none).
    pub refit_ms: f64,
}

/// A built 8-wide BVH: nodes (node 0 is the root), leaf blocks, and the
/// scene bounds.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// The 8-wide nodes; node 0 is the root.
    pub nodes: Vec<Node8>,
    /// The leaf blocks of eight triangle slots.
    pub blocks: Vec<Block8>,
    /// Triangles the tree was built over.
    pub triangle_count: usize,
    /// Minimum corner of the scene bounds, metres.
    pub min: Vec3,
    /// Maximum corner of the scene bounds, metres.
    pub max: Vec3,
    /// The parameters the tree was built with.
    pub params: BvhBuildParams,
    /// Figures of the build (and of the last refit).
    pub stats: BvhStats,
    /// The node-test build the queries use ([`Isa::detect`] by default).
    /// Private: the SIMD walks trust it to be a build this CPU supports,
    /// which [`Bvh::set_isa`] checks; read it with [`Bvh::isa`].
    isa: Isa,
}

impl Bvh {
    /// Builds the tree over `triangles` (vertex ids into `positions`).
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], params: &BvhBuildParams) -> Bvh {
        build::build(positions, triangles, params)
    }

    /// Runs the queries with node tests of `isa` (the portable build where
    /// this CPU lacks it); returns the build in use.
    pub fn set_isa(&mut self, isa: Isa) -> Isa {
        // The only place `isa` is chosen after the build (which takes
        // `Isa::detect`): the walks' SAFETY comments rest on this check.
        self.isa = if isa.supported() { isa } else { Isa::Portable };
        self.isa
    }

    /// The node-test build the queries use: always one this CPU supports.
    ///
    /// It is chosen only by the build and [`Bvh::set_isa`]; setting it from
    /// outside does not compile (it once could, and then safe code could
    /// run AVX-512 instructions on a CPU without them):
    ///
    /// ```compile_fail
    /// # use linkgi::bvh::{Bvh, BvhBuildParams, Isa};
    /// # use glam::Vec3;
    /// let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
    /// let mut bvh = Bvh::build(&positions, &[[0, 1, 2]], &BvhBuildParams::default());
    /// bvh.isa = Isa::Avx512;
    /// ```
    #[cfg(any(test, feature = "internals"))]
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Bytes of the nodes and blocks.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.blocks.as_slice())
    }
}
