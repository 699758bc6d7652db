//! Every struct shared with WGSL has the same size and field offsets in
//! Rust and in the shaders (parsed with naga). No GPU needed.

use linkgi::gpu::layout::{
    shared_constants, shared_f32_constants, shared_structs, GATHER_WGSL, RENDER_WGSL, TONEMAP_WGSL,
};
use linkgi::gpu::tracer::tracer_wgsl;
use linkgi::gpu::GpuWalk;

/// Every tracer's whole source (its walk joined with `trace.wgsl`), by the walk's file name.
fn tracers() -> Vec<(&'static str, String)> {
    vec![
        ("walk_bvh.wgsl", tracer_wgsl(GpuWalk::Bvh)),
        ("walk_kd.wgsl", tracer_wgsl(GpuWalk::Kd)),
        ("walk_rq.wgsl", tracer_wgsl(GpuWalk::RayQuery)),
    ]
}
use std::collections::HashMap;

/// `name -> (size, [(field, offset)])` of every struct in a WGSL source.
fn wgsl_structs(src: &str, file: &str) -> HashMap<String, (usize, Vec<(String, usize)>)> {
    let module = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{file}: {}", e.emit_to_string(src)));
    let mut out = HashMap::new();
    for (_, ty) in module.types.iter() {
        if let (Some(name), naga::TypeInner::Struct { members, span }) = (&ty.name, &ty.inner) {
            let fields = members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize)).collect();
            out.insert(name.clone(), (*span as usize, fields));
        }
    }
    out
}

#[test]
fn shared_structs_match_wgsl() {
    let mut shaders: Vec<_> = tracers().into_iter().map(|(f, src)| (f, wgsl_structs(&src, f))).collect();
    shaders.extend([
        ("gather.wgsl", wgsl_structs(GATHER_WGSL, "gather.wgsl")),
        ("render.wgsl", wgsl_structs(RENDER_WGSL, "render.wgsl")),
        ("tonemap.wgsl", wgsl_structs(TONEMAP_WGSL, "tonemap.wgsl")),
    ]);
    for s in shared_structs() {
        let mut seen = 0;
        for (file, structs) in &shaders {
            let Some((size, fields)) = structs.get(s.name) else { continue };
            seen += 1;
            assert_eq!(*size, s.size, "{file}: {} is {size} bytes in WGSL, {} in Rust", s.name, s.size);
            let rust: Vec<(String, usize)> = s.fields.iter().map(|(n, o)| (n.to_string(), *o)).collect();
            assert_eq!(fields, &rust, "{file}: {} fields/offsets differ", s.name);
        }
        assert!(seen > 0, "{} is declared in no shader", s.name);
    }
}

#[test]
fn every_wgsl_struct_outside_the_shader_is_listed() {
    // Structs only the shaders use internally.
    // (The renderer uploads LightArray and ShadowMatrices as arrays of
    // LightGpu and column-major 4x4 matrices; VsOut and SkyOut are stage-internal.)
    // RayDesc and RayIntersection are naga's predeclared ray-query types.
    let internal =
        ["Shear", "Best", "VsOut", "SkyOut", "LightArray", "ShadowMatrices", "RowCursor", "RayDesc", "RayIntersection"];
    let listed: Vec<&str> = shared_structs().iter().map(|s| s.name).collect();
    let mut sources: Vec<String> = tracers().into_iter().map(|(_, s)| s).collect();
    sources.extend([GATHER_WGSL, RENDER_WGSL, TONEMAP_WGSL].map(String::from));
    for src in &sources {
        for name in wgsl_structs(src, "shader").keys() {
            assert!(listed.contains(&name.as_str()) || internal.contains(&name.as_str()), "{name} has no Rust twin");
        }
    }
}

/// The initializer of `const name` in the shader `file`.
fn wgsl_constant(file: &str, name: &str) -> naga::Literal {
    let src = match file {
        "gather.wgsl" => GATHER_WGSL.to_string(),
        "render.wgsl" => RENDER_WGSL.to_string(),
        // Constants of trace.wgsl are checked in the BVH tracer's source.
        "trace.wgsl" | "walk_bvh.wgsl" => tracer_wgsl(GpuWalk::Bvh),
        "walk_kd.wgsl" => tracer_wgsl(GpuWalk::Kd),
        other => panic!("no shader {other}"),
    };
    let src = src.as_str();
    let module = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{file}: {}", e.emit_to_string(src)));
    let (_, c) = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("{file} declares no const {name}"));
    match module.global_expressions[c.init] {
        naga::Expression::Literal(l) => l,
        ref e => panic!("{file}: {name} is {e:?}, not a literal"),
    }
}

/// Every shared constant has its Rust value in its shader.
#[test]
fn shared_constants_match_wgsl() {
    for (file, name, value) in shared_constants() {
        match wgsl_constant(file, name) {
            naga::Literal::U32(v) => assert_eq!(v, value, "{file}: {name}"),
            l => panic!("{file}: {name} is {l:?}, not a u32 literal"),
        }
    }
    for (file, name, value) in shared_f32_constants() {
        match wgsl_constant(file, name) {
            naga::Literal::F32(v) => assert_eq!(v, value, "{file}: {name}"),
            l => panic!("{file}: {name} is {l:?}, not an f32 literal"),
        }
    }
}
