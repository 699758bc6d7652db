// Ray shooting over the flattened rope kd-tree (docs/DESIGN.md §1, §5).
//
// `shoot_rays`: one invocation per ray; ray `k` of batch vertex `i` is
// invocation `i * rays + k`, and the direction table is in 4x4-block order,
// so a workgroup of 64 traces four coherent blocks of one vertex.
// `light_visibility`: one invocation per shadow ray, any hit.
//
// The traversal mirrors `src/kdtree/traverse.rs` (`walk_ropes`) step by
// step, and the triangle test mirrors `src/kdtree/triangle.rs` (watertight,
// Woop et al. 2013) without its f64 fallback for edge functions that are
// exactly zero (WGSL has no portable f64). Distances in metres.

const LEAF: u32 = 3u;
const NO_ROPE: u32 = 0xffffffffu;
const NO_SKIP: u32 = 0xffffffffu;
const HIT_MISS: u32 = 0xffffffffu;
const HIT_BACK: u32 = 0x80000000u;
const WORKGROUP: u32 = 64u;

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

struct KdTriangle {
    v0: vec3<f32>,
    ia: u32,
    v1: vec3<f32>,
    ib: u32,
    v2: vec3<f32>,
    ic: u32,
}

struct HitRecord {
    tri: u32,
    u: f32,
    v: f32,
    t: f32,
}

// One shooting vertex: origin, the vertex id its rays skip, and its rotated frame.
struct RayVertex {
    origin: vec3<f32>,
    skip: u32,
    tangent: vec3<f32>,
    // Which direction set the vertex shoots (sets follow one another in `directions`).
    direction_set: u32,
    bitangent: vec3<f32>,
    _pad1: u32,
    normal: vec3<f32>,
    _pad2: u32,
}

struct ShadowRay {
    origin: vec3<f32>,
    skip: u32,
    dir: vec3<f32>,
    tmin: f32,
    tmax: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct TraceParams {
    // Rays (or shadow rays) in this dispatch.
    count: u32,
    rays_per_vertex: u32,
    // Workgroups along x of the 2D dispatch.
    groups_x: u32,
    leaf_count: u32,
    root_min: vec3<f32>,
    _pad0: u32,
    root_max: vec3<f32>,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var<storage, read> nodes: array<KdNode>;
@group(0) @binding(2) var<storage, read> leaves: array<KdLeaf>;
@group(0) @binding(3) var<storage, read> leaf_triangles: array<u32>;
@group(0) @binding(4) var<storage, read> triangles: array<KdTriangle>;
// shoot_rays: local directions (xyz, w unused), one set of rays_per_vertex
// after the other. light_visibility: unused.
@group(0) @binding(5) var<storage, read> directions: array<vec4<f32>>;
// shoot_rays: RayVertex per batch vertex.
@group(0) @binding(6) var<storage, read> ray_vertices: array<RayVertex>;
// shoot_rays: one HitRecord per ray.
@group(0) @binding(7) var<storage, read_write> hits: array<HitRecord>;

@group(1) @binding(0) var<storage, read> shadow_rays: array<ShadowRay>;
// 1: the segment is free, 0: blocked.
@group(1) @binding(1) var<storage, read_write> visible: array<u32>;

struct Shear {
    kx: u32,
    ky: u32,
    kz: u32,
    sx: f32,
    sy: f32,
    sz: f32,
}

fn make_shear(d: vec3<f32>) -> Shear {
    let ad = abs(d);
    // Ties go to the lower axis, as glam's max_position.
    var kz = 0u;
    var m = ad.x;
    if ad.y > m { kz = 1u; m = ad.y; }
    if ad.z > m { kz = 2u; }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    return Shear(kx, ky, kz, d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
}

struct Best {
    tri: u32,
    u: f32,
    v: f32,
    t: f32,
    front: bool,
}

fn closer(t: f32, tri: u32, best: Best) -> bool {
    return best.tri == HIT_MISS || t < best.t || (t == best.t && tri < best.tri);
}

// Watertight test; on a hit in [tmin, tmax] updates `best` if closer and returns true.
fn intersect(id: u32, o: vec3<f32>, s: Shear, tmin: f32, tmax: f32, best: ptr<function, Best>) -> bool {
    let tri = triangles[id];
    let a = tri.v0 - o;
    let b = tri.v1 - o;
    let c = tri.v2 - o;
    let ax = a[s.kx] - s.sx * a[s.kz];
    let ay = a[s.ky] - s.sy * a[s.kz];
    let bx = b[s.kx] - s.sx * b[s.kz];
    let by = b[s.ky] - s.sy * b[s.kz];
    let cx = c[s.kx] - s.sx * c[s.kz];
    let cy = c[s.ky] - s.sy * c[s.kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return false;
    }
    let det = u + v + w;
    if det == 0.0 {
        return false;
    }
    let t_scaled = s.sz * (u * a[s.kz] + v * b[s.kz] + w * c[s.kz]);
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t >= tmin && t <= tmax) {
        return false;
    }
    if closer(t, id, *best) {
        *best = Best(id, v * inv, w * inv, t, det > 0.0);
        return true;
    }
    return false;
}

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
        if intersect(id, o, s, tmin, tmax, best) && any_hit {
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
    var best = Best(HIT_MISS, 0.0, 0.0, 0.0, false);
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

fn invocation(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * params.groups_x * WORKGROUP;
}

@compute @workgroup_size(64)
fn shoot_rays(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = invocation(gid);
    if id >= params.count {
        return;
    }
    let rv = ray_vertices[id / params.rays_per_vertex];
    let l = directions[rv.direction_set * params.rays_per_vertex + id % params.rays_per_vertex].xyz;
    let w = rv.tangent * l.x + rv.bitangent * l.y + rv.normal * l.z;
    let dir = w * (1.0 / sqrt(dot(w, w)));
    let best = trace(rv.origin, dir, 0.0, 3.0e38, rv.skip, false);
    if best.tri == HIT_MISS {
        hits[id] = HitRecord(HIT_MISS, 0.0, 0.0, bitcast<f32>(0x7f800000u));
    } else {
        hits[id] = HitRecord(select(best.tri | HIT_BACK, best.tri, best.front), best.u, best.v, best.t);
    }
}

@compute @workgroup_size(64)
fn light_visibility(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = invocation(gid);
    if id >= params.count {
        return;
    }
    let r = shadow_rays[id];
    let best = trace(r.origin, r.dir, r.tmin, r.tmax, r.skip, true);
    visible[id] = select(0u, 1u, best.tri == HIT_MISS);
}
