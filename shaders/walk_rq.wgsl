enable wgpu_ray_query;

// The ray-query walk (docs/DESIGN.md §5, `src/gpu/rayquery.rs`), joined
// before `trace.wgsl`, which holds the entry points and the triangle test.
//
// The driver's traversal proposes candidate triangles (none is opaque); each
// is decided by the watertight test of the other tracers on the shader's own
// copy of its corners, skipping triangles with the ray's `skip` vertex as a
// corner. An accepted, closer candidate is confirmed, which lets the driver
// cull what lies beyond it; any-hit queries stop at the first accepted one.
// The driver's segment is widened by `SLACK` on both ends so its rounding
// never drops a candidate the watertight test would take; its start moves
// back along the ray by `SLACK` of the origin's magnitude too, so a
// triangle through the origin (t = 0, which the watertight test takes) is
// still proposed (a driver's t may round below 0, and its tmin cannot be
// negative). Distances in metres.

// Relative widening of the driver's [tmin, tmax].
const SLACK: f32 = 1e-5;

@group(0) @binding(1) var scene_tlas: acceleration_structure;
@group(0) @binding(2) var<storage, read> rq_triangles: array<KdTriangle>;

fn trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, skip: u32, any_hit: bool) -> Best {
    var best = no_hit();
    if !(tmin <= tmax) {
        return best;
    }
    let s = make_shear(d);
    var rq: ray_query;
    let ao = abs(o);
    let back = SLACK * max(max(ao.x, ao.y), max(ao.z, 1.0));
    let lo = max(tmin - SLACK * abs(tmin), 0.0);
    let hi = min(tmax + SLACK * abs(tmax) + 2.0 * back, 3.0e38);
    rayQueryInitialize(&rq, scene_tlas, RayDesc(RAY_FLAG_FORCE_NO_OPAQUE, 0xffu, lo, hi, o - back * d, d));
    while rayQueryProceed(&rq) {
        let c = rayQueryGetCandidateIntersection(&rq);
        if c.kind != RAY_QUERY_INTERSECTION_TRIANGLE {
            continue;
        }
        let id = c.primitive_index;
        let tri = rq_triangles[id];
        if tri.ia == skip || tri.ib == skip || tri.ic == skip {
            continue;
        }
        var t_end = tmax;
        if best.tri != HIT_MISS {
            t_end = best.t;
        }
        if hit_triangle(id, tri.v0, tri.v1, tri.v2, o, s, tmin, t_end, &best) {
            if any_hit {
                rayQueryTerminate(&rq);
                return best;
            }
            rayQueryConfirmIntersection(&rq);
        }
    }
    return best;
}
