// The 8-wide BVH walk (docs/DESIGN.md §1b, §5), joined before `trace.wgsl`,
// which holds the entry points and the triangle test.
//
// The same tree as the CPU's (`src/bvh`): `Node8` and `Block8` are uploaded
// as they are, so a refit on the CPU is a copy. The walk mirrors the CPU's
// portable build (`src/bvh/traverse.rs`) step by step: the eight slabs of a
// node with near and far planes picked by the direction's signs,
//     t_near = max(t_min, (near - o) / d),
//     t_far = min(t_best * CULL, (far - o) / d) * ROBUST,
// children entered in the order the build stored for the ray's octant, the
// nearest taken next and the others pushed with their entry distances; a
// popped child whose entry lies beyond the best hit (times CULL) is skipped.
// Leaves test blocks of eight triangles lane by lane. Empty slots and
// unused lanes are skipped by their ids (a GPU may not keep infinities or
// NaN as the CPU's inverted boxes and NaN corners rely on).
//
// The stack holds `STACK` entries; the tracer refuses a tree whose walk
// could push more (`stack_need` in `src/gpu/tracer.rs`). Distances in metres.

const EMPTY: u32 = 0xffffffffu;
const LEAF_BIT: u32 = 0x80000000u;
const FIRST_MASK: u32 = 0x07ffffffu;
const UNUSED: u32 = 0xffffffffu;
const STACK: u32 = 96u;
// 1 + 2 gamma_3 (pbrt): far distances scaled so rounding never culls a touched box.
const ROBUST: f32 = 1.0000003576278687;
// Margin on the best hit's distance, so a box holding a tie is entered.
const CULL: f32 = 1.0000100135803223;

struct Node8 {
    bounds: array<array<f32, 8>, 6>,
    child: array<u32, 8>,
    perm: array<u32, 8>,
}

struct Block8 {
    v: array<array<array<f32, 8>, 3>, 3>,
    corners: array<array<u32, 8>, 3>,
    tri: array<u32, 8>,
}

@group(0) @binding(1) var<storage, read> bvh_nodes: array<Node8>;
@group(0) @binding(2) var<storage, read> bvh_blocks: array<Block8>;

fn is_leaf(c: u32) -> bool {
    return (c & LEAF_BIT) != 0u && c != EMPTY;
}

fn corner(b: u32, c: u32, lane: u32) -> vec3<f32> {
    return vec3<f32>(bvh_blocks[b].v[c][0][lane], bvh_blocks[b].v[c][1][lane], bvh_blocks[b].v[c][2][lane]);
}

// Tests a leaf's blocks; returns true if `any_hit` and something was hit.
fn test_blocks(leaf: u32, o: vec3<f32>, s: Shear, tmin: f32, tmax_ray: f32, skip: u32, any_hit: bool,
               best: ptr<function, Best>) -> bool {
    let first = leaf & FIRST_MASK;
    let count = ((leaf >> 27u) & 0xfu) + 1u;
    for (var b = first; b < first + count; b++) {
        for (var lane = 0u; lane < 8u; lane++) {
            let id = bvh_blocks[b].tri[lane];
            if id == UNUSED {
                continue;
            }
            if bvh_blocks[b].corners[0][lane] == skip || bvh_blocks[b].corners[1][lane] == skip
                || bvh_blocks[b].corners[2][lane] == skip {
                continue;
            }
            var tmax = tmax_ray;
            if (*best).tri != HIT_MISS {
                tmax = (*best).t;
            }
            if hit_triangle(id, corner(b, 0u, lane), corner(b, 1u, lane), corner(b, 2u, lane), o, s, tmin, tmax, best)
                && any_hit {
                return true;
            }
        }
    }
    return false;
}

fn trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, skip: u32, any_hit: bool) -> Best {
    var best = no_hit();
    if !(tmin <= tmax) || arrayLength(&bvh_nodes) == 0u {
        return best;
    }
    var inv: vec3<f32>;
    var near: vec3<u32>;
    var far: vec3<u32>;
    var octant = 0u;
    for (var a = 0u; a < 3u; a++) {
        var da = d[a];
        if abs(da) < 1e-30 {
            // 1e-30 with the sign of d[a] (copysign).
            da = bitcast<f32>((bitcast<u32>(da) & 0x80000000u) | bitcast<u32>(1e-30));
        }
        inv[a] = 1.0 / da;
        if inv[a] >= 0.0 {
            near[a] = a;
            far[a] = a + 3u;
        } else {
            near[a] = a + 3u;
            far[a] = a;
            octant |= 1u << a;
        }
    }
    let shift = 3u * octant;
    let s = make_shear(d);
    var stack_child: array<u32, STACK>;
    var stack_t: array<f32, STACK>;
    var sp = 0u;
    var cur = 0u;
    var tbest = tmax;
    loop {
        var descend = false;
        if is_leaf(cur) {
            if test_blocks(cur, o, s, tmin, tmax, skip, any_hit, &best) {
                return best;
            }
            if best.tri != HIT_MISS {
                tbest = best.t;
            }
        } else {
            let limit = tbest * CULL;
            var last = EMPTY;
            var last_t = 0.0;
            for (var i = 0u; i < 8u; i++) {
                let slot = (bvh_nodes[cur].perm[i] >> shift) & 7u;
                let c = bvh_nodes[cur].child[slot];
                if c == EMPTY {
                    continue;
                }
                // The slab distances of this slot, axis by axis as on the CPU.
                var tn = tmin;
                var tf = limit;
                for (var a = 0u; a < 3u; a++) {
                    tn = max(tn, (bvh_nodes[cur].bounds[near[a]][slot] - o[a]) * inv[a]);
                    tf = min(tf, (bvh_nodes[cur].bounds[far[a]][slot] - o[a]) * inv[a]);
                }
                if tn <= tf * ROBUST {
                    if last != EMPTY && sp < STACK {
                        stack_child[sp] = last;
                        stack_t[sp] = last_t;
                        sp += 1u;
                    }
                    last = c;
                    last_t = tn;
                }
            }
            if last != EMPTY {
                cur = last;
                descend = true;
            }
        }
        if !descend {
            // Pop the nearest pending child that can still hold a nearer hit.
            var found = false;
            while sp > 0u {
                sp -= 1u;
                if stack_t[sp] <= tbest * CULL {
                    cur = stack_child[sp];
                    found = true;
                    break;
                }
            }
            if !found {
                return best;
            }
        }
    }
    return best;
}
