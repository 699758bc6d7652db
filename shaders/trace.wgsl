// Entry points of every GPU tracer (docs/DESIGN.md §1b, §5). This file is
// joined after one walk (`walk_bvh.wgsl`, `walk_kd.wgsl`, `walk_rq.wgsl`),
// which declares its structure's bindings in group 0 (from binding 1) and
//     fn trace(o, d, tmin, tmax, skip, any_hit) -> Best
// the nearest hit (front or back face, equal `t` ordered by triangle id) on
// the segment [tmin, tmax], ignoring triangles with vertex `skip` as a
// corner; with `any_hit` any hit, as soon as one is found.
//
// `shoot_rays`: one invocation per ray; ray `k` of batch vertex `i` is
// invocation `i * rays + k`, and the direction table is in 4x4-block order,
// so a workgroup of 64 traces four coherent blocks of one vertex.
// `closest_hits`: one invocation per ray of an arbitrary batch.
// `light_visibility`: one invocation per ray, any hit.
//
// The triangle test mirrors `src/kdtree/triangle.rs` (watertight, Woop et
// al. 2013) without its f64 fallback for edge functions that are exactly
// zero (WGSL has no portable f64). Distances in metres.

const NO_SKIP: u32 = 0xffffffffu;
const HIT_MISS: u32 = 0xffffffffu;
const HIT_BACK: u32 = 0x80000000u;
const WORKGROUP: u32 = 64u;

// A triangle's corners and corner vertex ids (the kd-tree's and the
// ray-query walk's copy, by triangle id).
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

// One ray of `closest_hits` or `light_visibility`: the segment [tmin, tmax].
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
    // Rays in this dispatch.
    count: u32,
    rays_per_vertex: u32,
    // Workgroups along x of the 2D dispatch.
    groups_x: u32,
    // The kd-tree's leaves (bounds its walk); unused by the other walks.
    leaf_count: u32,
    root_min: vec3<f32>,
    _pad0: u32,
    root_max: vec3<f32>,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;

// shoot_rays: local directions (xyz, w unused), one set of rays_per_vertex
// after the other.
@group(1) @binding(0) var<storage, read> directions: array<vec4<f32>>;
// shoot_rays: RayVertex per batch vertex.
@group(1) @binding(1) var<storage, read> ray_vertices: array<RayVertex>;
// closest_hits, light_visibility: the rays.
@group(1) @binding(2) var<storage, read> rays: array<ShadowRay>;
// shoot_rays, closest_hits: one HitRecord per ray.
@group(1) @binding(3) var<storage, read_write> hits: array<HitRecord>;
// light_visibility: 1 where the segment is free, 0 where blocked.
@group(1) @binding(4) var<storage, read_write> visible: array<u32>;

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

fn no_hit() -> Best {
    return Best(HIT_MISS, 0.0, 0.0, 0.0, false);
}

fn closer(t: f32, tri: u32, best: Best) -> bool {
    return best.tri == HIT_MISS || t < best.t || (t == best.t && tri < best.tri);
}

// Watertight test of triangle `id` with corners v0, v1, v2; on a hit in
// [tmin, tmax] that is closer than `best`, updates `best` and returns true.
fn hit_triangle(id: u32, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, o: vec3<f32>, s: Shear, tmin: f32, tmax: f32,
                best: ptr<function, Best>) -> bool {
    let a = v0 - o;
    let b = v1 - o;
    let c = v2 - o;
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

fn invocation(gid: vec3<u32>) -> u32 {
    return gid.x + gid.y * params.groups_x * WORKGROUP;
}

fn record(best: Best) -> HitRecord {
    if best.tri == HIT_MISS {
        return HitRecord(HIT_MISS, 0.0, 0.0, bitcast<f32>(0x7f800000u));
    }
    return HitRecord(select(best.tri | HIT_BACK, best.tri, best.front), best.u, best.v, best.t);
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
    hits[id] = record(trace(rv.origin, dir, 0.0, 3.0e38, rv.skip, false));
}

@compute @workgroup_size(64)
fn closest_hits(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = invocation(gid);
    if id >= params.count {
        return;
    }
    let r = rays[id];
    hits[id] = record(trace(r.origin, r.dir, r.tmin, r.tmax, r.skip, false));
}

@compute @workgroup_size(64)
fn light_visibility(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = invocation(gid);
    if id >= params.count {
        return;
    }
    let r = rays[id];
    let best = trace(r.origin, r.dir, r.tmin, r.tmax, r.skip, true);
    visible[id] = select(0u, 1u, best.tri == HIT_MISS);
}
