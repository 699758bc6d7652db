//! kd-tree construction: object-median top levels built in parallel, then
//! one O(n log n) SAH event sweep per subtree (see the module doc of
//! [`crate::kdtree`]), then ropes.
//!
//! Implementation (none of it changes the tree; it is the same tree, node
//! for node, as a textbook version of the sweep):
//! - An event is one `u64` key: the position mapped to an unsigned integer
//!   in `f32::total_cmp` order, then the kind, then the triangle id, so the
//!   event order is integer order and an event is 8 bytes.
//! - A subtree's initial event lists are sorted with a stable LSD radix sort
//!   on position and kind (events are generated in increasing triangle
//!   order, so stability gives the triangle tie-break for free).
//! - The event lists of the nodes on the current recursion path live in one
//!   arena per subtree: a split appends the two children's lists (filtered
//!   parent lists merged with the clipped events of straddling triangles)
//!   and truncates them when both children are done, so no node allocates.
//! - Nodes, leaves and leaf triangle lists are written straight into the
//!   flattened preorder layout; the parallel subtrees are concatenated with
//!   their indices shifted.

use super::accel::ROPE_LEAF;
use super::{ropes, Aabb, CpuAccel, KdBuildParams, KdLeaf, KdNode, KdStats, KdTree, LEAF, NO_ROPE};
use crate::trace::ray::KdTriangle;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Event kinds, ordered so that at equal positions ends come first, then
/// planar, then starts (the order the sweep needs).
const END: u64 = 0;
const PLANAR: u64 = 1;
const START: u64 = 2;

/// Bits of the triangle id in an event key (the kind sits above them).
const TRI_BITS: u32 = 30;
const TRI_MASK: u64 = (1 << TRI_BITS) - 1;

/// `f32` to `u32` in `total_cmp` order.
#[inline(always)]
fn order_bits(p: f32) -> u32 {
    let b = p.to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// Event key: position (total order), kind, triangle.
#[inline(always)]
fn event(pos: f32, kind: u64, tri: u32) -> u64 {
    (order_bits(pos) as u64) << 32 | kind << TRI_BITS | tri as u64
}

#[inline(always)]
fn ev_pos(k: u64) -> f32 {
    let b = (k >> 32) as u32;
    f32::from_bits(if b >> 31 == 1 { b & 0x7fff_ffff } else { !b })
}

#[inline(always)]
fn ev_kind(k: u64) -> u64 {
    (k >> TRI_BITS) & 3
}

#[inline(always)]
fn ev_tri(k: u64) -> usize {
    (k & TRI_MASK) as usize
}

/// Which side of a split a triangle goes to.
const BOTH: u8 = 0;
const LEFT: u8 = 1;
const RIGHT: u8 = 2;

struct Ctx<'a> {
    bounds: &'a [Aabb],
    p: &'a KdBuildParams,
    max_depth: u32,
}

/// Pushes the events of triangle `t` clipped to `node` onto the three lists.
fn push_events(lists: &mut [Vec<u64>], t: u32, tb: &Aabb, node: &Aabb) {
    let c = tb.intersect(node);
    for (a, list) in lists.iter_mut().enumerate().take(3) {
        // A triangle touching the box only in a plane still gets (planar) events.
        let (lo, hi) = (c.min[a], c.max[a].max(c.min[a]));
        if lo == hi {
            list.push(event(lo, PLANAR, t));
        } else {
            list.push(event(lo, START, t));
            list.push(event(hi, END, t));
        }
    }
}

struct Split {
    axis: usize,
    pos: f32,
    planar_left: bool,
    cost: f32,
}

fn sah_cost(ctx: &Ctx, node: &Aabb, axis: usize, pos: f32, nl: usize, nr: usize) -> f32 {
    let (l, r) = node.split(axis, pos);
    let inv = 1.0 / node.area();
    let (pl, pr) = (l.area() * inv, r.area() * inv);
    let bonus = if nl == 0 || nr == 0 { 1.0 - ctx.p.empty_bonus } else { 1.0 };
    bonus * (ctx.p.traversal_cost + ctx.p.intersect_cost * (pl * ctx.p.blocks(nl) + pr * ctx.p.blocks(nr)))
}

/// Full SAH sweep over the sorted events of all three axes.
fn find_split(ctx: &Ctx, node: &Aabb, lists: [&[u64]; 3], n: usize) -> Option<Split> {
    let mut best: Option<Split> = None;
    for (axis, list) in lists.iter().enumerate() {
        if node.max[axis] <= node.min[axis] {
            continue;
        }
        let (mut nl, mut nr) = (0usize, n);
        let mut i = 0;
        while i < list.len() {
            let pos = ev_pos(list[i]);
            let (mut ends, mut planars, mut starts) = (0usize, 0usize, 0usize);
            while i < list.len() && ev_pos(list[i]) == pos && ev_kind(list[i]) == END {
                ends += 1;
                i += 1;
            }
            while i < list.len() && ev_pos(list[i]) == pos && ev_kind(list[i]) == PLANAR {
                planars += 1;
                i += 1;
            }
            while i < list.len() && ev_pos(list[i]) == pos && ev_kind(list[i]) == START {
                starts += 1;
                i += 1;
            }
            nr -= planars + ends;
            if pos > node.min[axis] && pos < node.max[axis] {
                let cl = sah_cost(ctx, node, axis, pos, nl + planars, nr);
                let cr = sah_cost(ctx, node, axis, pos, nl, nr + planars);
                let (cost, planar_left) = if cl <= cr { (cl, true) } else { (cr, false) };
                if best.as_ref().is_none_or(|b| cost < b.cost) {
                    best = Some(Split { axis, pos, planar_left, cost });
                }
            }
            nl += starts + planars;
        }
    }
    best
}

/// Splits the events of `src` by the side of their triangle, merging the
/// sorted fresh events `fl` and `fr` in; returns the lengths written to
/// `dl` and `dr`.
fn split_list(src: &[u64], side: &[u8], fl: &[u64], fr: &[u64], dl: &mut [u64], dr: &mut [u64]) -> (usize, usize) {
    let (mut jl, mut jr, mut ol, mut or) = (0, 0, 0, 0);
    for &k in src {
        match side[ev_tri(k)] {
            LEFT => {
                while jl < fl.len() && fl[jl] < k {
                    dl[ol] = fl[jl];
                    ol += 1;
                    jl += 1;
                }
                dl[ol] = k;
                ol += 1;
            }
            RIGHT => {
                while jr < fr.len() && fr[jr] < k {
                    dr[or] = fr[jr];
                    or += 1;
                    jr += 1;
                }
                dr[or] = k;
                or += 1;
            }
            _ => {}
        }
    }
    let (tl, tr) = (fl.len() - jl, fr.len() - jr);
    dl[ol..ol + tl].copy_from_slice(&fl[jl..]);
    dr[or..or + tr].copy_from_slice(&fr[jr..]);
    (ol + tl, or + tr)
}

/// Stable LSD radix sort of event keys on position and kind (the bits above
/// the triangle id); `tmp` is scratch.
fn radix_sort(keys: &mut Vec<u64>, tmp: &mut Vec<u64>, count: &mut Vec<usize>) {
    tmp.resize(keys.len(), 0);
    for (shift, bits) in [(TRI_BITS, 12u32), (TRI_BITS + 12, 11), (TRI_BITS + 23, 11)] {
        let mask = (1u64 << bits) - 1;
        count.clear();
        count.resize(1 << bits, 0);
        for &k in keys.iter() {
            count[((k >> shift) & mask) as usize] += 1;
        }
        if count.contains(&keys.len()) {
            continue;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let here = *c;
            *c = sum;
            sum += here;
        }
        for &k in keys.iter() {
            let d = ((k >> shift) & mask) as usize;
            tmp[count[d]] = k;
            count[d] += 1;
        }
        std::mem::swap(keys, tmp);
    }
}

/// A part of the flattened tree in preorder (indices local to the part).
#[derive(Default)]
struct Part {
    nodes: Vec<KdNode>,
    leaves: Vec<KdLeaf>,
    leaf_triangles: Vec<u32>,
}

impl Part {
    fn leaf(&mut self, bx: &Aabb, tris: impl Iterator<Item = u32>) -> u32 {
        let idx = self.nodes.len() as u32;
        let first = self.leaf_triangles.len();
        self.leaf_triangles.extend(tris);
        self.nodes.push(KdNode { split: 0.0, kind: LEAF, a: self.leaves.len() as u32, b: 0 });
        self.leaves.push(KdLeaf {
            min: bx.min.into(),
            first: first as u32,
            max: bx.max.into(),
            count: (self.leaf_triangles.len() - first) as u32,
            ropes: [NO_ROPE; 6],
            _pad: [0; 2],
        });
        idx
    }

    /// Appends `other`, shifting its indices; returns the index of its root.
    fn append(&mut self, other: Part) -> u32 {
        let (n0, l0, t0) = (self.nodes.len() as u32, self.leaves.len() as u32, self.leaf_triangles.len() as u32);
        self.nodes.extend(other.nodes.iter().map(|n| {
            if n.kind == LEAF {
                KdNode { a: n.a + l0, ..*n }
            } else {
                KdNode { a: n.a + n0, b: n.b + n0, ..*n }
            }
        }));
        self.leaves.extend(other.leaves.iter().map(|l| KdLeaf { first: l.first + t0, ..*l }));
        self.leaf_triangles.extend_from_slice(&other.leaf_triangles);
        n0
    }
}

/// One SAH subtree: the event arena, the side of each triangle, scratch
/// lists for straddling triangles' clipped events, and the output.
struct Sweep<'a> {
    ctx: &'a Ctx<'a>,
    side: Vec<u8>,
    arena: Vec<u64>,
    /// Clipped events of straddlers: left x, y, z, then right x, y, z.
    fresh: [Vec<u64>; 6],
    out: Part,
}

type Lists = [(usize, usize); 3];

impl Sweep<'_> {
    fn list(&self, r: (usize, usize)) -> &[u64] {
        &self.arena[r.0..r.0 + r.1]
    }

    fn leaf(&mut self, bx: &Aabb, r: (usize, usize)) -> u32 {
        let list = &self.arena[r.0..r.0 + r.1];
        self.out.leaf(bx, list.iter().filter(|&&k| ev_kind(k) != END).map(|&k| ev_tri(k) as u32))
    }

    /// Builds the subtree of box `bx` over `n` triangles with event lists `r`.
    fn node(&mut self, bx: Aabb, r: Lists, n: usize, depth: u32) -> u32 {
        let ctx = self.ctx;
        if n == 0 || depth >= ctx.max_depth || bx.area() <= 0.0 {
            return self.leaf(&bx, r[0]);
        }
        let Some(split) = find_split(ctx, &bx, r.map(|r| self.list(r)), n) else {
            return self.leaf(&bx, r[0]);
        };
        if split.cost >= ctx.p.intersect_cost * ctx.p.blocks(n) {
            return self.leaf(&bx, r[0]);
        }
        let (lbox, rbox) = bx.split(split.axis, split.pos);
        let base = self.arena.len();
        let (child, counts) = self.split_lists(&r, &split, &lbox, &rbox);
        let idx = self.out.nodes.len();
        self.out.nodes.push(KdNode::default());
        let l = self.node(lbox, child[0], counts[0], depth + 1);
        let rr = self.node(rbox, child[1], counts[1], depth + 1);
        self.out.nodes[idx] = KdNode { split: split.pos, kind: split.axis as u32, a: l, b: rr };
        self.arena.truncate(base);
        idx as u32
    }

    /// Classifies the node's triangles for `split` and appends the two
    /// children's event lists to the arena; returns their ranges and
    /// triangle counts.
    fn split_lists(&mut self, r: &Lists, split: &Split, lbox: &Aabb, rbox: &Aabb) -> ([Lists; 2], [usize; 2]) {
        // Classify.
        let Sweep { ctx, side, arena, fresh, .. } = self;
        let list0 = &arena[r[0].0..r[0].0 + r[0].1];
        for &k in list0 {
            if ev_kind(k) != END {
                side[ev_tri(k)] = BOTH;
            }
        }
        let ra = r[split.axis];
        for &k in &arena[ra.0..ra.0 + ra.1] {
            let pos = ev_pos(k);
            match ev_kind(k) {
                END if pos <= split.pos => side[ev_tri(k)] = LEFT,
                START if pos >= split.pos => side[ev_tri(k)] = RIGHT,
                PLANAR => {
                    let left = pos < split.pos || (pos == split.pos && split.planar_left);
                    side[ev_tri(k)] = if left { LEFT } else { RIGHT };
                }
                _ => {}
            }
        }
        // Straddlers get fresh events clipped to each child.
        for f in fresh.iter_mut() {
            f.clear();
        }
        let mut counts = [0usize; 3];
        for &k in list0 {
            let t = ev_tri(k);
            if ev_kind(k) == END {
                continue;
            }
            counts[side[t] as usize] += 1;
            if side[t] == BOTH {
                let tb = &ctx.bounds[t];
                push_events(&mut fresh[0..3], t as u32, tb, lbox);
                push_events(&mut fresh[3..6], t as u32, tb, rbox);
            }
        }
        for f in fresh.iter_mut() {
            f.sort_unstable();
        }
        // Child lists: the parent's, filtered by side, merged with the fresh
        // ones, each in a slot of the arena sized for its upper bound.
        let base = arena.len();
        let cap: [usize; 3] = std::array::from_fn(|a| r[a].1 + fresh[a].len().max(fresh[3 + a].len()));
        arena.resize(base + 2 * cap.iter().sum::<usize>(), 0);
        let (old, new) = arena.split_at_mut(base);
        let mut child: [Lists; 2] = Default::default();
        let mut off = 0;
        for a in 0..3 {
            let (dl, rest) = new[off..off + 2 * cap[a]].split_at_mut(cap[a]);
            let (nl, nr) = split_list(&old[r[a].0..r[a].0 + r[a].1], side, &fresh[a], &fresh[3 + a], dl, rest);
            child[0][a] = (base + off, nl);
            child[1][a] = (base + off + cap[a], nr);
            off += 2 * cap[a];
        }
        (child, [counts[LEFT as usize] + counts[BOTH as usize], counts[RIGHT as usize] + counts[BOTH as usize]])
    }
}

/// An SAH subtree over `tris` (increasing ids): events clipped to `node`,
/// radix-sorted once, then the sweep.
fn sah_subtree(ctx: &Ctx, node: Aabb, tris: &[u32], depth: u32) -> Part {
    debug_assert!(tris.windows(2).all(|w| w[0] < w[1]));
    let mut lists: [Vec<u64>; 3] = Default::default();
    for l in lists.iter_mut() {
        l.reserve(tris.len() * 2);
    }
    for &t in tris {
        push_events(&mut lists, t, &ctx.bounds[t as usize], &node);
    }
    let (mut tmp, mut count) = (Vec::new(), Vec::new());
    let mut arena = Vec::with_capacity(lists.iter().map(Vec::len).sum::<usize>() * 3);
    let mut r: Lists = Default::default();
    for (a, l) in lists.iter_mut().enumerate() {
        radix_sort(l, &mut tmp, &mut count);
        r[a] = (arena.len(), l.len());
        arena.extend_from_slice(l);
    }
    drop(lists);
    let mut sweep =
        Sweep { ctx, side: vec![BOTH; ctx.bounds.len()], arena, fresh: Default::default(), out: Part::default() };
    sweep.node(node, r, tris.len(), depth);
    sweep.out
}

/// Object-median levels at the top, children built in parallel.
fn build_top(ctx: &Ctx, node: Aabb, tris: Vec<u32>, depth: u32, levels_left: u32) -> Part {
    if levels_left == 0 || tris.len() < 64 || node.area() <= 0.0 {
        return sah_subtree(ctx, node, &tris, depth);
    }
    let axis = (node.max - node.min).max_position();
    let mut centroids: Vec<f32> =
        tris.iter().map(|&t| 0.5 * (ctx.bounds[t as usize].min[axis] + ctx.bounds[t as usize].max[axis])).collect();
    let mid = centroids.len() / 2;
    let (_, &mut pos, _) = centroids.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    if !(pos > node.min[axis] && pos < node.max[axis]) {
        return sah_subtree(ctx, node, &tris, depth);
    }
    let (lbox, rbox) = node.split(axis, pos);
    let (mut lt, mut rt) = (Vec::new(), Vec::new());
    for &t in &tris {
        let b = ctx.bounds[t as usize];
        if b.max[axis] < pos || (b.max[axis] == pos && b.min[axis] < pos) {
            lt.push(t);
        } else if b.min[axis] >= pos {
            rt.push(t);
        } else {
            lt.push(t);
            rt.push(t);
        }
    }
    drop(tris);
    let (l, r) = rayon::join(
        || build_top(ctx, lbox, lt, depth + 1, levels_left - 1),
        || build_top(ctx, rbox, rt, depth + 1, levels_left - 1),
    );
    let mut part = Part {
        nodes: Vec::with_capacity(1 + l.nodes.len() + r.nodes.len()),
        leaves: Vec::with_capacity(l.leaves.len() + r.leaves.len()),
        leaf_triangles: Vec::with_capacity(l.leaf_triangles.len() + r.leaf_triangles.len()),
    };
    part.nodes.push(KdNode::default());
    let li = part.append(l);
    let ri = part.append(r);
    part.nodes[0] = KdNode { split: pos, kind: axis as u32, a: li, b: ri };
    part
}

/// Depth and SAH cost of the flattened tree (preorder, as the tree is stored).
fn tree_stats(kd: &KdTree, node: u32, bx: Aabb, depth: u32, root_area: f32, stats: &mut KdStats, sah: &mut f64) {
    stats.max_depth = stats.max_depth.max(depth);
    let rel = if root_area > 0.0 { (bx.area() / root_area) as f64 } else { 1.0 };
    let n = kd.nodes[node as usize];
    if n.kind == LEAF {
        *sah += rel * kd.params.intersect_cost as f64 * kd.params.blocks(kd.leaves[n.a as usize].count as usize) as f64;
    } else {
        *sah += rel * kd.params.traversal_cost as f64;
        let (lb, rb) = bx.split(n.kind as usize, n.split);
        tree_stats(kd, n.a, lb, depth + 1, root_area, stats, sah);
        tree_stats(kd, n.b, rb, depth + 1, root_area, stats, sah);
    }
}

/// Builds the tree (see the module doc).
pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], params: &KdBuildParams) -> KdTree {
    let start = Instant::now();
    assert!((triangles.len() as u64) <= TRI_MASK, "kd-tree: at most 2^30 triangles");
    let bounds: Vec<Aabb> =
        triangles.par_iter().map(|t| Aabb::of_points(&[0, 1, 2].map(|k| positions[t[k] as usize]))).collect();
    let root = bounds.iter().fold(Aabb::EMPTY, |b, t| Aabb { min: b.min.min(t.min), max: b.max.max(t.max) });
    let root = if triangles.is_empty() { Aabb { min: Vec3::ZERO, max: Vec3::ZERO } } else { root };
    let n = triangles.len().max(1) as f32;
    let max_depth = params.max_depth.unwrap_or((8.0 + 1.3 * n.log2()).round() as u32);
    let levels = params
        .parallel_levels
        .unwrap_or_else(|| (rayon::current_num_threads().max(1) as f32).log2().ceil() as u32)
        .min(max_depth);
    let ctx = Ctx { bounds: &bounds, p: params, max_depth };
    let (part, kd_triangles) = rayon::join(
        || build_top(&ctx, root, (0..triangles.len() as u32).collect(), 0, levels),
        || {
            triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| positions[i as usize]);
                    KdTriangle { v0: a.into(), ia: t[0], v1: b.into(), ib: t[1], v2: c.into(), ic: t[2] }
                })
                .collect()
        },
    );
    let mut kd = KdTree {
        nodes: part.nodes,
        leaves: part.leaves,
        leaf_triangles: part.leaf_triangles,
        triangles: kd_triangles,
        accel: CpuAccel::default(),
        min: root.min,
        max: root.max,
        params: *params,
        stats: KdStats::default(),
    };
    assert!(kd.nodes.len() < ROPE_LEAF as usize, "kd-tree: at most 2^31 nodes");
    ropes::build_ropes(&mut kd);
    kd.accel = CpuAccel::new(&kd.nodes, &kd.leaves, &kd.leaf_triangles, &kd.triangles);
    let (mut stats, mut sah) = (KdStats::default(), 0.0f64);
    tree_stats(&kd, 0, root, 0, root.area(), &mut stats, &mut sah);
    let non_empty = kd.leaves.iter().filter(|l| l.count > 0).count();
    stats.nodes = kd.nodes.len();
    stats.leaves = kd.leaves.len();
    stats.empty_leaves = kd.leaves.len() - non_empty;
    stats.mean_leaf_triangles = kd.leaf_triangles.len() as f32 / non_empty.max(1) as f32;
    stats.sah_cost = sah as f32;
    stats.build_ms = start.elapsed().as_secs_f64() * 1e3;
    kd.stats = stats;
    kd
}
