//! Binned SAH build of a binary BVH, collapsed into 8-wide nodes.
//!
//! Binary build: at each node the triangles' centroids are binned along all
//! three axes at once ([`BvhBuildParams::bins`] bins over the centroid
//! bounds), the best plane of the three sweeps is taken by the SAH with
//! leaves costing `intersect_cost * ceil(n / 8)`, and the index range is
//! partitioned in place. A node becomes a leaf when that is no dearer than
//! its best split and it holds at most `max_leaf_triangles`; a node whose
//! centroids all coincide is split at its median (index order). Subtrees of
//! more than `parallel_threshold` triangles are built with `rayon::join`
//! into node lists of their own, stitched in preorder; the result does not
//! depend on the thread count.
//!
//! Collapse: each 8-wide node takes a binary node's two children and opens
//! the inner child of largest surface area until it has eight (or only
//! leaves are left). Nodes are emitted in preorder (a child's index is
//! larger than its parent's, which [`super::refit`] relies on); a leaf's
//! triangles go into consecutive blocks of eight, unused lanes with NaN
//! corners (never hit) and vertex ids `u32::MAX`.

use super::leaf::{Block8, LANES};
use super::{leaf_ref, Bvh, BvhBuildParams, BvhStats, Node8};
use glam::Vec3;
use std::time::Instant;

/// A triangle's box.
#[derive(Clone, Copy, Debug)]
struct Prim {
    lo: Vec3,
    hi: Vec3,
}

impl Prim {
    /// Twice the centroid (the binning only compares, so the halving is skipped).
    #[inline(always)]
    fn c2(&self) -> Vec3 {
        self.lo + self.hi
    }
}

/// A binary node: inner (`count == 0`, children `a`, `b`) or a leaf of
/// `count` triangle ids at `ids[a..a + count]`.
#[derive(Clone, Copy, Debug)]
struct BNode {
    lo: Vec3,
    hi: Vec3,
    a: u32,
    b: u32,
    count: u32,
}

fn area(lo: Vec3, hi: Vec3) -> f32 {
    let d = (hi - lo).max(Vec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

#[derive(Clone, Copy)]
struct Bin {
    lo: Vec3,
    hi: Vec3,
    n: u32,
}

const EMPTY_BIN: Bin = Bin { lo: Vec3::splat(f32::INFINITY), hi: Vec3::splat(f32::NEG_INFINITY), n: 0 };

/// How a node is cut: ids `[..mid]` go left with box `l`, the rest right with box `r`.
struct Cut {
    mid: usize,
    l: (Vec3, Vec3),
    r: (Vec3, Vec3),
}

struct Builder<'a> {
    prims: &'a [Prim],
    p: BvhBuildParams,
}

impl Builder<'_> {
    fn blocks(n: usize) -> f32 {
        n.div_ceil(LANES) as f32
    }

    fn bounds(&self, ids: &[u32]) -> (Vec3, Vec3) {
        ids.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
            let p = &self.prims[i as usize];
            (lo.min(p.lo), hi.max(p.hi))
        })
    }

    /// The cut of a node, or `None` for a leaf.
    fn cut(&self, ids: &mut [u32], lo: Vec3, hi: Vec3) -> Option<Cut> {
        let n = ids.len();
        if n <= 2 {
            return None;
        }
        let (mut clo, mut chi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for &i in ids.iter() {
            let c = self.prims[i as usize].c2();
            clo = clo.min(c);
            chi = chi.max(c);
        }
        let nb = self.p.bins.clamp(2, 64);
        let ext = chi - clo;
        let scale = Vec3::select(ext.cmpgt(Vec3::ZERO), Vec3::splat(nb as f32) / ext, Vec3::ZERO);
        let bin_of = |c: f32, a: usize| (((c - clo[a]) * scale[a]) as usize).min(nb - 1);
        let mut bins = [[EMPTY_BIN; 64]; 3];
        for &i in ids.iter() {
            let p = &self.prims[i as usize];
            let c = p.c2();
            for a in 0..3 {
                let b = &mut bins[a][bin_of(c[a], a)];
                b.lo = b.lo.min(p.lo);
                b.hi = b.hi.max(p.hi);
                b.n += 1;
            }
        }
        // Best plane: (cost, axis, last bin on the left).
        let mut best: Option<(f32, usize, usize)> = None;
        let mut right_cost = [0f32; 64];
        for (a, bins) in bins.iter().enumerate() {
            if ext[a] <= 0.0 {
                continue;
            }
            let (mut rlo, mut rhi, mut rn) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0usize);
            for i in (1..nb).rev() {
                rlo = rlo.min(bins[i].lo);
                rhi = rhi.max(bins[i].hi);
                rn += bins[i].n as usize;
                right_cost[i] = if rn == 0 { 0.0 } else { area(rlo, rhi) * Self::blocks(rn) };
            }
            let (mut llo, mut lhi, mut ln) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0usize);
            for i in 0..nb - 1 {
                llo = llo.min(bins[i].lo);
                lhi = lhi.max(bins[i].hi);
                ln += bins[i].n as usize;
                if ln == 0 || ln == n {
                    continue;
                }
                let cost = area(llo, lhi) * Self::blocks(ln) + right_cost[i + 1];
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, a, i));
                }
            }
        }
        let parent_area = area(lo, hi).max(f32::MIN_POSITIVE);
        let leaf_cost = self.p.intersect_cost * Self::blocks(n);
        let max_leaf = self.p.max_leaf_triangles.clamp(2, LANES * super::MAX_LEAF_BLOCKS as usize);
        match best {
            Some((cost, a, split)) => {
                let split_cost = self.p.traversal_cost + self.p.intersect_cost * cost / parent_area;
                if n <= max_leaf && leaf_cost <= split_cost {
                    return None;
                }
                // Partition in place: bins 0..=split go left.
                let (mut i, mut j) = (0usize, n);
                while i < j {
                    if bin_of(self.prims[ids[i] as usize].c2()[a], a) <= split {
                        i += 1;
                    } else {
                        j -= 1;
                        ids.swap(i, j);
                    }
                }
                let side = |r: std::ops::Range<usize>| {
                    bins[a][r]
                        .iter()
                        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), b| (lo.min(b.lo), hi.max(b.hi)))
                };
                Some(Cut { mid: i, l: side(0..split + 1), r: side(split + 1..nb) })
            }
            // Every centroid in one point: a leaf if small enough, else the median.
            None if n <= max_leaf => None,
            None => {
                let mid = n / 2;
                Some(Cut { mid, l: self.bounds(&ids[..mid]), r: self.bounds(&ids[mid..]) })
            }
        }
    }

    /// Builds the subtree of `ids` (which start at `first` in the full id
    /// list) into `out` in preorder; returns its index.
    fn build_into(&self, ids: &mut [u32], first: usize, lo: Vec3, hi: Vec3, out: &mut Vec<BNode>) -> u32 {
        let me = out.len() as u32;
        out.push(BNode { lo, hi, a: first as u32, b: 0, count: ids.len() as u32 });
        if let Some(c) = self.cut(ids, lo, hi) {
            let (l, r) = ids.split_at_mut(c.mid);
            let a = self.build_into(l, first, c.l.0, c.l.1, out);
            let b = self.build_into(r, first + c.mid, c.r.0, c.r.1, out);
            out[me as usize] = BNode { lo, hi, a, b, count: 0 };
        }
        me
    }

    /// As [`Builder::build_into`], with large subtrees in parallel; the
    /// subtree's root is element 0 of the returned list.
    fn build_par(&self, ids: &mut [u32], first: usize, lo: Vec3, hi: Vec3) -> Vec<BNode> {
        if ids.len() <= self.p.parallel_threshold {
            let mut out = Vec::with_capacity(ids.len() / 2);
            self.build_into(ids, first, lo, hi, &mut out);
            return out;
        }
        let Some(c) = self.cut(ids, lo, hi) else {
            return vec![BNode { lo, hi, a: first as u32, b: 0, count: ids.len() as u32 }];
        };
        let (l, r) = ids.split_at_mut(c.mid);
        let (lv, rv) =
            rayon::join(|| self.build_par(l, first, c.l.0, c.l.1), || self.build_par(r, first + c.mid, c.r.0, c.r.1));
        let mut out = Vec::with_capacity(1 + lv.len() + rv.len());
        let (lo_off, ro_off) = (1u32, 1 + lv.len() as u32);
        out.push(BNode { lo, hi, a: lo_off, b: ro_off, count: 0 });
        let shift = |n: &BNode, off: u32| if n.count == 0 { BNode { a: n.a + off, b: n.b + off, ..*n } } else { *n };
        out.extend(lv.iter().map(|n| shift(n, lo_off)));
        out.extend(rv.iter().map(|n| shift(n, ro_off)));
        out
    }
}

/// Turns the binary tree into 8-wide nodes and leaf blocks.
struct Collapse<'a> {
    bin: &'a [BNode],
    ids: &'a [u32],
    positions: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    nodes: Vec<Node8>,
    blocks: Vec<Block8>,
    leaves: usize,
    max_depth: u32,
}

impl Collapse<'_> {
    fn leaf(&mut self, b: &BNode) -> u32 {
        let first = self.blocks.len() as u32;
        let ids = &self.ids[b.a as usize..(b.a + b.count) as usize];
        for chunk in ids.chunks(LANES) {
            let mut block = Block8::EMPTY;
            for (lane, &id) in chunk.iter().enumerate() {
                block.set(lane, id, self.triangles[id as usize], self.positions);
            }
            self.blocks.push(block);
        }
        self.leaves += 1;
        leaf_ref(first, self.blocks.len() as u32 - first)
    }

    /// Emits the 8-wide node for binary inner node `b`; returns its index.
    fn node(&mut self, b: usize, depth: u32) -> u32 {
        let bn = self.bin[b];
        let mut kids: Vec<u32> = vec![bn.a, bn.b];
        while kids.len() < 8 {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| self.bin[k as usize].count == 0)
                .max_by(|x, y| {
                    let (a, b) = (&self.bin[*x.1 as usize], &self.bin[*y.1 as usize]);
                    area(a.lo, a.hi).total_cmp(&area(b.lo, b.hi))
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let k = self.bin[kids[i] as usize];
            kids[i] = k.a;
            kids.push(k.b);
        }
        let me = self.nodes.len() as u32;
        self.nodes.push(Node8::EMPTY);
        for (slot, &k) in kids.iter().enumerate() {
            let kn = self.bin[k as usize];
            let child = if kn.count == 0 {
                self.node(k as usize, depth + 1)
            } else {
                self.max_depth = self.max_depth.max(depth);
                self.leaf(&kn)
            };
            self.nodes[me as usize].set_slot(slot, child, kn.lo, kn.hi);
        }
        self.nodes[me as usize].set_order();
        me
    }
}

/// Builds the BVH (see the module doc).
pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], params: &BvhBuildParams) -> Bvh {
    let start = Instant::now();
    let prims: Vec<Prim> = triangles
        .iter()
        .map(|t| {
            let (a, b, c) = (positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]);
            Prim { lo: a.min(b).min(c), hi: a.max(b).max(c) }
        })
        .collect();
    let mut ids: Vec<u32> = (0..triangles.len() as u32).collect();
    let builder = Builder { prims: &prims, p: *params };
    let (lo, hi) = builder.bounds(&ids);
    let bin = if ids.is_empty() { Vec::new() } else { builder.build_par(&mut ids, 0, lo, hi) };
    let mut c = Collapse {
        bin: &bin,
        ids: &ids,
        positions,
        triangles,
        nodes: Vec::with_capacity(bin.len() / 4 + 1),
        blocks: Vec::with_capacity(triangles.len() / 3 + 1),
        leaves: 0,
        max_depth: 0,
    };
    match bin.first() {
        None => {}
        // Everything fits one leaf: a root with one slot.
        Some(l) if l.count > 0 => {
            let mut root = Node8::EMPTY;
            let child = c.leaf(l);
            root.set_slot(0, child, l.lo, l.hi);
            root.set_order();
            c.nodes.push(root);
            c.max_depth = 1;
        }
        Some(_) => {
            c.node(0, 1);
        }
    }
    let (nodes, blocks, leaves, max_depth) = (c.nodes, c.blocks, c.leaves, c.max_depth);
    let mut bvh = Bvh {
        nodes,
        blocks,
        triangle_count: triangles.len(),
        min: lo,
        max: hi,
        params: *params,
        stats: BvhStats::default(),
        isa: super::Isa::detect(),
    };
    let sah = bvh.sah_cost();
    bvh.stats = BvhStats {
        nodes: bvh.nodes.len(),
        leaves,
        blocks: bvh.blocks.len(),
        mean_leaf_triangles: triangles.len() as f32 / leaves.max(1) as f32,
        max_depth,
        sah_cost: sah,
        fresh_sah_cost: sah,
        build_ms: start.elapsed().as_secs_f64() * 1e3,
        refit_ms: 0.0,
    };
    bvh
}
