//! Bad input gets a clear error naming the file and the problem (or a
//! documented fallback with a warning), never a panic.

use glam::Vec3;
use linkgi::scene::{self, prep};
use std::path::PathBuf;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("linkgi-bad-input-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &PathBuf, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 3 2\nf 1 4 3\n";

fn scene_toml(obj: &str) -> String {
    format!("[[mesh]]\nobj = \"{obj}\"\n[[light]]\nkind = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n")
}

fn load_err(path: &PathBuf) -> String {
    let e = scene::load(path.to_str().unwrap()).expect_err("should fail");
    let msg = e.to_string();
    eprintln!("{msg}");
    msg
}

#[test]
fn nan_coordinate_names_file_and_line() {
    let d = tmpdir("nan");
    write(&d, "m.obj", "# comment\nv 0 0 0\nv nan 0 0\nv 0 0 1\nf 1 2 3\n");
    let s = write(&d, "s.toml", &scene_toml("m.obj"));
    let msg = load_err(&s);
    assert!(msg.contains("m.obj:3") && msg.contains("not finite"), "{msg}");
    write(&d, "i.obj", "v 0 0 0\nv inf 0 0\nv 0 0 1\nf 1 2 3\n");
    let msg = load_err(&write(&d, "s2.toml", &scene_toml("i.obj")));
    assert!(msg.contains("i.obj:2"), "{msg}");
}

#[test]
fn index_out_of_range_names_line() {
    let d = tmpdir("index");
    write(&d, "m.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 2 3\nf 1 2 7\n");
    let msg = load_err(&write(&d, "s.toml", &scene_toml("m.obj")));
    assert!(msg.contains("m.obj:5") && msg.contains("out of range"), "{msg}");
    write(&d, "r.obj", "v 0 0 0\nf -1 -2 -3\n");
    let msg = load_err(&write(&d, "s2.toml", &scene_toml("r.obj")));
    assert!(msg.contains("r.obj:2"), "{msg}");
    // In-memory meshes are checked too.
    let mut desc = scene::builtin::closed_room(2, 0.5);
    desc.meshes[0].triangles[0][1] = 10_000;
    let msg = prep::prepare(&desc).unwrap_err().to_string();
    assert!(msg.contains("triangle 0 uses vertex 10000"), "{msg}");
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let d = tmpdir("degenerate");
    // A quad, a zero-area sliver (collinear), and a triangle with a repeated corner.
    write(&d, "m.obj", &format!("{QUAD}v 2 0 0\nv 3 0 0\nf 1 5 6\nf 1 1 2\n"));
    let desc = scene::load(write(&d, "s.toml", &scene_toml("m.obj")).to_str().unwrap()).unwrap();
    let p = prep::prepare(&desc).unwrap();
    assert_eq!(p.dropped_triangles, 2);
    assert_eq!(p.triangles.len(), 2);
}

#[test]
fn missing_files_are_named() {
    let d = tmpdir("missing");
    let msg = load_err(&write(&d, "s.toml", &scene_toml("nowhere.obj")));
    assert!(msg.contains("nowhere.obj"), "{msg}");
    let e = scene::load(d.join("absent.toml").to_str().unwrap()).unwrap_err().to_string();
    assert!(e.contains("absent.toml"), "{e}");
    let e = scene::load("no_such_builtin").unwrap_err().to_string();
    assert!(e.contains("no_such_builtin") && e.contains("cornell"), "{e}");
}

#[test]
fn malformed_toml_names_file_and_line() {
    let d = tmpdir("toml");
    write(&d, "m.obj", QUAD);
    let msg = load_err(&write(&d, "s.toml", "[settings]\nrays_per_vertex = \n[[mesh]]\nobj = \"m.obj\"\n"));
    assert!(msg.contains("s.toml") && msg.contains("line 2"), "{msg}");
    let msg = load_err(&write(&d, "k.toml", "[[mesh]]\nobj = \"m.obj\"\n[[light]]\nkind = \"spot\"\n"));
    assert!(msg.contains("k.toml") && msg.contains("spot"), "{msg}");
    let msg = load_err(&write(&d, "r.toml", "[settings]\nrays_per_vertex = 200\n[[mesh]]\nobj = \"m.obj\"\n"));
    assert!(msg.contains("r.toml") && msg.contains("square"), "{msg}");
    let msg = load_err(&write(&d, "b.toml", "[settings]\nbounces = \"many\"\n[[mesh]]\nobj = \"m.obj\"\n"));
    assert!(msg.contains("b.toml") && msg.contains("auto"), "{msg}");
    let msg = load_err(&write(&d, "e.toml", "[settings]\nseed = 3\n"));
    assert!(msg.contains("e.toml") && msg.contains("no [[mesh]]"), "{msg}");
    let msg = load_err(&write(
        &d,
        "n.toml",
        "[[mesh]]\nobj = \"m.obj\"\n[[light]]\nkind = \"point\"\nposition = [0, nan, 0]\nintensity = [1, 1, 1]\n",
    ));
    assert!(msg.contains("n.toml") && msg.contains("not finite"), "{msg}");
}

#[test]
fn empty_scene_is_an_error() {
    let d = tmpdir("empty");
    write(&d, "m.obj", "v 0 0 0\nv 1 0 0\n");
    let msg = load_err(&write(&d, "s.toml", &scene_toml("m.obj")));
    assert!(msg.contains("m.obj") && msg.contains("no faces"), "{msg}");
    // Only degenerate faces: the prepared scene has no triangles.
    write(&d, "z.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    let desc = scene::load(write(&d, "z.toml", &scene_toml("z.obj")).to_str().unwrap()).unwrap();
    let msg = prep::prepare(&desc).unwrap_err().to_string();
    assert!(msg.contains("no triangles"), "{msg}");
}

#[test]
fn missing_mtl_and_bright_albedo_fall_back_with_warnings() {
    let d = tmpdir("mtl");
    write(&d, "m.obj", &format!("mtllib absent.mtl\nusemtl red\n{QUAD}"));
    let desc = scene::load(write(&d, "s.toml", &scene_toml("m.obj")).to_str().unwrap()).unwrap();
    assert!(desc.warnings.iter().any(|w| w.contains("m.obj") && w.contains("material library")), "{:?}", desc.warnings);
    assert_eq!(desc.meshes[0].materials[0].albedo, Vec3::splat(linkgi::scene::obj::DEFAULT_ALBEDO));

    write(&d, "b.mtl", "newmtl hot\nKd 1.5 0.5 -0.2\n");
    write(&d, "b.obj", &format!("mtllib b.mtl\nusemtl hot\n{QUAD}"));
    let desc = scene::load(write(&d, "b.toml", &scene_toml("b.obj")).to_str().unwrap()).unwrap();
    assert!(desc.warnings.iter().any(|w| w.contains("hot") && w.contains("clamped")), "{:?}", desc.warnings);
    let a = desc.meshes[0].materials[0].albedo;
    assert!(a.x < 1.0 && a.z == 0.0 && a.y == 0.5, "{a}");
}

#[test]
fn non_finite_transform_and_lights_are_rejected() {
    let mut desc = scene::builtin::closed_room(2, 0.5);
    desc.meshes[0].transform.scale = f32::INFINITY;
    assert!(prep::prepare(&desc).unwrap_err().to_string().contains("not finite"));
    let mut desc = scene::builtin::closed_room(2, 0.5);
    desc.lights.push(scene::Light::Point { position: Vec3::NAN, intensity: Vec3::ONE });
    assert!(prep::prepare(&desc).is_err());
}

#[test]
fn bare_obj_loads_with_defaults() {
    let d = tmpdir("bare");
    let p = write(&d, "m.obj", QUAD);
    let desc = scene::load(p.to_str().unwrap()).unwrap();
    assert_eq!(desc.meshes[0].triangles.len(), 2);
    assert!(desc.lights.is_empty());
}

#[test]
fn tracer_setting_is_checked_and_round_trips() {
    let d = tmpdir("tracer");
    write(&d, "m.obj", QUAD);
    let msg = load_err(&write(&d, "t.toml", &format!("[settings]\ntracer = \"octree\"\n{}", scene_toml("m.obj"))));
    assert!(msg.contains("t.toml") && msg.contains("tracer") && msg.contains("octree"), "{msg}");

    let p = write(&d, "kd.toml", &format!("[settings]\ntracer = \"kd\"\n{}", scene_toml("m.obj")));
    let desc = scene::load(p.to_str().unwrap()).unwrap();
    assert_eq!(desc.settings.tracer, scene::TracerKind::Kd);
    let text = scene::file::to_toml(&desc, &["m.obj".to_string()]);
    assert!(text.contains("tracer = \"kd\""), "{text}");
    let back = scene::file::parse_toml(&p, &text).unwrap();
    assert_eq!(back.settings, desc.settings);

    // Ray queries round-trip as "rq".
    let p = write(&d, "rq.toml", &format!("[settings]\ntracer = \"rq\"\n{}", scene_toml("m.obj")));
    let desc = scene::load(p.to_str().unwrap()).unwrap();
    assert_eq!(desc.settings.tracer, scene::TracerKind::RayQuery);
    let text = scene::file::to_toml(&desc, &["m.obj".to_string()]);
    assert!(text.contains("tracer = \"rq\""), "{text}");

    // The default (auto) is left out when written, and read back as auto.
    let desc = scene::load(write(&d, "b.toml", &scene_toml("m.obj")).to_str().unwrap()).unwrap();
    assert_eq!(desc.settings.tracer, scene::TracerKind::Auto);
    let text = scene::file::to_toml(&desc, &["m.obj".to_string()]);
    assert!(!text.contains("tracer"), "{text}");
    assert_eq!(scene::file::parse_toml(&p, &text).unwrap().settings.tracer, scene::TracerKind::Auto);
}
