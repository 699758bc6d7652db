// One bounce of light exchange over the CSR link matrix (docs/DESIGN.md §4):
// `gather_bounce`: E^(b)[v] = sum_j w_vj * B[target_j] (RGB, W/m^2), one
// invocation per vertex, links summed in stored order as on the CPU.
// `update_bounce`: E_i += E^(b); B = rho * E^(b) / pi; per-workgroup sums of
// E^(b) for the bounce totals (the CPU adds the partials in f64).
// `reconstruct_radiosity`: B~[c] = B[c] + sum_n K_cn (B[n] - B[c]), clamped
// to B's range over the row (src/exchange/reconstruct.rs), before every
// bounce after the first when the correction is on.
// Links are compact (src/links/packed.rs): weights are IEEE half floats
// packed two per u32 (link j in the low half of word j/2 when j is even);
// targets are gaps in a byte stream: a row is the control bytes of its
// blocks of four links (two bits a link: code k means GAP_BYTES byte k
// data bytes), then the blocks' gaps, little-endian; target = previous
// target + 1 + gap, starting from previous = 0xffffffff. The stream is
// read as little-endian u32 words, padded with 16 zero bytes.

const WORKGROUP: u32 = 256u;
// Byte k: data bytes of a gap of code k (`links::packed::CODE_BYTES`).
const GAP_BYTES: u32 = 0x04020100u;
const PI: f32 = 3.14159265358979323846264338327950288;

// radiosity-begin: the radiosity of a Lambertian surface, rho/pi E + M/pi,
// W/(m^2 sr): `exchange::bounce::operator::radiosity`, which tests/gpu.rs
// checks this copy against.
fn lambert_radiosity(rho: vec3<f32>, e: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return e * rho / PI + m / PI;
}
// radiosity-end

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
@group(0) @binding(2) var<storage, read> link_stream: array<u32>;
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
// Byte offset of each row's first block in `link_stream` (segment-relative).
@group(0) @binding(9) var<storage, read> row_starts: array<u32>;
// `decode_targets`: every link's target, at its link index (segment-relative).
@group(0) @binding(10) var<storage, read_write> decoded: array<u32>;
// `reconstruct_radiosity` (src/exchange/reconstruct.rs): the corrected
// radiosity it writes (what `gather_bounce` then reads as `radiosity`),
// and its CSR rows of (neighbour, weight bits) pairs.
@group(0) @binding(11) var<storage, read_write> corrected: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> recon_offsets: array<u32>;
@group(0) @binding(13) var<storage, read> recon_entries: array<vec2<u32>>;

var<workgroup> sums: array<vec4<f32>, WORKGROUP>;

fn weight(j: u32) -> f32 {
    let pair = unpack2x16float(weights[j / 2u]);
    return select(pair.y, pair.x, (j & 1u) == 0u);
}

// The `len` (0 to 4) little-endian bytes at byte `i` of the stream.
fn stream_bytes(i: u32, len: u32) -> u32 {
    let shift = (i & 3u) * 8u;
    // (A shift by 32 is a shift by 0 in WGSL: select instead.)
    let hi = select(link_stream[(i >> 2u) + 1u] << (32u - shift), 0u, shift == 0u);
    let x = (link_stream[i >> 2u] >> shift) | hi;
    return select(x & ((1u << (len * 8u)) - 1u), x, len == 4u);
}

// One row's decoder: the next control byte, the next data byte and the
// previous target.
struct RowCursor {
    ctl: u32,
    data: u32,
    prev: u32,
}

// The decoder at the start of a row of `count` links starting at byte `start`.
fn row_cursor(start: u32, count: u32) -> RowCursor {
    return RowCursor(start, start + (count + 3u) / 4u, 0xffffffffu);
}

// The next block's control byte (and steps past it).
fn block_control(c: ptr<function, RowCursor>) -> u32 {
    let ctl = stream_bytes((*c).ctl, 1u);
    (*c).ctl += 1u;
    return ctl;
}

// Lane `lane`'s target of a block with control byte `ctl` (lanes in order).
fn next_target(c: ptr<function, RowCursor>, ctl: u32, lane: u32) -> u32 {
    let len = (GAP_BYTES >> (8u * ((ctl >> (2u * lane)) & 3u))) & 0xffu;
    (*c).prev += 1u + stream_bytes((*c).data, len);
    (*c).data += len;
    return (*c).prev;
}

// Summed as on the CPU: link 4i + l into partial sum l, then pairwise.
@compute @workgroup_size(256)
fn gather_bounce(@builtin(global_invocation_id) gid: vec3<u32>) {
    let local = gid.x + gid.y * params.groups_x * WORKGROUP;
    if local >= params.vertex_count {
        return;
    }
    var acc = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    let j0 = offsets[local];
    let count = offsets[local + 1u] - j0;
    var c = row_cursor(row_starts[local], count);
    for (var k = 0u; k < count; k += 4u) {
        let ctl = block_control(&c);
        for (var l = 0u; l < min(4u, count - k); l++) {
            let t = next_target(&c, ctl, l);
            acc[l] += radiosity[t].xyz * weight(j0 + k + l);
        }
    }
    bounce[params.first_vertex + local] = vec4<f32>((acc[0] + acc[1]) + (acc[2] + acc[3]), 0.0);
}

// Writes every link's decoded target (tests: the WGSL decoder against the CPU's).
@compute @workgroup_size(256)
fn decode_targets(@builtin(global_invocation_id) gid: vec3<u32>) {
    let local = gid.x + gid.y * params.groups_x * WORKGROUP;
    if local >= params.vertex_count {
        return;
    }
    let j0 = offsets[local];
    let count = offsets[local + 1u] - j0;
    var c = row_cursor(row_starts[local], count);
    for (var k = 0u; k < count; k += 4u) {
        let ctl = block_control(&c);
        for (var l = 0u; l < min(4u, count - k); l++) {
            decoded[j0 + k + l] = next_target(&c, ctl, l);
        }
    }
}

@compute @workgroup_size(256)
fn update_bounce(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32,
                 @builtin(workgroup_id) wid: vec3<u32>) {
    let v = gid.x + gid.y * params.groups_x * WORKGROUP;
    var e = vec4<f32>(0.0);
    if v < params.vertex_count {
        e = bounce[v];
        total[v] += e;
        radiosity[v] = vec4<f32>(lambert_radiosity(albedo[v].xyz, e.xyz, vec3<f32>(0.0)), 0.0);
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

// Same operations in the same order as `Reconstruction::at` on the CPU.
@compute @workgroup_size(256)
fn reconstruct_radiosity(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x + gid.y * params.groups_x * WORKGROUP;
    if c >= params.vertex_count {
        return;
    }
    let bc = radiosity[c];
    var acc = bc;
    var lo = bc;
    var hi = bc;
    for (var j = recon_offsets[c]; j < recon_offsets[c + 1u]; j++) {
        let e = recon_entries[j];
        let bn = radiosity[e.x];
        acc += (bn - bc) * bitcast<f32>(e.y);
        lo = min(lo, bn);
        hi = max(hi, bn);
    }
    corrected[c] = min(max(acc, lo), hi);
}
