// Rasterized display of a solved scene (src/render/gpu.rs).
//
// Outgoing radiance per pixel, W/(m^2 sr):
//   L = rho / pi * (E_d(pixel) + E_sky + E_i) + M_e / pi
// with E_sky, E_i and the emitted radiance M_e / pi interpolated from the
// vertices; pixels that see nothing show the sky (sky_vs / sky_fs).
// E_d: sum over lights of I cos / r^2 (point) or E cos (directional), times
// the shadow-map visibility (3x3 percentage-closer filtering, each tap a
// hardware 2x2 comparison). Point lights use six 2D layers (one per cube
// face, picked by the major axis of the light-to-point vector); directional
// lights one layer each. Back faces are black (surfaces are one-sided).
// rho is interpolated from the vertices, or on a textured triangle (map !=
// NO_MAP) the albedo texture at the pixel times the interpolated factor,
// clamped to [0, MAX_ALBEDO] (src/render/textures.rs; sample_texture is
// the copy of scene::texture::TextureMap::sample).
// The HDR target holds linear L; exposure and tone mapping run on read-back.

const PI: f32 = 3.14159265358979323846264338327950288;
const MAX_LIGHTS: u32 = 8u;
const MAX_SHADOW_LAYERS: u32 = 56u;
// Untextured triangle (scene::texture::NO_MAP).
const NO_MAP: u32 = 4294967295u;
// Largest albedo (scene::MAX_ALBEDO).
const MAX_ALBEDO: f32 = 0.999;

// radiosity-begin: the radiosity of a Lambertian surface, rho/pi E + M/pi,
// W/(m^2 sr): `exchange::bounce::operator::radiosity`, which tests/gpu.rs
// checks this copy against.
fn lambert_radiosity(rho: vec3<f32>, e: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return e * rho / PI + m / PI;
}
// radiosity-end

struct FrameUniforms {
    view_proj: mat4x4<f32>,
    camera_pos: vec3<f32>,
    light_count: u32,
    // 0 combined, 1 direct, 2 indirect.
    view_mode: u32,
    // World-space offset along the normal before shadow lookups, metres.
    normal_offset: f32,
    // Size of one shadow-map texel in uv units.
    shadow_texel: f32,
    // Depth-space bias subtracted before comparing.
    depth_bias: f32,
    // Clip-to-world matrix: the sky pass's view directions.
    inv_view_proj: mat4x4<f32>,
}

struct LightGpu {
    position: vec3<f32>,
    // 0 point, 1 directional.
    kind: u32,
    color: vec3<f32>,
    // First shadow layer (point lights use six).
    layer: u32,
    direction: vec3<f32>,
    _pad0: u32,
}

struct ShadowMatrices {
    m: array<mat4x4<f32>, MAX_SHADOW_LAYERS>,
}

struct LightArray {
    l: array<LightGpu, MAX_LIGHTS>,
}

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var<uniform> lights: LightArray;
@group(0) @binding(2) var<uniform> shadow: ShadowMatrices;
@group(0) @binding(3) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(4) var shadow_sampler: sampler_comparison;
// The sky as an equirectangular radiance image (src/sky/envmap.rs layout:
// u = atan2(x, -z) / 2 pi, the azimuth from -z clockwise seen from above,
// toward +x first; v = polar angle from +y over pi).
@group(0) @binding(5) var sky_map: texture_2d<f32>;
@group(0) @binding(6) var sky_sampler: sampler;

// One albedo texture: first texel in `texels`, size, and mode (bits 0-1
// wrap along u, 2-3 along v: 0 clamp to edge, 1 repeat, 2 mirrored repeat;
// bit 4 nearest, else bilinear).
struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    mode: u32,
}

// Linear RGB texels, rows from the top: (pack2x16float(r, g), pack2x16float(b, 0)).
@group(0) @binding(7) var<storage, read> texels: array<vec2<u32>>;
@group(0) @binding(8) var<storage, read> maps: array<TextureInfo>;

fn wrap_index(i: i32, n: i32, mode: u32) -> i32 {
    if mode == 0u {
        return clamp(i, 0, n - 1);
    }
    if mode == 1u {
        return ((i % n) + n) % n;
    }
    let m = ((i % (2 * n)) + 2 * n) % (2 * n);
    return select(2 * n - 1 - m, m, m < n);
}

fn fetch_texel(t: TextureInfo, x: i32, y: i32) -> vec3<f32> {
    let w = i32(t.width);
    let xi = wrap_index(x, w, t.mode & 3u);
    let yi = wrap_index(y, i32(t.height), (t.mode >> 2u) & 3u);
    let p = texels[t.offset + u32(yi * w + xi)];
    return vec3<f32>(unpack2x16float(p.x), unpack2x16float(p.y).x);
}

fn lerp3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return a + (b - a) * t;
}

// Texel centres at half-integers; nearest rounds half away from zero.
fn sample_texture(index: u32, uv: vec2<f32>) -> vec3<f32> {
    let t = maps[index];
    let p = clamp(uv * vec2<f32>(f32(t.width), f32(t.height)) - 0.5, vec2<f32>(-1e9), vec2<f32>(1e9));
    if (t.mode & 16u) != 0u {
        let r = select(ceil(p - 0.5), floor(p + 0.5), p >= vec2<f32>(0.0));
        return fetch_texel(t, i32(r.x), i32(r.y));
    }
    let f = floor(p);
    let w = p - f;
    let x = i32(f.x);
    let y = i32(f.y);
    let top = lerp3(fetch_texel(t, x, y), fetch_texel(t, x + 1, y), w.x);
    let bottom = lerp3(fetch_texel(t, x, y + 1), fetch_texel(t, x + 1, y + 1), w.x);
    return lerp3(top, bottom, w.y);
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) e_indirect: vec3<f32>,
    @location(4) e_sky: vec3<f32>,
    @location(5) emitted: vec3<f32>,
    @location(6) uv: vec2<f32>,
    @location(7) @interpolate(flat) map: u32,
}

@vertex
fn vs_main(
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) albedo: vec3<f32>,
    @location(3) e_indirect: vec3<f32>,
    @location(4) e_sky: vec3<f32>,
    @location(5) emitted: vec3<f32>,
    @location(6) uv: vec2<f32>,
    @location(7) map: u32,
) -> VsOut {
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.normal = normal;
    out.albedo = albedo;
    out.e_indirect = e_indirect;
    out.e_sky = e_sky;
    out.emitted = emitted;
    out.uv = uv;
    out.map = map;
    return out;
}

// Depth-only pass into one shadow layer; the instance index selects the matrix.
@vertex
fn shadow_vs(@location(0) position: vec3<f32>, @builtin(instance_index) layer: u32) -> @builtin(position) vec4<f32> {
    return shadow.m[layer] * vec4<f32>(position, 1.0);
}

fn pcf(layer: u32, p: vec3<f32>) -> f32 {
    let clip = shadow.m[layer] * vec4<f32>(p, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || ndc.z > 1.0 {
        return 1.0;
    }
    let depth = ndc.z - frame.depth_bias;
    var sum = 0.0;
    for (var y = -1; y <= 1; y++) {
        for (var x = -1; x <= 1; x++) {
            let o = vec2<f32>(f32(x), f32(y)) * frame.shadow_texel;
            sum += textureSampleCompareLevel(shadow_maps, shadow_sampler, uv + o, i32(layer), depth);
        }
    }
    return sum / 9.0;
}

fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1u, 0u, d.x > 0.0);
    }
    if a.y >= a.z {
        return select(3u, 2u, d.y > 0.0);
    }
    return select(5u, 4u, d.z > 0.0);
}

@fragment
fn fs_main(in: VsOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    if !front {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let n = normalize(in.normal);
    let p = in.world + n * frame.normal_offset;
    var e_d = vec3<f32>(0.0);
    for (var i = 0u; i < frame.light_count; i++) {
        let l = lights.l[i];
        if l.kind == 0u {
            let d = l.position - in.world;
            let r2 = max(dot(d, d), 1e-8);
            let c = dot(n, d) / sqrt(r2);
            if c <= 0.0 {
                continue;
            }
            let vis = pcf(l.layer + cube_face(p - l.position), p);
            e_d += l.color * (c / r2) * vis;
        } else {
            let c = dot(n, -l.direction);
            if c <= 0.0 {
                continue;
            }
            let vis = pcf(l.layer, p);
            e_d += l.color * c * vis;
        }
    }
    let none = vec3<f32>(0.0);
    var rho = in.albedo;
    if in.map != NO_MAP {
        rho = clamp(in.albedo * sample_texture(in.map, in.uv), none, vec3<f32>(MAX_ALBEDO));
    }
    var l = lambert_radiosity(rho, e_d + in.e_sky + in.e_indirect, none) + in.emitted;
    if frame.view_mode == 1u {
        l = lambert_radiosity(rho, e_d + in.e_sky, none) + in.emitted;
    } else if frame.view_mode == 2u {
        l = lambert_radiosity(rho, in.e_indirect, none);
    }
    return vec4<f32>(l, 1.0);
}

// Sky pass: one triangle over the screen at the far plane, drawn before the
// mesh without depth; each pixel shows the sky radiance along its view ray
// (black in the indirect view).
struct SkyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

@vertex
fn sky_vs(@builtin(vertex_index) i: u32) -> SkyOut {
    let xy = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0;
    var out: SkyOut;
    out.clip = vec4<f32>(xy, 1.0, 1.0);
    out.ndc = xy;
    return out;
}

@fragment
fn sky_fs(in: SkyOut) -> @location(0) vec4<f32> {
    if frame.view_mode == 2u {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let far = frame.inv_view_proj * vec4<f32>(in.ndc, 1.0, 1.0);
    let d = normalize(far.xyz / far.w - frame.camera_pos);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    var phi = atan2(d.x, -d.z);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let uv = vec2<f32>(phi / (2.0 * PI), theta / PI);
    return vec4<f32>(textureSampleLevel(sky_map, sky_sampler, uv, 0.0).rgb, 1.0);
}
