//! kd-tree construction: object-median top levels built in parallel, then
//! one O(n log n) SAH event sweep per subtree (see the module doc of
//! [`crate::kdtree`]), then flattening and ropes.

use super::{ropes, Aabb, KdBuildParams, KdLeaf, KdNode, KdStats, KdTree, KdTriangle, LEAF, NO_ROPE};
use glam::Vec3;
use std::time::Instant;

/// Event kinds, ordered so that at equal positions ends come first, then
/// planar, then starts (the order the sweep needs).
const END: u8 = 0;
const PLANAR: u8 = 1;
const START: u8 = 2;

#[derive(Clone, Copy, Debug)]
struct Event {
    pos: f32,
    tri: u32,
    kind: u8,
}

fn event_order(a: &Event, b: &Event) -> std::cmp::Ordering {
    a.pos.total_cmp(&b.pos).then(a.kind.cmp(&b.kind)).then(a.tri.cmp(&b.tri))
}

/// Build-time tree (boxed), flattened afterwards.
enum BNode {
    Leaf(Vec<u32>),
    Inner { axis: u8, split: f32, left: Box<BNode>, right: Box<BNode> },
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
fn push_events(lists: &mut [Vec<Event>; 3], t: u32, tb: &Aabb, node: &Aabb) {
    let c = tb.intersect(node);
    for (a, list) in lists.iter_mut().enumerate() {
        // A triangle touching the box only in a plane still gets (planar) events.
        let (lo, hi) = (c.min[a], c.max[a].max(c.min[a]));
        if lo == hi {
            list.push(Event { pos: lo, tri: t, kind: PLANAR });
        } else {
            list.push(Event { pos: lo, tri: t, kind: START });
            list.push(Event { pos: hi, tri: t, kind: END });
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
    bonus * (ctx.p.traversal_cost + ctx.p.intersect_cost * (pl * nl as f32 + pr * nr as f32))
}

/// Full SAH sweep over the sorted events of all three axes.
fn find_split(ctx: &Ctx, node: &Aabb, lists: &[Vec<Event>; 3], n: usize) -> Option<Split> {
    let mut best: Option<Split> = None;
    for (axis, list) in lists.iter().enumerate() {
        if node.max[axis] <= node.min[axis] {
            continue;
        }
        let (mut nl, mut nr) = (0usize, n);
        let mut i = 0;
        while i < list.len() {
            let pos = list[i].pos;
            let (mut ends, mut planars, mut starts) = (0usize, 0usize, 0usize);
            while i < list.len() && list[i].pos == pos && list[i].kind == END {
                ends += 1;
                i += 1;
            }
            while i < list.len() && list[i].pos == pos && list[i].kind == PLANAR {
                planars += 1;
                i += 1;
            }
            while i < list.len() && list[i].pos == pos && list[i].kind == START {
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

fn build_sah(ctx: &Ctx, node: Aabb, lists: [Vec<Event>; 3], depth: u32, side: &mut [u8]) -> BNode {
    let tris: Vec<u32> = lists[0].iter().filter(|e| e.kind != END).map(|e| e.tri).collect();
    let n = tris.len();
    if n == 0 || depth >= ctx.max_depth || node.area() <= 0.0 {
        return BNode::Leaf(tris);
    }
    let Some(split) = find_split(ctx, &node, &lists, n) else {
        return BNode::Leaf(tris);
    };
    if split.cost >= ctx.p.intersect_cost * n as f32 {
        return BNode::Leaf(tris);
    }
    // Classify.
    for &t in &tris {
        side[t as usize] = BOTH;
    }
    for e in &lists[split.axis] {
        match e.kind {
            END if e.pos <= split.pos => side[e.tri as usize] = LEFT,
            START if e.pos >= split.pos => side[e.tri as usize] = RIGHT,
            PLANAR => {
                let left = e.pos < split.pos || (e.pos == split.pos && split.planar_left);
                side[e.tri as usize] = if left { LEFT } else { RIGHT };
            }
            _ => {}
        }
    }
    let (lbox, rbox) = node.split(split.axis, split.pos);
    // Split sorted lists; straddlers get fresh clipped events, sorted and merged.
    let mut left: [Vec<Event>; 3] = Default::default();
    let mut right: [Vec<Event>; 3] = Default::default();
    for a in 0..3 {
        left[a].reserve(lists[a].len() / 2);
        right[a].reserve(lists[a].len() / 2);
        for e in &lists[a] {
            match side[e.tri as usize] {
                LEFT => left[a].push(*e),
                RIGHT => right[a].push(*e),
                _ => {}
            }
        }
    }
    let mut new_l: [Vec<Event>; 3] = Default::default();
    let mut new_r: [Vec<Event>; 3] = Default::default();
    for &t in &tris {
        if side[t as usize] == BOTH {
            let tb = &ctx.bounds[t as usize];
            push_events(&mut new_l, t, tb, &lbox);
            push_events(&mut new_r, t, tb, &rbox);
        }
    }
    drop(lists);
    for a in 0..3 {
        left[a] = merge_sorted(std::mem::take(&mut left[a]), std::mem::take(&mut new_l[a]));
        right[a] = merge_sorted(std::mem::take(&mut right[a]), std::mem::take(&mut new_r[a]));
    }
    let l = build_sah(ctx, lbox, left, depth + 1, side);
    let r = build_sah(ctx, rbox, right, depth + 1, side);
    BNode::Inner { axis: split.axis as u8, split: split.pos, left: Box::new(l), right: Box::new(r) }
}

fn merge_sorted(a: Vec<Event>, mut b: Vec<Event>) -> Vec<Event> {
    if b.is_empty() {
        return a;
    }
    b.sort_unstable_by(event_order);
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if event_order(&a[i], &b[j]).is_le() {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// Starts an SAH subtree: events for `tris` clipped to `node`, sorted once.
fn sah_subtree(ctx: &Ctx, node: Aabb, tris: &[u32], depth: u32) -> BNode {
    let mut lists: [Vec<Event>; 3] = Default::default();
    for l in lists.iter_mut() {
        l.reserve(tris.len() * 2);
    }
    for &t in tris {
        push_events(&mut lists, t, &ctx.bounds[t as usize], &node);
    }
    for l in lists.iter_mut() {
        l.sort_unstable_by(event_order);
    }
    let mut side = vec![BOTH; ctx.bounds.len()];
    build_sah(ctx, node, lists, depth, &mut side)
}

/// Object-median levels at the top, children built in parallel.
fn build_top(ctx: &Ctx, node: Aabb, tris: Vec<u32>, depth: u32, levels_left: u32) -> BNode {
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
    BNode::Inner { axis: axis as u8, split: pos, left: Box::new(l), right: Box::new(r) }
}

struct Flat {
    nodes: Vec<KdNode>,
    leaves: Vec<KdLeaf>,
    leaf_triangles: Vec<u32>,
    stats: KdStats,
    sah: f64,
}

fn flatten(b: &BNode, bx: Aabb, depth: u32, root_area: f32, p: &KdBuildParams, out: &mut Flat) -> u32 {
    let idx = out.nodes.len() as u32;
    out.nodes.push(KdNode::default());
    out.stats.max_depth = out.stats.max_depth.max(depth);
    let rel = if root_area > 0.0 { (bx.area() / root_area) as f64 } else { 1.0 };
    match b {
        BNode::Leaf(tris) => {
            let leaf = KdLeaf {
                min: bx.min.into(),
                first: out.leaf_triangles.len() as u32,
                max: bx.max.into(),
                count: tris.len() as u32,
                ropes: [NO_ROPE; 6],
                _pad: [0; 2],
            };
            out.leaf_triangles.extend_from_slice(tris);
            out.nodes[idx as usize] = KdNode { split: 0.0, kind: LEAF, a: out.leaves.len() as u32, b: 0 };
            out.leaves.push(leaf);
            out.sah += rel * p.intersect_cost as f64 * tris.len() as f64;
        }
        BNode::Inner { axis, split, left, right } => {
            out.sah += rel * p.traversal_cost as f64;
            let (lb, rb) = bx.split(*axis as usize, *split);
            let l = flatten(left, lb, depth + 1, root_area, p, out);
            let r = flatten(right, rb, depth + 1, root_area, p, out);
            out.nodes[idx as usize] = KdNode { split: *split, kind: *axis as u32, a: l, b: r };
        }
    }
    idx
}

/// Builds the tree (see the module doc).
pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], params: &KdBuildParams) -> KdTree {
    let start = Instant::now();
    let bounds: Vec<Aabb> =
        triangles.iter().map(|t| Aabb::of_points(&[0, 1, 2].map(|k| positions[t[k] as usize]))).collect();
    let root = bounds.iter().fold(Aabb::EMPTY, |b, t| Aabb { min: b.min.min(t.min), max: b.max.max(t.max) });
    let root = if triangles.is_empty() { Aabb { min: Vec3::ZERO, max: Vec3::ZERO } } else { root };
    let n = triangles.len().max(1) as f32;
    let max_depth = params.max_depth.unwrap_or((8.0 + 1.3 * n.log2()).round() as u32);
    let levels = params
        .parallel_levels
        .unwrap_or_else(|| (rayon::current_num_threads().max(1) as f32).log2().ceil() as u32)
        .min(max_depth);
    let ctx = Ctx { bounds: &bounds, p: params, max_depth };
    let tree = build_top(&ctx, root, (0..triangles.len() as u32).collect(), 0, levels);
    let mut flat = Flat { nodes: vec![], leaves: vec![], leaf_triangles: vec![], stats: KdStats::default(), sah: 0.0 };
    flatten(&tree, root, 0, root.area(), params, &mut flat);
    drop(tree);
    let mut kd = KdTree {
        nodes: flat.nodes,
        leaves: flat.leaves,
        leaf_triangles: flat.leaf_triangles,
        triangles: triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                KdTriangle { v0: a.into(), ia: t[0], v1: b.into(), ib: t[1], v2: c.into(), ic: t[2] }
            })
            .collect(),
        min: root.min,
        max: root.max,
        params: *params,
        stats: flat.stats,
    };
    ropes::build_ropes(&mut kd);
    let non_empty = kd.leaves.iter().filter(|l| l.count > 0).count();
    kd.stats.nodes = kd.nodes.len();
    kd.stats.leaves = kd.leaves.len();
    kd.stats.empty_leaves = kd.leaves.len() - non_empty;
    kd.stats.mean_leaf_triangles = kd.leaf_triangles.len() as f32 / non_empty.max(1) as f32;
    kd.stats.sah_cost = flat.sah as f32;
    kd.stats.build_ms = start.elapsed().as_secs_f64() * 1e3;
    kd
}
