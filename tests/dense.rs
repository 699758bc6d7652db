//! Dense meshes (issue 45): a scene denser than the triangle budget is
//! solved on a simplified lighting mesh ([`linkgi::scene::simplify`]) and
//! every input position reads its light through the transfer
//! ([`linkgi::scene::transfer`]). Checked against the sphere furnace at
//! every input vertex, against a dark room beside a lit one through a
//! 1 mm wall, and against the coarse copy's picture.

mod common;

use glam::Vec3;
use linkgi::bvh::Bvh;
use linkgi::reference::image::score;
use linkgi::render::cpu::render_cpu;
use linkgi::render::{Frame, RenderParams};
use linkgi::scene::dense::dense_copy;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, Bounces, Light};

/// A sphere furnace tessellated 16x finer than the light needs (81,920
/// triangles) under a budget of 5,000: the lighting mesh is the budget's
/// size, and every one of the input's positions reads the analytic
/// `rho / (1 - rho) * I / R^2` through the transfer, within 5%.
#[test]
fn a_dense_sphere_reaches_the_furnace_value_at_every_input_vertex() {
    let (rho, intensity) = (0.6f32, 1.0f32);
    let coarse = builtin::furnace(rho, 4, Vec3::new(0.2, -0.1, 0.1), intensity);
    let mut desc = common::with_settings(dense_copy(&coarse, 2), 256, Bounces::Auto, 30.0);
    desc.settings.refine.max_triangles = 5000;
    let input = &desc.meshes[0];
    let (solver, sol) = common::solve(&desc);
    let scene = solver.scene();
    assert!(scene.triangles.len() <= 6000, "lighting mesh of {} triangles", scene.triangles.len());
    assert!(scene.vertex_count() < input.positions.len() / 8);
    // The lighting mesh's own radius (its area's): the furnace it is.
    let r2 = common::mesh_area(scene) / (4.0 * std::f32::consts::PI);
    let expect = rho / (1.0 - rho) * intensity / r2;
    let on = scene.on_input(0, &sol.e_indirect);
    assert_eq!(on.len(), input.positions.len());
    let mut worst = 0f32;
    for (i, e) in on.iter().enumerate() {
        let e = e.unwrap_or_else(|| panic!("input position {i} has no value"));
        worst = worst.max((e.x / expect - 1.0).abs());
    }
    eprintln!(
        "{} input positions on {} lighting vertices: worst {:.2}% from the furnace value",
        on.len(),
        scene.vertex_count(),
        worst * 100.0
    );
    assert!(worst < 0.05, "worst input position {worst}");
}

/// Two closed rooms in one mesh, one material, their walls 1 mm apart
/// (facing away from each other), only the first lit; tessellated 16x
/// over the budget. Every input position of the dark room reads no light
/// through the transfer, although the lit room's wall is the nearest
/// lighting triangle to many of them; the lit room's shared wall reads
/// light.
#[test]
fn a_thin_wall_leaks_no_light_through_the_transfer() {
    let mut b = MeshBuilder::new();
    let grey = b.add_material("grey", Vec3::splat(0.7));
    b.cuboid(Vec3::new(-1.0, 0.0, -0.5), Vec3::new(0.0, 1.0, 0.5), 8, grey, true);
    b.cuboid(Vec3::new(0.001, 0.0, -0.5), Vec3::new(1.001, 1.0, 0.5), 8, grey, true);
    let rooms = b.finish("two rooms", 30.0);
    let light = Light::Point { position: Vec3::new(-0.5, 0.6, 0.0), intensity: Vec3::splat(2.0) };
    let coarse = common::scene_desc("two rooms", vec![rooms], vec![light], None, 64, Bounces::Auto);
    let mut desc = dense_copy(&coarse, 2);
    desc.settings.refine.max_triangles = 1000;
    let input = desc.meshes[0].positions.clone();
    let (solver, sol) = common::solve(&desc);
    let scene = solver.scene();
    assert!(scene.triangles.len() < desc.meshes[0].triangles.len() / 4, "simplified");
    let direct = scene.on_input(0, &sol.e_direct);
    let indirect = scene.on_input(0, &sol.e_indirect);
    let (mut dark, mut lit_wall) = (0, 0);
    for (i, p) in input.iter().enumerate() {
        let (d, e) = (direct[i].expect("a value"), indirect[i].expect("a value"));
        if p.x > 0.0005 {
            assert_eq!((d, e), (Vec3::ZERO, Vec3::ZERO), "dark room position {p} reads light");
            dark += 1;
        } else if p.x > -1e-6 && p.y > 0.05 && p.y < 0.95 && p.z.abs() < 0.45 {
            assert!(d.x + e.x > 0.0, "the lit room's wall at {p} reads no light");
            lit_wall += 1;
        }
    }
    assert!(dark > 1000 && lit_wall > 100, "{dark} dark, {lit_wall} on the lit wall");
}

/// A dense copy (16x the triangles, the same geometry) of the Cornell box
/// under a budget of its coarse size gives the coarse copy's picture: mean
/// luminance within 5%, 8x8 block error under 10%.
#[test]
fn a_dense_copy_gives_the_coarse_picture() {
    let coarse = common::with_settings(builtin::builtin("cornell").unwrap(), 256, Bounces::Auto, 30.0);
    let triangles: usize = coarse.meshes.iter().map(|m| m.triangles.len()).sum();
    let mut dense = dense_copy(&coarse, 2);
    dense.settings.refine.max_triangles = triangles.max(1000) as u32;
    let camera = coarse.camera.expect("cornell has a camera");
    let picture = |desc: &linkgi::scene::SceneDesc| {
        let (solver, sol) = common::solve(desc);
        let scene = solver.scene();
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
        let p = RenderParams { width: 96, height: 72, ..Default::default() };
        let (img, _) = render_cpu(&Frame::of(scene, &sol.e_indirect, camera), &p, Some(&bvh)).unwrap();
        (img, scene.triangles.len())
    };
    let (a, na) = picture(&coarse);
    let (b, nb) = picture(&dense);
    let s = score(&b, &a).expect("lit");
    eprintln!(
        "coarse {na} triangles, dense {} simplified to {nb}: mean ratio {:.4}, block error {:.2}%",
        4 * 4 * triangles,
        s.mean_ratio,
        s.block_error * 100.0
    );
    assert!(nb <= 2 * triangles, "lighting mesh {nb} for a coarse {triangles}");
    assert!((s.mean_ratio - 1.0).abs() < 0.05, "mean luminance ratio {}", s.mean_ratio);
    assert!(s.block_error < 0.10, "block error {}", s.block_error);
}
