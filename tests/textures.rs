//! Textures (issue 32): OBJ `map_Kd` and glTF emissive textures sampled
//! per vertex (2x2-texel images read back at the vertices, OBJ's v-up
//! convention, corners split where a position's values differ, a missing
//! texture falling back to `Kd`), and albedo drawn per pixel: a checkerboard
//! plane renders as a checkerboard on the GPU and the CPU, which agree.
//! GPU tests run on any adapter (lavapipe in CI); with no adapter they fail
//! when `CI` is set and skip with a message otherwise.

mod common;
#[path = "common/gltf_doc.rs"]
mod gltf_doc;

use glam::{Vec2, Vec3};
use gltf_doc::Doc;
use linkgi::gpu::{self, GpuDevice};
use linkgi::render::{cpu::render_cpu, gpu::GpuRenderer, pixel_ray, Frame, HdrImage, RenderParams};
use linkgi::scene::texture::{srgb_to_linear, CornerTextures, Sampler, Texture, TextureMap, Wrap, NO_MAP};
use linkgi::scene::{self, prep, Camera, Light, SceneDesc};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("linkgi-textures-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(p: &Path) -> SceneDesc {
    scene::load(p.to_str().unwrap()).unwrap_or_else(|e| panic!("{e}"))
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol * a.abs().max(b.abs()).max_element().max(1e-6)
}

/// Writes a PNG of 8-bit sRGB texels, rows from the top.
fn png(path: &Path, w: u32, h: u32, texels: &[[u8; 3]]) {
    image::RgbImage::from_raw(w, h, texels.concat()).unwrap().save(path).unwrap();
}

fn linear(t: [u8; 3]) -> Vec3 {
    Vec3::from(t.map(|c| srgb_to_linear(c as f32 / 255.0)))
}

/// Four distinct texels of a 2x2 image, rows from the top: A B / C D.
const TEXELS: [[u8; 3]; 4] = [[200, 30, 30], [30, 200, 30], [30, 30, 200], [150, 150, 60]];

/// The unit floor quad (normal +y) with the four texels' centres as OBJ
/// coordinates (v up: the top row is at v = 0.75); the second triangle's
/// corner at the first position uses coordinates `vt` (1: the same as the
/// first triangle's).
fn quad_obj(vt: u32) -> String {
    format!(
        "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\n\
         vt 0.25 0.75\nvt 0.75 0.75\nvt 0.75 0.25\nvt 0.25 0.25\n\
         usemtl tex\nf 1/1 2/2 3/3\nf 1/{vt} 3/3 4/4\n"
    )
}

#[test]
fn obj_map_kd_is_kd_times_the_texel_at_each_vertex_with_v_up() {
    let dir = tmpdir("obj");
    png(&dir.join("tex.png"), 2, 2, &TEXELS);
    std::fs::write(dir.join("quad.obj"), quad_obj(2)).unwrap();
    // Options before the file name are skipped.
    std::fs::write(dir.join("quad.mtl"), "newmtl tex\nKd 0.8 0.6 0.9\nmap_Kd -blendu on tex.png\n").unwrap();
    let desc = load(&dir.join("quad.obj"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let kd = Vec3::new(0.8, 0.6, 0.9);
    let mesh = &desc.meshes[0];
    // (position, texel): position 1 carries two texture coordinates, so it is two vertices.
    let want = [(0, 0), (1, 1), (2, 3), (0, 1), (3, 2)];
    let corners = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::NEG_Z];
    assert_eq!(mesh.positions.len(), want.len());
    let albedo = mesh.vertex_albedo.as_ref().expect("per-vertex albedo");
    for (v, &(p, texel)) in want.iter().enumerate() {
        assert_eq!(mesh.positions[v], corners[p]);
        let expect = kd * linear(TEXELS[texel]);
        assert!(close(albedo[v], expect, 1e-6), "vertex {v}: {} vs texel {texel}: {expect}", albedo[v]);
    }
    // Prepared: the triangles' corners at the first position differ, so their shared
    // edge is a seam (6 vertices); with the same coordinates there it is not (4).
    let s = prep::prepare(&desc).unwrap();
    assert_eq!(s.vertex_count(), 6);
    std::fs::write(dir.join("joined.obj"), quad_obj(1)).unwrap();
    assert_eq!(prep::prepare(&load(&dir.join("joined.obj"))).unwrap().vertex_count(), 4);
    for (v, p) in s.positions.iter().enumerate() {
        let texels: Vec<Vec3> =
            want.iter().filter(|&&(q, _)| corners[q] == *p).map(|&(_, t)| kd * linear(TEXELS[t])).collect();
        assert!(texels.iter().any(|t| close(s.albedo[v], *t, 1e-6)), "prepared vertex at {p}: {}", s.albedo[v]);
    }
    let tex = s.textures.as_ref().expect("the prepared scene keeps the texture");
    assert_eq!(tex.triangle_map, vec![0, 0]);
    // Coordinates per corner in the top-left convention: v = 1 - v_obj.
    assert_eq!(tex.uv[1][0], Vec2::new(0.75, 0.25));
    assert_eq!(tex.factor[0][0], kd);
    // The renderer's albedo at a corner is the vertex's.
    for (t, tri) in s.triangles.iter().enumerate() {
        for k in 0..3 {
            let mut b = [0.0; 3];
            b[k] = 1.0;
            let a = tex.albedo(t, b).unwrap();
            assert!(close(a, s.albedo[tri[k] as usize], 1e-6), "triangle {t} corner {k}: {a}");
        }
    }
}

#[test]
fn missing_map_kd_warns_and_falls_back_to_kd() {
    let dir = tmpdir("missing");
    std::fs::write(dir.join("quad.obj"), quad_obj(2)).unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl tex\nKd 0.3 0.4 0.5\nmap_Kd missing.png\n").unwrap();
    let desc = load(&dir.join("quad.obj"));
    let w = desc.warnings.iter().find(|w| w.contains("missing.png")).expect("a warning names the texture");
    assert!(w.contains("quad.mtl") && w.contains("'tex'") && w.contains("Kd"), "{w}");
    assert!(desc.meshes[0].textures.is_none() && desc.meshes[0].vertex_albedo.is_none());
    let s = prep::prepare(&desc).unwrap();
    assert!(s.textures.is_none());
    assert!(s.albedo.iter().all(|a| *a == Vec3::new(0.3, 0.4, 0.5)), "{:?}", s.albedo);
    assert_eq!(s.vertex_count(), 4, "untextured faces keep their positions");
}

/// A glTF quad of two triangles with their own vertices, emissive through
/// `glow.png`: at (0, 0, 0) the first triangle uses texel A and the second
/// `texel_b`; at (1, 0, -1) both use texel D. Returns the file and each
/// vertex's texel.
fn emissive_quad(dir: &Path, name: &str, texel_b: usize) -> (PathBuf, [usize; 6]) {
    let mut d = Doc::new();
    let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::ZERO, Vec3::new(1.0, 0.0, -1.0), Vec3::NEG_Z];
    let texel = [0, 1, 3, texel_b, 3, 2];
    let centre = |t: usize| Vec2::new(0.25 + 0.5 * (t % 2) as f32, 0.25 + 0.5 * (t / 2) as f32);
    let pos = d.floats("VEC3", &p.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>());
    let uvs = d.floats("VEC2", &texel.iter().flat_map(|&t| centre(t).to_array()).collect::<Vec<_>>());
    let idx = d.indices(&[0, 1, 2, 3, 4, 5]);
    let mat = d.material(json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]},
        "emissiveFactor": [1.0, 0.5, 0.25],
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}}}));
    d.json["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    d.json["textures"] = json!([{"source": 0}]);
    d.json["images"] = json!([{"uri": "glow.png"}]);
    let mesh = d.mesh(json!({"attributes": {"POSITION": pos, "TEXCOORD_0": uvs}, "indices": idx, "material": mat}));
    d.node(json!({"mesh": mesh}), true);
    (d.write(dir, name), texel)
}

#[test]
fn gltf_emissive_texture_scales_the_emission_per_vertex() {
    let dir = tmpdir("emissive");
    // Texel D is black: that corner does not glow.
    let texels = [TEXELS[0], TEXELS[1], TEXELS[2], [0, 0, 0]];
    png(&dir.join("glow.png"), 2, 2, &texels);
    let (path, texel) = emissive_quad(&dir, "glow.gltf", 2);
    let desc = load(&path);
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    let m = &desc.meshes[0];
    // The material's exitance: emissiveFactor x strength through one unit conversion (scene::gltf).
    let exitance = m.materials[0].emission;
    let k = exitance / (Vec3::new(1.0, 0.5, 0.25) * 3.0);
    assert!(k.x > 0.0 && close(k, Vec3::splat(k.x), 1e-6), "{exitance}");
    let emission = m.vertex_emission.as_ref().expect("per-vertex emission");
    for v in 0..6 {
        let want = exitance * linear(texels[texel[v]]);
        assert!(close(emission[v], want, 1e-6), "vertex {v}: {} vs {want}", emission[v]);
    }
    assert_eq!(emission[2], Vec3::ZERO);
    // Albedo stays the base colour.
    assert!(m.vertex_albedo.as_ref().unwrap().iter().all(|a| *a == Vec3::splat(0.5)));
    // Prepared: the corners at (0, 0, 0) glow differently, so the shared edge is a
    // seam (6 vertices, two of them at the origin with each emission).
    let s = prep::prepare(&desc).unwrap();
    assert_eq!(s.vertex_count(), 6);
    let at = |q: Vec3| (0..6).filter(|&v| s.positions[v] == q).map(|v| s.emission[v]).collect::<Vec<_>>();
    let origin = at(Vec3::ZERO);
    assert_eq!(origin.len(), 2);
    for want in [exitance * linear(texels[0]), exitance * linear(texels[2])] {
        assert!(origin.iter().any(|e| close(*e, want, 1e-6)), "{origin:?} lacks {want}");
    }
    assert_eq!(at(Vec3::new(1.0, 0.0, -1.0)), vec![Vec3::ZERO; 2]);
    // The same texel at the origin in both triangles: joined (4 vertices).
    let (joined, _) = emissive_quad(&dir, "joined.gltf", 0);
    assert_eq!(prep::prepare(&load(&joined)).unwrap().vertex_count(), 4);
    // A scene file's `emission` for the mesh replaces the texture's.
    std::fs::write(dir.join("glow.toml"), "[[mesh]]\ngltf = \"glow.gltf\"\nemission = [0.5, 0.25, 1.0]\n").unwrap();
    let s = prep::prepare(&load(&dir.join("glow.toml"))).unwrap();
    let uniform = scene::emission::exitance(Vec3::new(0.5, 0.25, 1.0));
    assert!(s.emission.iter().all(|e| *e == uniform), "{:?} vs {uniform}", s.emission);
}

fn device() -> Option<Arc<GpuDevice>> {
    static DEV: OnceLock<Option<Arc<GpuDevice>>> = OnceLock::new();
    DEV.get_or_init(|| {
        let d = gpu::open_all().into_iter().next();
        match &d {
            Some(d) => eprintln!("texture render tests on {}", d.describe()),
            None if std::env::var_os("CI").is_some() => {
                panic!("no graphics adapter in CI: install mesa-vulkan-drivers (lavapipe)")
            }
            None => eprintln!("SKIPPED (GPU part): no graphics adapter"),
        }
        d
    })
    .clone()
}

const SIZE: u32 = 128;
/// Looking straight down at the unit floor quad x in [0, 1], z in [-1, 0].
const CAMERA: Camera = Camera { position: Vec3::new(0.5, 1.6, -0.5), target: Vec3::new(0.5, 0.0, -0.5), fov_deg: 40.0 };
const E_DIRECT: f32 = 3.0;
const E_INDIRECT: f32 = 0.5;

/// Where the primary ray of each pixel meets the plane y = 0 (`None`: outside
/// the quad, or within `margin` of its border).
fn floor_points(margin: f32) -> Vec<Option<Vec3>> {
    let mut out = Vec::new();
    for y in 0..SIZE {
        for x in 0..SIZE {
            let r = pixel_ray(&CAMERA, SIZE, SIZE, 1.5, x, y);
            let p = r.origin + r.dir * (-r.origin.y / r.dir.y);
            let inside = p.x > margin && p.x < 1.0 - margin && p.z < -margin && p.z > -1.0 + margin;
            out.push(inside.then_some(p));
        }
    }
    out
}

/// Renders the prepared floor lit from straight above with `E_INDIRECT` at every vertex, GPU (if any) and CPU.
fn render_floor(s: &prep::PreparedScene) -> (Option<HdrImage>, HdrImage) {
    let e_i = vec![Vec3::splat(E_INDIRECT); s.vertex_count()];
    let lights = [Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::splat(E_DIRECT) }];
    let frame = Frame { lights: &lights, ..Frame::of(s, &e_i, CAMERA) };
    let params = RenderParams { width: SIZE, height: SIZE, shadow_size: 256, ..Default::default() };
    let gpu = device().map(|d| GpuRenderer::new(d).unwrap().render(&frame, &params).unwrap().0);
    let cpu = render_cpu(&frame, &params, None).unwrap().0;
    (gpu, cpu)
}

/// GPU and CPU agree to `tol` of the peak at all but `1 / share` of the
/// pixels that see the quad away from its border (the rasterizer and the
/// primary rays may give a pixel on a shared edge, or at a jump of nearest
/// sampling, to different sides), and on average to a tenth of `tol`.
fn assert_agree(name: &str, gpu: &HdrImage, cpu: &HdrImage, tol: f32, share: usize) {
    let peak = cpu.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
    let diffs: Vec<f32> = floor_points(0.03)
        .iter()
        .enumerate()
        .filter(|(_, p)| p.is_some())
        .map(|(i, _)| (gpu.pixels[i] - cpu.pixels[i]).abs().max_element() / peak)
        .collect();
    let n = diffs.len();
    let off = diffs.iter().filter(|&&d| d > tol).count();
    let mean = diffs.iter().sum::<f32>() / n.max(1) as f32;
    eprintln!("{name}: GPU vs CPU over {n} pixels: {off} differ by more than {tol} of the peak, mean {mean:.5}");
    assert!(n > 1000, "{name}: only {n} pixels see the quad");
    assert!(off * share <= n, "{name}: {off} of {n} pixels differ by more than {tol} of the peak");
    assert!(mean < tol / 10.0, "{name}: mean difference {mean} of the peak");
}

#[test]
fn checkerboard_plane_renders_as_a_checkerboard() {
    let dir = tmpdir("checker");
    let (white, dark) = ([255u8; 3], [40u8; 3]);
    // 8 x 8 cells of 4 x 4 texels: bilinear sampling blends cells only within half a texel of their border.
    let texels: Vec<[u8; 3]> =
        (0..32 * 32u32).map(|i| if ((i % 32) / 4 + (i / 32) / 4).is_multiple_of(2) { white } else { dark }).collect();
    png(&dir.join("checker.png"), 32, 32, &texels);
    let obj = "mtllib c.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl c\nf 1/1 2/2 3/3 4/4\n";
    std::fs::write(dir.join("c.obj"), obj).unwrap();
    std::fs::write(dir.join("c.mtl"), "newmtl c\nKd 0.8 0.8 0.8\nmap_Kd checker.png\n").unwrap();
    let s = prep::prepare(&load(&dir.join("c.obj"))).unwrap();
    let (gpu, cpu) = render_floor(&s);
    // Cell (col, row) of the image: u = x, v = 1 - v_obj = 1 + z.
    let expect = |p: Vec3| {
        let (u, v) = (p.x * 8.0, (1.0 + p.z) * 8.0);
        let centre = (u.fract() - 0.5).abs() < 0.25 && (v.fract() - 0.5).abs() < 0.25;
        let texel = if (u as u32 + v as u32).is_multiple_of(2) { white } else { dark };
        centre.then(|| 0.8 * linear(texel) / std::f32::consts::PI * (E_DIRECT + E_INDIRECT))
    };
    let points = floor_points(0.0);
    for (name, img) in [("cpu", Some(&cpu)), ("gpu", gpu.as_ref())] {
        let Some(img) = img else { continue };
        let (mut bright, mut darkest_bright, mut brightest_dark, mut n) = (0, f32::MAX, 0.0f32, 0);
        for (i, p) in points.iter().enumerate() {
            let Some(want) = p.and_then(expect) else { continue };
            let got = img.pixels[i];
            assert!(close(got, want, 0.02), "{name}: pixel {i} at {}: {got} vs {want}", p.unwrap());
            n += 1;
            if want.x > 0.1 {
                bright += 1;
                darkest_bright = darkest_bright.min(got.x);
            } else {
                brightest_dark = brightest_dark.max(got.x);
            }
        }
        eprintln!("{name}: {n} cell-centre pixels, {bright} bright; darkest bright {darkest_bright}, brightest dark {brightest_dark}");
        assert!(bright > 100 && n - bright > 100, "{name}: {bright} of {n}");
        assert!(darkest_bright > 10.0 * brightest_dark, "{name}: the checker's contrast is lost");
    }
    if let Some(gpu) = &gpu {
        assert_agree("checker", gpu, &cpu, 0.02, 100);
    }
}

/// Every wrap mode and both filters, over coordinates reaching past [0, 1]:
/// the GPU's sampling is the CPU's.
#[test]
fn gpu_samples_textures_as_the_cpu_does() {
    if device().is_none() {
        return;
    }
    let mut b = linkgi::scene::shapes::MeshBuilder::new();
    let m = b.add_material("floor", Vec3::splat(0.5));
    b.quad_grid(Vec3::ZERO, Vec3::X, Vec3::NEG_Z, 4, 4, m);
    let mesh = b.finish("floor", 30.0);
    let desc = common::scene_desc("floor", vec![mesh], vec![], None, 16, scene::Bounces::Fixed(1));
    let mut s = prep::prepare(&desc).unwrap();
    // A 3x2 image of distinct colours.
    let texels: Vec<Vec3> = (0..6).map(|i| Vec3::new(0.1 + 0.15 * i as f32, 0.9 - 0.12 * i as f32, 0.3)).collect();
    let image = Arc::new(Texture::from_linear(3, 2, texels).unwrap());
    let t = s.triangles.len();
    let uv_of = |p: Vec3| Vec2::new(p.x * 4.0 - 1.3, -p.z * 3.0 - 0.9);
    for wrap in [Wrap::ClampToEdge, Wrap::Repeat, Wrap::MirroredRepeat] {
        for nearest in [false, true] {
            let map = TextureMap { image: image.clone(), sampler: Sampler { wrap: [wrap, Wrap::Repeat], nearest } };
            s.textures = Some(Arc::new(CornerTextures {
                maps: vec![map],
                triangle_map: (0..t as u32).map(|i| if i % 7 == 3 { NO_MAP } else { 0 }).collect(),
                uv: s.triangles.iter().map(|tri| tri.map(|v| uv_of(s.positions[v as usize]))).collect(),
                factor: vec![[Vec3::ONE; 3]; t],
            }));
            let (gpu, cpu) = render_floor(&s);
            let name = format!("{wrap:?} nearest={nearest}");
            // Nearest sampling jumps at texel edges.
            assert_agree(&name, gpu.as_ref().unwrap(), &cpu, 0.02, if nearest { 50 } else { 100 });
        }
    }
}
