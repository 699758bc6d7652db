//! Scenes built in code (`scene::builder`) against the same scene loaded
//! from OBJ + MTL + TOML: the same links and irradiance; and bad buffers
//! refused with the loaders' errors.

mod common;

use glam::Vec3;
use linkgi::scene::builder::{MeshInput, SceneBuilder};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{Bounces, Light, Settings};

/// A small room: a floor and a back wall (6 x 6 quads each, from
/// `MeshBuilder::quad_grid`, taken as buffers) and a glowing ceiling panel;
/// exact binary fractions so the OBJ text is the same numbers.
fn room() -> (Vec<Vec3>, Vec<u32>, Vec<Vec3>, Vec<u32>) {
    let mut b = MeshBuilder::new();
    let m = b.add_material("wall", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.5, 0.0, 1.5), Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -3.0), 6, 6, m);
    b.quad_grid(Vec3::new(-1.5, 0.0, -1.5), Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0), 6, 6, m);
    let mesh = b.finish("room", 30.0);
    let idx = mesh.triangles.iter().flatten().copied().collect();
    // A panel at y = 2.5 facing down.
    let lamp = vec![
        Vec3::new(-0.5, 2.5, -0.5),
        Vec3::new(0.5, 2.5, -0.5),
        Vec3::new(0.5, 2.5, 0.5),
        Vec3::new(-0.5, 2.5, 0.5),
    ];
    (mesh.positions, idx, lamp, vec![0, 1, 2, 0, 2, 3])
}

fn obj_text(p: &[Vec3], idx: &[u32], material: &str) -> String {
    let mut s = format!("mtllib m.mtl\nusemtl {material}\n");
    for v in p {
        s += &format!("v {} {} {}\n", v.x, v.y, v.z);
    }
    for t in idx.chunks(3) {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

#[test]
fn a_scene_built_in_code_equals_the_same_scene_from_files() {
    let (p, idx, lamp, lamp_idx) = room();
    let light = Light::Point { position: Vec3::new(0.25, 1.75, 0.5), intensity: Vec3::new(2.0, 1.5, 1.0) };
    let settings = Settings { rays_per_vertex: 64, bounces: Bounces::Fixed(2), ..Default::default() };
    let built = SceneBuilder::new("room")
        .settings(settings)
        .mesh(MeshInput::new("room", &p, &idx).albedo(Vec3::new(0.5, 0.25, 0.75)))
        .mesh(
            MeshInput::new("lamp", &lamp, &lamp_idx)
                .albedo(Vec3::splat(0.5))
                .emission_radiance(Vec3::new(2.0, 2.0, 1.0)),
        )
        .light(light)
        .build()
        .unwrap();

    let dir = std::env::temp_dir().join(format!("linkgi-builder-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("m.mtl"), "newmtl wall\nKd 0.5 0.25 0.75\nnewmtl glow\nKd 0.5 0.5 0.5\nKe 2 2 1\n")
        .unwrap();
    std::fs::write(dir.join("room.obj"), obj_text(&p, &idx, "wall")).unwrap();
    std::fs::write(dir.join("lamp.obj"), obj_text(&lamp, &lamp_idx, "glow")).unwrap();
    std::fs::write(
        dir.join("s.toml"),
        "[settings]\nrays_per_vertex = 64\nbounces = 2\n[[mesh]]\nobj = \"room.obj\"\n[[mesh]]\nobj = \"lamp.obj\"\n\
         [[light]]\nkind = \"point\"\nposition = [0.25, 1.75, 0.5]\nintensity = [2, 1.5, 1]\n",
    )
    .unwrap();
    let loaded = linkgi::scene::load(dir.join("s.toml").to_str().unwrap()).unwrap();

    let (a, sa) = common::solve(&built);
    let (b, sb) = common::solve(&loaded);
    assert_eq!(a.scene().positions, b.scene().positions);
    assert_eq!(a.scene().emission, b.scene().emission);
    assert_eq!(a.scene().albedo, b.scene().albedo);
    assert_eq!(a.links().offsets, b.links().offsets);
    assert_eq!(a.links().targets(), b.links().targets());
    assert_eq!(a.links().weights, b.links().weights);
    assert_eq!(sa.e_direct, sb.e_direct);
    assert_eq!(sa.e_indirect, sb.e_indirect);
    assert!(common::mean(&sa.e_indirect).min_element() > 0.0);
    // Read per input vertex, in the caller's order.
    let on = a.scene().on_input(0, &sa.e_indirect);
    assert_eq!(on.len(), p.len());
    assert!(on.iter().all(|e| e.is_some_and(|e| e.is_finite())));
}

#[test]
fn bad_buffers_are_refused_with_the_loaders_errors() {
    let (p, idx, ..) = room();
    let err = |input: MeshInput| SceneBuilder::new("bad").mesh(input).build().unwrap_err().to_string();
    let e = err(MeshInput::new("room", &p, &idx[..idx.len() - 1]));
    assert!(e.contains("room") && e.contains("not three per triangle"), "{e}");
    let mut far = idx.clone();
    far[4] = 9999;
    let e = err(MeshInput::new("room", &p, &far));
    assert!(e.contains("room") && e.contains("triangle 1 uses vertex 9999"), "{e}");
    let mut nan = p.clone();
    nan[3].y = f32::NAN;
    let e = err(MeshInput::new("room", &nan, &idx));
    assert!(e.contains("room") && e.contains("vertex 3") && e.contains("non-finite"), "{e}");
    let e = err(MeshInput::new("lamp", &p, &idx).emission_radiance(Vec3::new(1.0, -1.0, 0.0)));
    assert!(e.contains("lamp") && e.contains("emission"), "{e}");
    let short = [Vec3::splat(0.5); 3];
    let e = err(MeshInput::new("room", &p, &idx).vertex_albedo(&short));
    assert!(e.contains("3 vertex albedos"), "{e}");
    let e = SceneBuilder::new("empty").build().unwrap_err().to_string();
    assert!(e.contains("no triangles"), "{e}");
    let e = SceneBuilder::new("s")
        .settings(Settings { rays_per_vertex: 10, ..Default::default() })
        .mesh(MeshInput::new("room", &p, &idx))
        .build()
        .unwrap_err()
        .to_string();
    assert!(e.contains("rays_per_vertex"), "{e}");
}
