//! glTF 2.0 import (`scene::gltf`) and export (`scene::gltf_write`): the same
//! scene as OBJ+TOML and as glTF solves the same; node transforms, textures,
//! vertex colours and light units come through; `.glb` equals `.gltf`; bad
//! files get errors naming the file and the problem.

mod common;
#[path = "common/gltf_doc.rs"]
mod gltf_doc;

use glam::{Vec2, Vec3};
use gltf_doc::Doc;
use linkgi::scene::{self, gltf_write, prep, Backend, Bounces, Light, SceneDesc, TracerKind, MAX_ALBEDO};
use serde_json::json;
use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("linkgi-gltf-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(p: &Path) -> SceneDesc {
    scene::load(p.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(p: &Path) -> String {
    let msg = scene::load(p.to_str().unwrap()).expect_err("should fail").to_string();
    eprintln!("{msg}");
    msg
}

/// `a` and `b` agree to `tol` relative to the larger, with an absolute floor.
fn close(a: Vec3, b: Vec3, tol: f32, floor: f32) -> bool {
    (a - b).abs().max_element() <= tol * a.abs().max(b.abs()).max_element() + floor
}

fn repo_scene(name: &str) -> SceneDesc {
    load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name))
}

fn solve_settings(mut d: SceneDesc) -> SceneDesc {
    d = common::with_settings(d, 16, Bounces::Fixed(3), 30.0);
    d.settings.seed = 7;
    d.settings.backend = Backend::Cpu;
    d.settings.tracer = TracerKind::Bvh;
    d
}

fn light_close(a: &Light, b: &Light) -> bool {
    match (*a, *b) {
        (Light::Point { position: p, intensity: i }, Light::Point { position: q, intensity: j }) => {
            close(p, q, 1e-6, 1e-6) && close(i, j, 1e-6, 0.0)
        }
        (Light::Directional { direction: d, irradiance: i }, Light::Directional { direction: e, irradiance: j }) => {
            close(d, e, 1e-6, 1e-6) && close(i, j, 1e-6, 0.0)
        }
        _ => false,
    }
}

#[test]
fn obj_toml_and_gltf_solve_the_same() {
    let dir = tmpdir("same");
    let from_obj = repo_scene("cornell.toml");
    let path = dir.join("cornell.gltf");
    gltf_write::write_gltf(&from_obj, &path).unwrap();
    let from_gltf = load(&path);
    assert!(from_gltf.warnings.is_empty(), "{:?}", from_gltf.warnings);
    assert_eq!(from_gltf.meshes.len(), from_obj.meshes.len());
    assert_eq!(from_gltf.lights.len(), from_obj.lights.len());
    for (a, b) in from_obj.lights.iter().zip(&from_gltf.lights) {
        assert!(light_close(a, b), "{a:?} vs {b:?}");
    }
    let (ca, cb) = (from_obj.camera.unwrap(), from_gltf.camera.unwrap());
    assert!(close(ca.position, cb.position, 1e-6, 1e-6));
    let dir_of = |c: scene::Camera| (c.target - c.position).normalize();
    assert!(close(dir_of(ca), dir_of(cb), 1e-5, 1e-6), "{ca:?} vs {cb:?}");
    assert!((ca.fov_deg - cb.fov_deg).abs() < 1e-4);

    let (a, b) = (solve_settings(from_obj), solve_settings(from_gltf));
    let (pa, pb) = (prep::prepare(&a).unwrap(), prep::prepare(&b).unwrap());
    assert_eq!(pa.vertex_count(), pb.vertex_count());
    assert_eq!(pa.triangles, pb.triangles);
    for v in 0..pa.vertex_count() {
        assert!(close(pa.positions[v], pb.positions[v], 1e-5, 1e-6), "vertex {v}");
        assert!(close(pa.albedo[v], pb.albedo[v], 1e-5, 0.0), "albedo {v}: {} vs {}", pa.albedo[v], pb.albedo[v]);
    }
    let (_, sa) = common::solve(&a);
    let (_, sb) = common::solve(&b);
    eprintln!("{} vertices, mean E_i {}", pa.vertex_count(), common::mean(&sa.e_indirect));
    assert!(common::mean(&sa.e_indirect).min_element() > 0.0);
    let floor = 1e-6 * common::mean(&sa.e_direct).max_element();
    for v in 0..pa.vertex_count() {
        assert!(close(sa.e_direct[v], sb.e_direct[v], 1e-5, floor), "E_d {v}");
        assert!(
            close(sa.e_indirect[v], sb.e_indirect[v], 1e-5, floor),
            "E_i {v}: {} vs {}",
            sa.e_indirect[v],
            sb.e_indirect[v]
        );
    }
}

/// One triangle (0,0,0), (1,0,0), (0,1,0) with a grey material; returns (doc, mesh index).
fn triangle_doc() -> (Doc, usize) {
    let mut d = Doc::new();
    let pos = d.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    let idx = d.indices(&[0, 1, 2]);
    let mat = d.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}));
    let mesh = d.mesh(json!({"attributes": {"POSITION": pos}, "indices": idx, "material": mat}));
    (d, mesh)
}

#[test]
fn node_hierarchy_bakes_transforms() {
    let dir = tmpdir("nodes");
    let (mut d, mesh) = triangle_doc();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // Parent: scale 2, then 90 degrees about +y, then translate (1, 2, 3).
    // Child: mirror z, then translate (0, 1, 0); a mirror reverses the winding.
    let child = d.node(json!({"name": "child", "mesh": mesh, "translation": [0, 1, 0], "scale": [1, 1, -1]}), false);
    d.node(
        json!({"name": "parent", "children": [child], "translation": [1, 2, 3], "rotation": [0, h, 0, h], "scale": [2, 2, 2]}),
        true,
    );
    // A root with a matrix (column-major): translation (5, 0, 0).
    let m = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 5, 0, 0, 1];
    d.node(json!({"name": "moved", "mesh": mesh, "matrix": m}), true);
    let desc = load(&d.write(&dir, "nodes.gltf"));
    assert_eq!(desc.meshes.len(), 2);
    let by_hand = |p: Vec3| {
        let c = Vec3::new(p.x, p.y + 1.0, -p.z);
        let s = 2.0 * c;
        Vec3::new(s.z, s.y, -s.x) + Vec3::new(1.0, 2.0, 3.0)
    };
    let local = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let child_mesh = &desc.meshes[0];
    assert!(child_mesh.name.ends_with("#child"), "{}", child_mesh.name);
    for (p, q) in local.iter().zip(&child_mesh.positions) {
        assert!(close(by_hand(*p), *q, 1e-6, 1e-6), "{} vs {q}", by_hand(*p));
    }
    assert_eq!(child_mesh.triangles, vec![[0, 2, 1]], "mirrored node keeps its front face");
    let moved = &desc.meshes[1];
    assert!(moved.name.ends_with("#moved"));
    for (p, q) in local.iter().zip(&moved.positions) {
        assert_eq!(*p + Vec3::new(5.0, 0.0, 0.0), *q);
    }
    assert_eq!(moved.triangles, vec![[0, 1, 2]]);
    // The mirrored child still faces where its untransformed normal (+z) goes: mirror to -z, rotate to -x.
    let s = prep::prepare(&desc).unwrap();
    let n = s.normals[s.meshes[0].vertices.start as usize];
    assert!(close(n, Vec3::NEG_X, 1e-5, 1e-6), "{n}");
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[test]
fn textured_albedo_is_factor_times_texel_times_colour() {
    let dir = tmpdir("texture");
    let texels: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [188, 128, 64]];
    image::RgbImage::from_raw(2, 2, texels.concat()).unwrap().save(dir.join("tex.png")).unwrap();
    let mut d = Doc::new();
    let pos = d.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0]);
    // Texel centres of the 2x2 image (row 0 at v = 0).
    let uv = [Vec2::new(0.25, 0.25), Vec2::new(0.75, 0.25), Vec2::new(0.25, 0.75), Vec2::new(0.75, 0.75)];
    let uvs = d.floats("VEC2", &uv.iter().flat_map(|u| u.to_array()).collect::<Vec<_>>());
    let colour = [Vec3::ONE, Vec3::splat(0.5), Vec3::ONE, Vec3::ONE];
    let colours = d.floats("VEC3", &colour.iter().flat_map(|c| c.to_array()).collect::<Vec<_>>());
    let idx = d.indices(&[0, 2, 1, 1, 2, 3]);
    let factor = Vec3::new(0.5, 0.8, 1.0);
    let mat = d.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [factor.x, factor.y, factor.z, 1.0], "baseColorTexture": {"index": 0}}}));
    d.json["textures"] = json!([{"source": 0}]);
    d.json["images"] = json!([{"uri": "tex.png"}]);
    let mesh = d.mesh(json!({"attributes": {"POSITION": pos, "TEXCOORD_0": uvs, "COLOR_0": colours}, "indices": idx, "material": mat}));
    d.node(json!({"mesh": mesh}), true);
    let desc = load(&d.write(&dir, "tex.gltf"));
    let expect: Vec<Vec3> = (0..4)
        .map(|v| (factor * Vec3::from(texels[v].map(srgb_to_linear)) * colour[v]).min(Vec3::splat(MAX_ALBEDO)))
        .collect();
    let got = desc.meshes[0].vertex_albedo.as_ref().expect("per-vertex albedo");
    for v in 0..4 {
        assert!(close(got[v], expect[v], 1e-5, 1e-7), "vertex {v}: {} vs {}", got[v], expect[v]);
    }
    // The blue texel times factor 1.0 reaches 1: clamped, with a warning.
    assert_eq!(got[2].z, MAX_ALBEDO);
    assert!(desc.warnings.iter().any(|w| w.contains("clamped")), "{:?}", desc.warnings);
    // Prepared vertices carry the same albedo (4 vertices: none split).
    let s = prep::prepare(&desc).unwrap();
    assert_eq!(s.vertex_count(), 4);
    for (p, a) in s.positions.iter().zip(&s.albedo) {
        let v = desc.meshes[0].positions.iter().position(|q| q == p).unwrap();
        assert!(close(*a, expect[v], 1e-5, 1e-7), "prepared vertex at {p}: {a} vs {}", expect[v]);
    }
}

#[test]
fn lights_and_camera_convert_units() {
    let dir = tmpdir("lights");
    let (mut d, mesh) = triangle_doc();
    d.node(json!({"mesh": mesh}), true);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 683.0, "range": 10.0},
        {"type": "directional", "intensity": 1366.0},
        {"type": "spot", "intensity": 68.3, "spot": {"outerConeAngle": 0.5}},
    ]}});
    for (l, node) in [
        json!({"translation": [0, 2, 0]}),
        json!({"rotation": [-h, 0, 0, h]}), // -90 degrees about x: -z turns to -y
        json!({"translation": [1, 1, 1]}),
    ]
    .into_iter()
    .enumerate()
    {
        let mut node = node;
        node["extensions"] = json!({"KHR_lights_punctual": {"light": l}});
        d.node(node, true);
    }
    d.json["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
    d.node(json!({"camera": 0, "translation": [0, 0.5, 5]}), true);
    let desc = load(&d.write(&dir, "lights.gltf"));
    let expect = [
        Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::new(1.0, 0.5, 0.25) },
        Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::splat(2.0) },
        Light::Point { position: Vec3::ONE, intensity: Vec3::splat(0.1) },
    ];
    assert_eq!(desc.lights.len(), 3);
    for (a, b) in desc.lights.iter().zip(&expect) {
        assert!(light_close(a, b), "{a:?} vs {b:?}");
    }
    assert!(desc.warnings.iter().any(|w| w.contains("spot")), "{:?}", desc.warnings);
    assert!(desc.warnings.iter().any(|w| w.contains("range")), "{:?}", desc.warnings);
    let c = desc.camera.expect("the file has a camera");
    assert_eq!(c.position, Vec3::new(0.0, 0.5, 5.0));
    assert!(close((c.target - c.position).normalize(), Vec3::NEG_Z, 1e-6, 1e-6));
    assert!((c.fov_deg - 0.8f32.to_degrees()).abs() < 1e-4);
}

#[test]
fn glb_loads_like_gltf() {
    let dir = tmpdir("glb");
    let mut original = repo_scene("cornell.toml");
    original.lights.push(Light::Directional {
        direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
        irradiance: Vec3::new(0.5, 0.25, 0.0),
    });
    let (text, binary) = (dir.join("c.gltf"), dir.join("c.glb"));
    gltf_write::write_gltf(&original, &text).unwrap();
    gltf_write::write_gltf(&original, &binary).unwrap();
    assert!(std::fs::read(&binary).unwrap().starts_with(b"glTF"));
    let (a, b) = (load(&text), load(&binary));
    assert_eq!(a.meshes.len(), b.meshes.len());
    for (m, n) in a.meshes.iter().zip(&b.meshes) {
        assert_eq!(m.positions, n.positions);
        assert_eq!(m.triangles, n.triangles);
        assert_eq!(m.triangle_material, n.triangle_material);
        assert_eq!(m.materials, n.materials);
    }
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.camera, b.camera);
    for (x, y) in original.lights.iter().zip(&b.lights) {
        assert!(light_close(x, y), "{x:?} vs {y:?}");
    }
}

#[test]
fn toml_mesh_may_name_a_gltf() {
    let dir = tmpdir("toml");
    let (mut d, mesh) = triangle_doc();
    d.node(json!({"mesh": mesh}), true);
    d.json["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
    d.node(json!({"camera": 0}), true);
    d.write(&dir, "tri.glb");
    let light = "[[light]]\nkind = \"point\"\nposition = [0, 1, 1]\nintensity = [1, 1, 1]\n";
    let toml =
        format!("[[mesh]]\ngltf = \"tri.glb\"\ndynamic = true\n[mesh.transform]\ntranslate = [0, 1, 0]\n{light}");
    std::fs::write(dir.join("s.toml"), toml).unwrap();
    let desc = load(&dir.join("s.toml"));
    assert_eq!(desc.meshes.len(), 1);
    assert!(desc.meshes[0].dynamic);
    assert_eq!(desc.lights.len(), 1);
    assert!(desc.warnings.iter().any(|w| w.contains("ignored")), "{:?}", desc.warnings);
    let s = prep::prepare(&desc).unwrap();
    assert!(s.positions.contains(&Vec3::new(1.0, 1.0, 0.0)), "{:?}", s.positions);
    // Both keys, or neither, is an error naming the scene file.
    std::fs::write(dir.join("both.toml"), format!("[[mesh]]\ngltf = \"tri.glb\"\nobj = \"x.obj\"\n{light}")).unwrap();
    let msg = load_err(&dir.join("both.toml"));
    assert!(msg.contains("both.toml") && msg.contains("exactly one"), "{msg}");
    // A bad glTF behind a scene file is named.
    std::fs::write(dir.join("bad.glb"), b"glTF\x02\0\0\0\x08\0\0\0").unwrap();
    std::fs::write(dir.join("bad.toml"), format!("[[mesh]]\ngltf = \"bad.glb\"\n{light}")).unwrap();
    let msg = load_err(&dir.join("bad.toml"));
    assert!(msg.contains("bad.glb"), "{msg}");
}

#[test]
fn malformed_gltf_files_name_the_file_and_the_problem() {
    let dir = tmpdir("bad");
    let case = |name: &str, edit: &dyn Fn(&mut Doc, usize)| -> String {
        let (mut d, mesh) = triangle_doc();
        d.node(json!({"mesh": mesh}), true);
        edit(&mut d, mesh);
        let msg = load_err(&d.write(&dir, name));
        assert!(msg.contains(name), "{name}: {msg}");
        msg
    };
    // Missing buffer file.
    let (mut d, mesh) = triangle_doc();
    d.node(json!({"mesh": mesh}), true);
    let p = d.write(&dir, "nobin.gltf");
    std::fs::remove_file(dir.join("nobin.bin")).unwrap();
    let msg = load_err(&p);
    assert!(msg.contains("nobin.gltf") && msg.contains("buffer 0") && msg.contains("nobin.bin"), "{msg}");
    // Index out of range.
    let msg = case("index.gltf", &|d, _| {
        let o = d.offset_of(1) + 8;
        d.bin[o..o + 4].copy_from_slice(&7u32.to_le_bytes());
    });
    assert!(msg.contains("out of range") && msg.contains('7'), "{msg}");
    // Accessor index out of range in the JSON.
    let msg = case("accessor.gltf", &|d, m| d.json["meshes"][m]["primitives"][0]["indices"] = json!(9));
    assert!(msg.contains("indices"), "{msg}");
    // Not triangles.
    let msg = case("lines.gltf", &|d, m| d.json["meshes"][m]["primitives"][0]["mode"] = json!(1));
    assert!(msg.contains("Lines") && msg.contains("not a triangle mode"), "{msg}");
    // NaN position.
    let msg = case("nan.gltf", &|d, _| {
        let o = d.offset_of(0) + 4 * 4;
        d.bin[o..o + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    });
    assert!(msg.contains("vertex 1") && msg.contains("not finite"), "{msg}");
    // An accessor reaching past its buffer view.
    let msg = case("short.gltf", &|d, _| d.json["accessors"][0]["count"] = json!(4));
    assert!(msg.contains("reaches past"), "{msg}");
    // A camera whose type names a projection it lacks (the gltf crate would unwrap it).
    let msg = case("camera.gltf", &|d, _| {
        d.json["cameras"] =
            json!([{"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 9, "znear": 0.1}}]);
        d.node(json!({"camera": 0}), true);
    });
    assert!(msg.contains("camera 0"), "{msg}");
    // A directional light turned by a quaternion so large its direction overflows.
    let msg = case("sun.gltf", &|d, _| {
        d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "directional"}]}});
        d.node(
            json!({"rotation": [4294967295.0, 0.3, 0, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
            true,
        );
    });
    assert!(msg.contains("light 0") && msg.contains("direction"), "{msg}");
    // An image without a source.
    let msg = case("image.gltf", &|d, _| d.json["images"] = json!([{"name": "nothing"}]));
    assert!(msg.contains("image 0"), "{msg}");
    // A node that is its own child.
    let msg = case("cycle.gltf", &|d, _| d.json["nodes"][0]["children"] = json!([0]));
    assert!(msg.contains("reached twice"), "{msg}");
    // Not glTF at all, as JSON and as binary.
    std::fs::write(dir.join("text.gltf"), "solid cube\nfacet normal 0 0 1\n").unwrap();
    let msg = load_err(&dir.join("text.gltf"));
    assert!(msg.contains("text.gltf") && msg.contains("not a glTF"), "{msg}");
    std::fs::write(dir.join("short.glb"), b"glTF\x02\0\0\0\xff\xff\0\0JSON").unwrap();
    let msg = load_err(&dir.join("short.glb"));
    assert!(msg.contains("short.glb") && msg.contains("GLB header"), "{msg}");
}

/// Emitters survive the glTF writer and reader: exitance above and below
/// pi W/m^2 (factor alone, and factor times KHR_materials_emissive_strength).
#[test]
fn emission_round_trips_through_gltf() {
    let dir = tmpdir("emission");
    let mut original = repo_scene("window.toml");
    original.sky = None;
    let lamp = original.meshes.iter().position(|m| m.name.contains("window_1")).expect("the lamp mesh");
    original.meshes[lamp].materials[0].emission = Vec3::new(1.0, 0.5, 0.0);
    for ext in ["gltf", "glb"] {
        let path = dir.join(format!("w.{ext}"));
        gltf_write::write_gltf(&original, &path).unwrap();
        let back = load(&path);
        let emits: Vec<Vec3> = back.meshes.iter().flat_map(|m| m.materials.iter().map(|x| x.emission)).collect();
        let want: Vec<Vec3> = original.meshes.iter().flat_map(|m| m.materials.iter().map(|x| x.emission)).collect();
        assert_eq!(emits.len(), want.len());
        for (a, b) in emits.iter().zip(&want) {
            assert!(close(*a, *b, 1e-6, 1e-6), "{ext}: emission {a} vs {b}");
        }
        assert!(want.iter().any(|e| e.max_element() > std::f32::consts::PI), "strength > 1 is exercised");
        assert!(want.iter().any(|e| e.max_element() > 0.0 && e.max_element() < std::f32::consts::PI));
    }
}
