// Display pass (src/render/present.rs): the HDR target's linear radiance,
// W/(m^2 sr), to display colour, drawn as one full-screen triangle.
//
//   c = ACES(L * exposure)            Narkowicz 2015 fit, clamped to [0, 1]
//   c = sRGB(c)                       only when the target is not an *Srgb
//                                     format (those encode on store)
//
// The same formulas as `render::tone_map` on the CPU, which is its oracle.

struct ToneMapUniforms {
    // Radiance scale before the curve.
    exposure: f32,
    // 1: apply the sRGB transfer curve in the shader; 0: the target encodes.
    encode_srgb: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: ToneMapUniforms;
@group(0) @binding(1) var hdr: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (-1,-1), (3,-1), (-1,3): one triangle covering the viewport.
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn aces(x: vec3<f32>) -> vec3<f32> {
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    return clamp((x * (a * x + b)) / (x * (c * x + d) + e), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb(x: vec3<f32>) -> vec3<f32> {
    let lo = 12.92 * x;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

@fragment
fn fs_tonemap(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let l = textureLoad(hdr, vec2<i32>(pos.xy), 0).rgb;
    var c = aces(max(l * params.exposure, vec3<f32>(0.0)));
    if params.encode_srgb == 1u {
        c = srgb(c);
    }
    return vec4<f32>(c, 1.0);
}
