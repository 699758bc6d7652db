// The rope kd-tree walk (docs/DESIGN.md §1, §5), joined before
// `trace.wgsl`, which holds the entry points and the triangle test.
//
// The traversal mirrors `src/kdtree/traverse.rs` (`walk_ropes`) step by
// step: locate the leaf holding the entry point, test its triangles, leave
// through the exit face's rope. Distances in metres.

const LEAF: u32 = 3u;
const NO_ROPE: u32 = 0xffffffffu;

struct KdNode {
    split: f32,
    kind: u32,
    a: u32,
    b: u32,
}

struct KdLeaf {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
    ropes: array<u32, 6>,
    _pad: array<u32, 2>,
}

@group(0) @binding(1) var<storage, read> nodes: array<KdNode>;
@group(0) @binding(2) var<storage, read> leaves: array<KdLeaf>;
@group(0) @binding(3) var<storage, read> leaf_triangles: array<u32>;
@group(0) @binding(4) var<storage, read> triangles: array<KdTriangle>;

// Tests a leaf's triangles; returns true if `any_hit` and something was hit.
fn test_leaf(leaf_id: u32, o: vec3<f32>, s: Shear, tmin: f32, tmax_ray: f32, skip: u32, any_hit: bool,
             best: ptr<function, Best>) -> bool {
    let leaf = leaves[leaf_id];
    for (var i = leaf.first; i < leaf.first + leaf.count; i++) {
        let id = leaf_triangles[i];
        let tri = triangles[id];
        if tri.ia == skip || tri.ib == skip || tri.ic == skip {
            continue;
        }
        var tmax = tmax_ray;
        if (*best).tri != HIT_MISS {
            tmax = (*best).t;
        }
        if hit_triangle(id, tri.v0, tri.v1, tri.v2, o, s, tmin, tmax, best) && any_hit {
            return true;
        }
    }
    return false;
}

// The leaf under `start` containing `p` (ties go the way `d` points).
fn locate(start: u32, p: vec3<f32>, d: vec3<f32>) -> u32 {
    var node = start;
    var n = nodes[node];
    while n.kind != LEAF {
        let a = n.kind;
        if p[a] < n.split || (p[a] == n.split && d[a] <= 0.0) {
            node = n.a;
        } else {
            node = n.b;
        }
        n = nodes[node];
    }
    return n.a;
}

// Nearest (or any) hit on the segment [tmin, tmax] by walking leaf ropes.
fn trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, skip: u32, any_hit: bool) -> Best {
    var best = no_hit();
    // 1/d, with 0 where d is 0 (those axes are never divided by below).
    let inv = select(1.0 / d, vec3<f32>(0.0), d == vec3<f32>(0.0));
    var t_enter = tmin;
    var t_exit_root = tmax;
    for (var a = 0u; a < 3u; a++) {
        if d[a] == 0.0 {
            if o[a] < params.root_min[a] || o[a] > params.root_max[a] {
                return best;
            }
            continue;
        }
        let ta = (params.root_min[a] - o[a]) * inv[a];
        let tb = (params.root_max[a] - o[a]) * inv[a];
        t_enter = max(t_enter, min(ta, tb));
        t_exit_root = min(t_exit_root, max(ta, tb));
    }
    if !(t_enter <= t_exit_root) {
        return best;
    }
    let s = make_shear(d);
    var node = 0u;
    // After the first step the entry point lies on the plane of the face
    // just left: that coordinate is the plane's own (as in the CPU walk), so
    // a leaf an ulp thick is entered, not stepped over.
    var entry_axis = 3u;
    var entry_plane = 0.0;
    for (var step = 0u; step <= params.leaf_count; step++) {
        var p = o + d * t_enter;
        if entry_axis < 3u {
            p[entry_axis] = entry_plane;
        }
        let leaf_id = locate(node, p, d);
        if test_leaf(leaf_id, o, s, tmin, tmax, skip, any_hit, &best) {
            return best;
        }
        let leaf = leaves[leaf_id];
        var t_exit = bitcast<f32>(0x7f800000u);
        var exit_face = 6u;
        var t_face = vec3<f32>(bitcast<f32>(0x7f800000u));
        for (var a = 0u; a < 3u; a++) {
            var bound: f32;
            var f: u32;
            if d[a] > 0.0 {
                bound = leaf.max[a];
                f = 2u * a + 1u;
            } else if d[a] < 0.0 {
                bound = leaf.min[a];
                f = 2u * a;
            } else {
                continue;
            }
            let t = (bound - o[a]) * inv[a];
            t_face[a] = t;
            if t < t_exit {
                t_exit = t;
                exit_face = f;
            }
        }
        // Leaving through an edge or corner: also test the leaves across the other tied faces.
        if t_exit < t_exit_root {
            for (var a = 0u; a < 3u; a++) {
                let f = 2u * a + select(0u, 1u, d[a] > 0.0);
                if f == exit_face || t_face[a] - t_exit > 1e-6 * abs(t_exit) {
                    continue;
                }
                let rope = leaf.ropes[f];
                if rope != NO_ROPE {
                    var q = o + d * t_exit;
                    q[a] = select(leaf.min[a], leaf.max[a], d[a] > 0.0);
                    let side = locate(rope, q, d);
                    if test_leaf(side, o, s, tmin, tmax, skip, any_hit, &best) {
                        return best;
                    }
                }
            }
        }
        if best.tri != HIT_MISS && best.t <= t_exit {
            return best;
        }
        if t_exit >= t_exit_root || exit_face == 6u {
            return best;
        }
        let rope = leaf.ropes[exit_face];
        if rope == NO_ROPE {
            return best;
        }
        node = rope;
        entry_axis = exit_face / 2u;
        entry_plane = select(leaf.min[entry_axis], leaf.max[entry_axis], exit_face % 2u == 1u);
        t_enter = max(t_enter, t_exit);
    }
    return best;
}
