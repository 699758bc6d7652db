//! Loaders survive any input: random mutations of valid scene files (TOML,
//! OBJ, MTL from `scenes/`, glTF/GLB with their buffers and a PNG
//! texture written here, and scenes with a `[sky]` image in OpenEXR and
//! Radiance HDR) are loaded through `scene::load` and, when they
//! load, prepared with `prep::prepare`. No input may panic, and every error
//! must name a file (the scene's name for an empty scene).
//!
//! Mutations, one to three per input: a number replaced by nan, inf, huge,
//! negative or odd values (in binary files: a 4-byte word overwritten with
//! such bit patterns), truncation, a bit flipped or a byte replaced, a line
//! (a slice, in binary files) duplicated or dropped, a token inserted. The
//! RNG is seeded (`Pcg32`), so a failure is reproducible; failing inputs are
//! kept in the temporary directory and named in the report.
//!
//! `cargo test` runs a short pass; the `#[ignore]`d test runs 100,000 inputs
//! (`cargo test --release --test fuzz_loaders -- --ignored`).

#[path = "common/gltf_doc.rs"]
mod gltf_doc;

use glam::Vec3;
use linkgi::scene::{self, gltf_write, prep, Light};
use linkgi::Error;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;
use serde_json::json;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

/// A file of the corpus: its name, pristine bytes, and the files to load
/// (entries) that read it.
struct Target {
    name: &'static str,
    bytes: Vec<u8>,
    binary: bool,
    entries: &'static [&'static str],
}

/// Writes the pristine corpus into `dir` and returns the targets.
fn corpus(dir: &Path) -> Vec<Target> {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let repo = |name: &str| std::fs::read(scenes.join(name)).unwrap();
    // cornell.toml, its big room mesh swapped for the small lamp shade, plus a
    // deforming glTF mesh.
    let toml = String::from_utf8(repo("cornell.toml")).unwrap().replace("cornell_0.obj", "colorlamp_2.obj")
        + "\n[[mesh]]\ngltf = \"small.gltf\"\ndynamic = true\n[[mesh.deform]]\nkind = \"twist\"\namount = 30.0\n";
    // A small glTF from a built-in room with lights.
    let mut room = scene::builtin::closed_room(2, 0.6);
    room.lights = vec![
        Light::Point { position: Vec3::new(0.1, 1.5, 0.2), intensity: Vec3::new(1.0, 0.8, 0.6) },
        Light::Directional { direction: Vec3::new(0.2, -1.0, 0.1).normalize(), irradiance: Vec3::splat(0.5) },
    ];
    gltf_write::write_gltf(&room, &dir.join("small.gltf")).unwrap();
    gltf_write::write_gltf(&room, &dir.join("small.glb")).unwrap();
    write_textured(dir);
    write_skies(dir);
    std::fs::write(dir.join("colorlamp_2.obj"), repo("colorlamp_2.obj")).unwrap();
    std::fs::write(dir.join("colorlamp_2.mtl"), repo("colorlamp_2.mtl")).unwrap();
    let file = |name: &str| std::fs::read(dir.join(name)).unwrap();
    let mut t = vec![
        Target { name: "scene.toml", bytes: toml.into_bytes(), binary: false, entries: &["scene.toml"] },
        Target {
            name: "colorlamp_2.obj",
            bytes: repo("colorlamp_2.obj"),
            binary: false,
            entries: &["colorlamp_2.obj", "scene.toml"],
        },
        Target {
            name: "colorlamp_2.mtl",
            bytes: repo("colorlamp_2.mtl"),
            binary: false,
            entries: &["colorlamp_2.obj"],
        },
        Target { name: "cornell_1.mtl", bytes: repo("cornell_1.mtl"), binary: false, entries: &["scene.toml"] },
        Target { name: "small.gltf", bytes: file("small.gltf"), binary: false, entries: &["small.gltf", "scene.toml"] },
        Target { name: "small.bin", bytes: file("small.bin"), binary: true, entries: &["small.gltf"] },
        Target { name: "small.glb", bytes: file("small.glb"), binary: true, entries: &["small.glb"] },
        Target { name: "tex.gltf", bytes: file("tex.gltf"), binary: false, entries: &["tex.gltf"] },
        Target { name: "tex.bin", bytes: file("tex.bin"), binary: true, entries: &["tex.gltf"] },
        Target { name: "tex.png", bytes: file("tex.png"), binary: true, entries: &["tex.gltf"] },
        Target { name: "sky_exr.toml", bytes: file("sky_exr.toml"), binary: false, entries: &["sky_exr.toml"] },
        Target { name: "sky.exr", bytes: file("sky.exr"), binary: true, entries: &["sky_exr.toml"] },
        Target { name: "sky.hdr", bytes: file("sky.hdr"), binary: true, entries: &["sky_hdr.toml"] },
    ];
    // Read by scene.toml, not mutated (it is large).
    std::fs::write(dir.join("cornell_1.obj"), repo("cornell_1.obj")).unwrap();
    for target in &mut t {
        std::fs::write(dir.join(target.name), &target.bytes).unwrap();
    }
    t
}

/// A small sky image as `sky.exr` and `sky.hdr`, and a scene for each
/// (`[sky] image = ...`, turned and scaled) over the lamp shade's mesh.
fn write_skies(dir: &Path) {
    let (w, h) = (16, 8);
    let pixels: Vec<Vec3> =
        (0..w * h).map(|i| Vec3::new(1.0 + (i % w) as f32 * 0.1, 2.0 - (i / w) as f32 * 0.2, 0.5)).collect();
    let map = linkgi::sky::EnvMap::new(w, h, pixels.clone()).unwrap();
    linkgi::sky::envmap::write_exr(&map, &dir.join("sky.exr")).unwrap();
    let rgb: Vec<image::Rgb<f32>> = pixels.iter().map(|p| image::Rgb(p.to_array())).collect();
    let out = std::fs::File::create(dir.join("sky.hdr")).unwrap();
    image::codecs::hdr::HdrEncoder::new(out).encode(&rgb, w, h).unwrap();
    for (toml, img) in [("sky_exr.toml", "sky.exr"), ("sky_hdr.toml", "sky.hdr")] {
        let text = format!(
            "[settings]\nrays_per_vertex = 16\n\n[[mesh]]\nobj = \"colorlamp_2.obj\"\nemission = [1, 2, 3]\n\n[sky]\nimage = \"{img}\"\nrotate_deg = 30\nintensity = 2\n"
        );
        std::fs::write(dir.join(toml), text).unwrap();
    }
}

/// `tex.gltf`: a textured, vertex-coloured quad strip under a node
/// hierarchy, with a spot light and a camera.
fn write_textured(dir: &Path) {
    image::RgbImage::from_raw(2, 2, vec![200, 10, 10, 10, 200, 10, 10, 10, 200, 128, 128, 128])
        .unwrap()
        .save(dir.join("tex.png"))
        .unwrap();
    let mut d = gltf_doc::Doc::new();
    let pos =
        d.floats("VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0]);
    let uv = d.floats("VEC2", &[0.1, 0.1, 0.9, 0.1, 0.1, 0.9, 0.9, 0.9, 0.5, 0.5, 1.5, -0.5]);
    let col = d.floats("VEC4", &[1.0; 24]);
    let idx = d.indices(&[0, 2, 1, 1, 2, 3, 0, 1, 4, 1, 5, 4]);
    let mat = d.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.7, 1.0],
        "baseColorTexture": {"index": 0, "texCoord": 0}}, "emissiveFactor": [0.0, 0.0, 0.0]}));
    d.json["textures"] = json!([{"source": 0, "sampler": 0}]);
    d.json["samplers"] = json!([{"magFilter": 9729, "wrapS": 33648, "wrapT": 33071}]);
    d.json["images"] = json!([{"uri": "tex.png"}]);
    let mesh = d.mesh(
        json!({"attributes": {"POSITION": pos, "TEXCOORD_0": uv, "COLOR_0": col}, "indices": idx, "material": mat}),
    );
    let child = d.node(json!({"mesh": mesh, "translation": [0.0, 0.5, 0.0], "scale": [1.0, 1.0, -1.0]}), false);
    d.node(json!({"children": [child], "rotation": [0.0, 0.38268343, 0.0, 0.9238795], "scale": [2.0, 2.0, 2.0]}), true);
    d.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    d.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "spot", "intensity": 100.0, "spot": {"outerConeAngle": 0.6}}]}});
    d.node(json!({"translation": [0.5, 2.0, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}}), true);
    d.json["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05}}]);
    d.node(json!({"camera": 0, "translation": [0.5, 1.0, 4.0]}), true);
    d.write(dir, "tex.gltf");
}

const TOKENS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e39",
    "-1e39",
    "1e300",
    "3.4028236e38",
    "-1",
    "-0",
    "0",
    "1",
    "2",
    "3",
    "4",
    "7",
    "-7",
    "0.5",
    "1.5",
    "65535",
    "65536",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "-2147483649",
    "1e-45",
    "5121",
    "5123",
    "5125",
    "5126",
    "34962",
    "\"VEC2\"",
    "\"x\"",
    "[]",
    "{}",
    "null",
    "true",
    "\"",
    "\n",
    "/",
    "#",
    "=",
    "f",
    "v",
];

const WORDS: &[u32] = &[
    0x7fc0_0000, // NaN
    0x7f80_0000, // inf
    0xff80_0000, // -inf
    0x7f7f_ffff, // f32::MAX
    0x7149_f2ca, // 1e30
    0xbf80_0000, // -1.0
    0x8000_0000, // -0.0
    0,
    1,
    7,
    0xffff,
    u32::MAX,
];

/// Byte ranges of the numbers in `b`.
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let is_num = |c: u8| c.is_ascii_digit() || b"+-.eE".contains(&c);
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        if is_num(b[i]) && (i == 0 || !b[i - 1].is_ascii_alphanumeric()) {
            let start = i;
            while i < b.len() && is_num(b[i]) {
                i += 1;
            }
            if b[start..i].iter().any(u8::is_ascii_digit) {
                out.push((start, i));
            }
        } else {
            i += 1;
        }
    }
    out
}

/// Line (text) or slice (binary) boundaries: `(start, end)` of a random piece.
fn piece(rng: &mut Pcg32, b: &[u8], binary: bool) -> (usize, usize) {
    if binary {
        let s = rng.random_range(0..b.len());
        return (s, (s + rng.random_range(1..=64)).min(b.len()));
    }
    let s = rng.random_range(0..b.len());
    let start = b[..s].iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1);
    let end = b[s..].iter().position(|&c| c == b'\n').map_or(b.len(), |p| s + p + 1);
    (start, end)
}

/// Applies one to three random mutations; returns the bytes and what was done.
fn mutate(rng: &mut Pcg32, original: &[u8], binary: bool) -> (Vec<u8>, String) {
    let mut b = original.to_vec();
    let mut done = Vec::new();
    for _ in 0..rng.random_range(1..=3) {
        if b.is_empty() {
            break;
        }
        match rng.random_range(0..7) {
            0 | 1 => {
                let nums = numbers(&b);
                if binary && (nums.is_empty() || rng.random_bool(0.7)) && b.len() >= 4 {
                    let at = rng.random_range(0..b.len() / 4) * 4;
                    let w = WORDS[rng.random_range(0..WORDS.len())];
                    b[at..at + 4].copy_from_slice(&w.to_le_bytes());
                    done.push(format!("word {at} = {w:#x}"));
                } else if !nums.is_empty() {
                    let (s, e) = nums[rng.random_range(0..nums.len())];
                    let tok = TOKENS[rng.random_range(0..TOKENS.len())];
                    done.push(format!("number at {s} '{}' -> {tok:?}", String::from_utf8_lossy(&b[s..e])));
                    b.splice(s..e, tok.bytes());
                }
            }
            2 => {
                let at = rng.random_range(0..b.len());
                b.truncate(at);
                done.push(format!("truncate at {at}"));
            }
            3 => {
                let at = rng.random_range(0..b.len());
                if rng.random_bool(0.5) {
                    let bit = rng.random_range(0..8);
                    b[at] ^= 1 << bit;
                    done.push(format!("flip bit {bit} of byte {at}"));
                } else {
                    b[at] = rng.random();
                    done.push(format!("byte {at} = {}", b[at]));
                }
            }
            4 => {
                let (s, e) = piece(rng, &b, binary);
                let copy = b[s..e].to_vec();
                b.splice(e..e, copy);
                done.push(format!("duplicate {s}..{e}"));
            }
            5 => {
                let (s, e) = piece(rng, &b, binary);
                b.drain(s..e);
                done.push(format!("drop {s}..{e}"));
            }
            _ => {
                let at = rng.random_range(0..=b.len());
                let tok = TOKENS[rng.random_range(0..TOKENS.len())];
                b.splice(at..at, tok.bytes());
                done.push(format!("insert {tok:?} at {at}"));
            }
        }
    }
    (b, done.join(", "))
}

/// Loads `entry` and prepares it; `Err` with a message if the error names no file.
fn load_and_prepare(entry: &Path, dir: &str) -> Result<bool, String> {
    let stem = entry.file_stem().unwrap().to_string_lossy().into_owned();
    let result = scene::load(entry.to_str().unwrap()).and_then(|desc| prep::prepare(&desc).map(|_| ()));
    match result {
        Ok(()) => Ok(true),
        Err(Error::EmptyScene(name)) if name == stem => Ok(false),
        Err(e) if e.to_string().contains(dir) => Ok(false),
        Err(e) => Err(format!("error names no file: {e}")),
    }
}

fn panic_text(p: Box<dyn std::any::Any + Send>) -> String {
    p.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| p.downcast_ref::<String>().cloned()).unwrap_or_default()
}

/// Runs `count` mutated inputs from `seed`; panics listing every failure.
fn fuzz(name: &str, count: usize, seed: u64) {
    let dir = std::env::temp_dir().join(format!("linkgi-fuzz-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let dir_text = dir.display().to_string();
    let targets = corpus(&dir);
    for t in &targets {
        for e in t.entries {
            let r = load_and_prepare(&dir.join(e), &dir_text);
            assert_eq!(r, Ok(true), "pristine {e} must load and prepare");
        }
    }
    let mut rng = Pcg32::seed_from_u64(seed);
    let mut failures = Vec::new();
    let (mut loaded, mut rejected) = (0usize, 0usize);
    let start = std::time::Instant::now();
    for i in 0..count {
        let t = &targets[rng.random_range(0..targets.len())];
        let entry = t.entries[rng.random_range(0..t.entries.len())];
        let (bytes, what) = mutate(&mut rng, &t.bytes, t.binary);
        let path = dir.join(t.name);
        std::fs::write(&path, &bytes).unwrap();
        let outcome = catch_unwind(AssertUnwindSafe(|| load_and_prepare(&dir.join(entry), &dir_text)));
        let problem = match outcome {
            Ok(Ok(true)) => {
                loaded += 1;
                None
            }
            Ok(Ok(false)) => {
                rejected += 1;
                None
            }
            Ok(Err(m)) => Some(m),
            Err(p) => Some(format!("panic: {}", panic_text(p))),
        };
        if let Some(problem) = problem {
            let keep = dir.join(format!("failure-{i}-{}", t.name));
            std::fs::write(&keep, &bytes).unwrap();
            failures.push(format!(
                "input {i}: {} ({what}) loaded via {entry}, kept as {}: {problem}",
                t.name,
                keep.display()
            ));
        }
        std::fs::write(&path, &t.bytes).unwrap();
    }
    eprintln!(
        "{name}: {count} inputs in {:.1} s: {loaded} loaded and prepared, {rejected} rejected with errors naming the file, {} failures",
        start.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mutated_scene_files_never_panic() {
    fuzz("short", 2_000, 1);
}

#[test]
#[ignore = "long: 100,000 inputs; run with --release -- --ignored"]
fn mutated_scene_files_never_panic_long() {
    fuzz("long", 100_000, 2);
}
