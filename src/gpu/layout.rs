//! Data shared with the WGSL shaders: `#[repr(C)]` + `bytemuck::Pod`, each
//! mirrored by a WGSL struct of the same name. [`shared_structs`] lists
//! every one with its size and field offsets ([`shared_constants`] the
//! shared constants), and `tests/gpu_layout.rs`
//! parses the shaders with naga and checks them against it.
//!
//! Lengths in metres; `vec3<f32>` fields are followed by a `u32`/`f32` so
//! they fill 16 bytes as WGSL lays them out.

#[cfg(any(test, feature = "internals"))]
use crate::bvh::{Block8, Node8};
#[cfg(any(test, feature = "internals"))]
use crate::kdtree::{KdLeaf, KdNode};
#[cfg(any(test, feature = "internals"))]
use crate::trace::ray::KdTriangle;
#[cfg(any(test, feature = "internals"))]
use crate::links::HitRecord;
use bytemuck::{Pod, Zeroable};
#[cfg(any(test, feature = "internals"))]
use std::mem::{offset_of, size_of};

/// One shooting vertex of a batch: ray origin, the vertex its rays skip,
/// and its frame rotated about the normal (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RayVertex {
    /// Ray origin, metres.
    pub origin: [f32; 3],
    /// The vertex whose triangles the rays skip (triangles with it as a corner are not tested).
    pub skip: u32,
    /// Unit tangent of the frame (rotated about the normal).
    pub tangent: [f32; 3],
    /// Which direction set the vertex shoots ([`crate::sampling::vertex_rotations_and_sets`]).
    pub direction_set: u32,
    /// Unit bitangent of the frame.
    pub bitangent: [f32; 3],
    /// Padding to 16 bytes.
    pub _pad1: u32,
    /// Unit normal of the frame (local z of the directions).
    pub normal: [f32; 3],
    /// Padding to 16 bytes.
    pub _pad2: u32,
}

/// A shadow-ray segment `origin + t dir`, `t` in `[tmin, tmax]` (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadowRay {
    /// Segment origin, metres.
    pub origin: [f32; 3],
    /// The vertex whose triangles the ray skips (triangles with it as a corner are not tested).
    pub skip: u32,
    /// Unit direction.
    pub dir: [f32; 3],
    /// Start of the segment along `dir`, metres.
    pub tmin: f32,
    /// End of the segment along `dir`, metres.
    pub tmax: f32,
    /// Padding.
    pub _pad0: u32,
    /// Padding.
    pub _pad1: u32,
    /// Padding.
    pub _pad2: u32,
}

/// Uniforms of one tracing dispatch (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TraceParams {
    /// Rays (or shadow rays) in the dispatch.
    pub count: u32,
    /// Rays per shooting vertex (the stride from ray id to vertex).
    pub rays_per_vertex: u32,
    /// Workgroups along x of the 2D dispatch.
    pub groups_x: u32,
    /// Leaves of the kd-tree (bounds the steps of a traversal).
    pub leaf_count: u32,
    /// Minimum corner of the kd-tree's root box, metres.
    pub root_min: [f32; 3],
    /// Padding to 16 bytes.
    pub _pad0: u32,
    /// Maximum corner of the kd-tree's root box, metres.
    pub root_max: [f32; 3],
    /// Padding to 16 bytes.
    pub _pad1: u32,
}

/// Uniforms of the gather shader (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GatherUniforms {
    /// Vertices of the dispatch.
    pub vertex_count: u32,
    /// Workgroups along x of the 2D dispatch.
    pub groups_x: u32,
    /// First vertex of the dispatch (a link segment's first row; 0 for `update_bounce`).
    pub first_vertex: u32,
    /// Padding to 16 bytes.
    pub _pad0: u32,
}

/// Per-frame uniforms of the renderer (`shaders/render.wgsl`, 160 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FrameUniforms {
    /// Column-major world-to-clip matrix.
    pub view_proj: [f32; 16],
    /// Camera position, metres.
    pub camera_pos: [f32; 3],
    /// Lights in the light buffer.
    pub light_count: u32,
    /// 0 combined, 1 direct, 2 indirect.
    pub view_mode: u32,
    /// Offset along the normal before shadow lookups, metres.
    pub normal_offset: f32,
    /// One shadow-map texel in uv units.
    pub shadow_texel: f32,
    /// Bias subtracted from the depth before comparing.
    pub depth_bias: f32,
    /// Column-major clip-to-world matrix (the sky pass's view directions).
    pub inv_view_proj: [f32; 16],
}

/// One light of the renderer (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightGpu {
    /// Point: the light's position; directional: the centre of the scene's bounds (metres).
    pub position: [f32; 3],
    /// 0 point, 1 directional.
    pub kind: u32,
    /// Point: intensity W/sr; directional: irradiance W/m^2.
    pub color: [f32; 3],
    /// First shadow layer (six for a point light).
    pub layer: u32,
    /// Directional: unit direction of travel.
    pub direction: [f32; 3],
    /// Padding to 16 bytes.
    pub _pad0: u32,
}

/// One albedo texture of the renderer (`render.wgsl`, 16 bytes): where its
/// texels start in the texel buffer and how it is sampled.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TextureInfo {
    /// Index of its first texel (row by row from the top).
    pub offset: u32,
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    /// Bits 0-1: wrap along u, 2-3: wrap along v (`Wrap::code`); bit 4: nearest.
    pub mode: u32,
}

/// Uniforms of the display pass (`shaders/tonemap.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ToneMapUniforms {
    /// Radiance scale before the ACES curve.
    pub exposure: f32,
    /// 1: the shader applies the sRGB curve; 0: the target format encodes.
    pub encode_srgb: u32,
    /// Padding to 16 bytes.
    pub _pad0: u32,
    /// Padding to 16 bytes.
    pub _pad1: u32,
}

/// A struct shared with WGSL: name, size and `(field, offset)` pairs.
#[cfg(any(test, feature = "internals"))]
pub struct SharedStruct {
    /// The struct's name in Rust and WGSL.
    pub name: &'static str,
    /// Size, bytes.
    pub size: usize,
    /// Each field's name and byte offset, in declaration order.
    pub fields: Vec<(&'static str, usize)>,
}

#[cfg(any(test, feature = "internals"))]
macro_rules! shared {
    ($t:ty, $name:literal, [$($f:ident),*]) => {
        SharedStruct { name: $name, size: size_of::<$t>(), fields: vec![$((stringify!($f), offset_of!($t, $f))),*] }
    };
}

/// Every struct the shaders also declare.
#[cfg(any(test, feature = "internals"))]
pub fn shared_structs() -> Vec<SharedStruct> {
    vec![
        shared!(KdNode, "KdNode", [split, kind, a, b]),
        shared!(Node8, "Node8", [bounds, child, perm]),
        shared!(Block8, "Block8", [v, corners, tri]),
        shared!(KdLeaf, "KdLeaf", [min, first, max, count, ropes, _pad]),
        shared!(KdTriangle, "KdTriangle", [v0, ia, v1, ib, v2, ic]),
        shared!(HitRecord, "HitRecord", [tri, u, v, t]),
        shared!(RayVertex, "RayVertex", [origin, skip, tangent, direction_set, bitangent, _pad1, normal, _pad2]),
        shared!(ShadowRay, "ShadowRay", [origin, skip, dir, tmin, tmax, _pad0, _pad1, _pad2]),
        shared!(
            TraceParams,
            "TraceParams",
            [count, rays_per_vertex, groups_x, leaf_count, root_min, _pad0, root_max, _pad1]
        ),
        shared!(GatherUniforms, "GatherUniforms", [vertex_count, groups_x, first_vertex, _pad0]),
        shared!(
            FrameUniforms,
            "FrameUniforms",
            [view_proj, camera_pos, light_count, view_mode, normal_offset, shadow_texel, depth_bias, inv_view_proj]
        ),
        shared!(LightGpu, "LightGpu", [position, kind, color, layer, direction, _pad0]),
        shared!(ToneMapUniforms, "ToneMapUniforms", [exposure, encode_srgb, _pad0, _pad1]),
        shared!(TextureInfo, "TextureInfo", [offset, width, height, mode]),
    ]
}

/// Constants shared with WGSL: `(shader file, name, value)`, checked by
/// the layout test against the shaders' `const` declarations.
#[cfg(any(test, feature = "internals"))]
pub fn shared_constants() -> Vec<(&'static str, &'static str, u32)> {
    vec![
        ("gather.wgsl", "GAP_BYTES", crate::links::packed::GAP_BYTES_WORD),
        ("gather.wgsl", "WORKGROUP", GATHER_WORKGROUP),
        ("render.wgsl", "NO_MAP", crate::scene::texture::NO_MAP),
        ("walk_bvh.wgsl", "EMPTY", crate::bvh::EMPTY),
        ("walk_bvh.wgsl", "LEAF_BIT", crate::bvh::LEAF_BIT),
        ("walk_bvh.wgsl", "FIRST_MASK", crate::bvh::FIRST_MASK),
        ("walk_bvh.wgsl", "UNUSED", crate::bvh::leaf::UNUSED),
        ("walk_bvh.wgsl", "STACK", BVH_STACK as u32),
        ("trace.wgsl", "HIT_MISS", crate::links::HIT_MISS),
        ("trace.wgsl", "HIT_BACK", crate::links::HIT_BACK),
    ]
}

/// Float constants shared with WGSL, checked like [`shared_constants`].
#[cfg(any(test, feature = "internals"))]
pub fn shared_f32_constants() -> Vec<(&'static str, &'static str, f32)> {
    vec![
        ("render.wgsl", "MAX_ALBEDO", crate::scene::MAX_ALBEDO),
        ("walk_bvh.wgsl", "ROBUST", crate::bvh::traverse::ROBUST),
        ("walk_bvh.wgsl", "CULL", crate::bvh::traverse::CULL),
    ]
}

/// Entries of the BVH walk's stack (`STACK` in `walk_bvh.wgsl`): at most
/// 7 a level, so trees 13 levels deep; the built-in scenes' need 23 to 46
/// (conference, 237k triangles, 7 levels: 45).
pub const BVH_STACK: usize = 96;

/// The WGSL sources, for pipelines and the layout test: the tracers'
/// entry points and triangle test, joined after one structure's walk
/// ([`super::tracer::tracer_wgsl`]).
pub const TRACE_WGSL: &str = include_str!("../../shaders/trace.wgsl");
/// The 8-wide BVH walk.
pub const WALK_BVH_WGSL: &str = include_str!("../../shaders/walk_bvh.wgsl");
/// The rope kd-tree walk.
pub const WALK_KD_WGSL: &str = include_str!("../../shaders/walk_kd.wgsl");
/// The ray-query walk (needs `EXPERIMENTAL_RAY_QUERY`).
pub const WALK_RQ_WGSL: &str = include_str!("../../shaders/walk_rq.wgsl");

/// Invocations per workgroup of the gather shaders (`WORKGROUP` in `gather.wgsl`).
pub const GATHER_WORKGROUP: u32 = 256;

/// The gather shaders' WGSL source.
pub const GATHER_WGSL: &str = include_str!("../../shaders/gather.wgsl");
/// The renderer's WGSL source.
pub const RENDER_WGSL: &str = include_str!("../../shaders/render.wgsl");
/// The display (tone mapping) pass's WGSL source.
#[cfg(any(feature = "viewer", feature = "internals"))]
pub const TONEMAP_WGSL: &str = include_str!("../../shaders/tonemap.wgsl");
