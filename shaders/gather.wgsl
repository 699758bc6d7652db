// One bounce of light exchange over the CSR link matrix (docs/DESIGN.md §4):
// `gather_bounce`: E^(b)[v] = sum_j w_vj * B[target_j] (RGB, W/m^2), one
// invocation per vertex, links summed in stored order as on the CPU.
// `update_bounce`: E_i += E^(b); B = rho * E^(b) / pi; per-workgroup sums of
// E^(b) for the bounce totals (the CPU adds the partials in f64).
// Weights are IEEE half floats packed two per u32 (link j in the low half
// of word j/2 when j is even).

const WORKGROUP: u32 = 256u;
const PI: f32 = 3.14159265358979323846264338327950288;

// One dispatch covers vertices first_vertex .. first_vertex + vertex_count.
// `gather_bounce` runs once per link segment (a row range whose links fit
// one storage binding); its offsets, targets and weights are that
// segment's, offsets rebased to the segment's first link.
struct GatherUniforms {
    vertex_count: u32,
    groups_x: u32,
    first_vertex: u32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> params: GatherUniforms;
@group(0) @binding(1) var<storage, read> offsets: array<u32>;
@group(0) @binding(2) var<storage, read> targets: array<u32>;
@group(0) @binding(3) var<storage, read> weights: array<u32>;
// Outgoing radiosity B = rho/pi * E of the previous bounce (xyz).
@group(0) @binding(4) var<storage, read_write> radiosity: array<vec4<f32>>;
// Irradiance of the newest bounce.
@group(0) @binding(5) var<storage, read_write> bounce: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> albedo: array<vec4<f32>>;
// Running indirect irradiance E_i.
@group(0) @binding(7) var<storage, read_write> total: array<vec4<f32>>;
// Sum of `bounce` over each workgroup's vertices.
@group(0) @binding(8) var<storage, read_write> partials: array<vec4<f32>>;

var<workgroup> sums: array<vec4<f32>, WORKGROUP>;

fn weight(j: u32) -> f32 {
    let pair = unpack2x16float(weights[j / 2u]);
    return select(pair.y, pair.x, (j & 1u) == 0u);
}

@compute @workgroup_size(256)
fn gather_bounce(@builtin(global_invocation_id) gid: vec3<u32>) {
    let local = gid.x + gid.y * params.groups_x * WORKGROUP;
    if local >= params.vertex_count {
        return;
    }
    var acc = vec3<f32>(0.0);
    for (var j = offsets[local]; j < offsets[local + 1u]; j++) {
        acc += radiosity[targets[j]].xyz * weight(j);
    }
    bounce[params.first_vertex + local] = vec4<f32>(acc, 0.0);
}

@compute @workgroup_size(256)
fn update_bounce(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32,
                 @builtin(workgroup_id) wid: vec3<u32>) {
    let v = gid.x + gid.y * params.groups_x * WORKGROUP;
    var e = vec4<f32>(0.0);
    if v < params.vertex_count {
        e = bounce[v];
        total[v] += e;
        radiosity[v] = vec4<f32>(e.xyz * albedo[v].xyz / PI, 0.0);
    }
    sums[lid] = e;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride /= 2u) {
        if lid < stride {
            sums[lid] += sums[lid + stride];
        }
        workgroupBarrier();
    }
    if lid == 0u {
        partials[wid.x + wid.y * params.groups_x] = sums[0];
    }
}
