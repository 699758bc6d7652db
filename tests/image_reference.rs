//! The image-space reference (`reference::image`): the reference path
//! tracer through a camera, against an analytic case and against the
//! link solution's render of a finely tessellated built-in scene.

mod common;

use glam::Vec3;
use linkgi::bvh::Bvh;
use linkgi::reference::image::{render, score};
use linkgi::reference::ReferenceParams;
use linkgi::render::cpu::render_cpu;
use linkgi::render::{pixel_ray, Frame, HdrImage, RenderParams};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, prep, Bounces, Camera, Light};

#[test]
fn a_plate_under_a_point_light_shows_rho_over_pi_i_cos_over_r2() {
    let rho = Vec3::new(0.7, 0.5, 0.3);
    let mut b = MeshBuilder::new();
    let m = b.add_material("plate", rho);
    // A 2 x 2 m plate at y = 0 facing up, two triangles (the estimate is exact at any point).
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), 1, 1, m);
    let (i, light) = (Vec3::new(3.0, 2.0, 1.0), Vec3::new(0.3, 1.2, -0.2));
    let desc = common::scene_desc(
        "plate",
        vec![b.finish("plate", 30.0)],
        vec![Light::Point { position: light, intensity: i }],
        None,
        16,
        Bounces::Fixed(1),
    );
    let scene = prep::prepare(&desc).unwrap();
    assert!(scene.normals.iter().all(|n| n.y > 0.99), "the plate faces up");
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
    let camera = Camera { position: Vec3::new(0.0, 2.5, 2.0), target: Vec3::ZERO, fov_deg: 50.0 };
    let (w, h) = (40, 30);
    let img = render(&scene, &bvh, &camera, w, h, 4, &ReferenceParams::default(), &|| {});
    let extent = {
        let (lo, hi) = scene.bounds();
        (hi - lo).length()
    };
    let mut on_plate = 0;
    for y in 0..h {
        for x in 0..w {
            let ray = pixel_ray(&camera, w, h, extent, x, y);
            let t = -ray.origin.y / ray.dir.y;
            let p = ray.origin + ray.dir * t;
            let got = img.at(x, y);
            if t > 0.0 && p.x.abs() < 0.999 && p.z.abs() < 0.999 {
                let d = light - p;
                let expect = rho / std::f32::consts::PI * i * (d.y / d.length()) / d.length_squared();
                let err = ((got - expect).abs() / expect).max_element();
                assert!(err < 1e-4, "pixel ({x}, {y}): {got} against {expect}");
                on_plate += 1;
            } else if t <= 0.0 || p.x.abs() > 1.001 || p.z.abs() > 1.001 {
                assert_eq!(got, Vec3::ZERO, "pixel ({x}, {y}) sees nothing");
            }
        }
    }
    assert!(on_plate > 300, "{on_plate} pixels on the plate");
}

#[test]
fn the_score_of_an_image_against_itself_and_a_brighter_copy() {
    let img =
        HdrImage { width: 20, height: 12, pixels: (0..240).map(|i| Vec3::splat(0.1 + (i % 7) as f32 * 0.3)).collect() };
    let same = score(&img, &img).unwrap();
    assert_eq!((same.mean_ratio, same.block_error), (1.0, 0.0));
    assert_eq!(same.blocks, 3 * 2);
    let double = HdrImage { pixels: img.pixels.iter().map(|p| *p * 2.0).collect(), ..img.clone() };
    let s = score(&double, &img).unwrap();
    assert!((s.mean_ratio - 2.0).abs() < 1e-6 && (s.block_error - 1.0).abs() < 1e-6, "{s:?}");
    let black = HdrImage { pixels: vec![Vec3::ZERO; 240], ..img.clone() };
    assert_eq!(score(&img, &black), None);
}

#[test]
fn the_link_solution_of_the_cornell_box_agrees_with_the_image_reference() {
    let mut desc = builtin::builtin("cornell").unwrap();
    desc.settings.rays_per_vertex = 256;
    desc.settings.bounces = Bounces::Auto;
    let (solver, sol) = common::solve(&desc);
    let scene = solver.scene();
    let camera = desc.camera.unwrap();
    let (w, h) = (64, 48);
    let p = RenderParams { width: w, height: h, ..Default::default() };
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
    let (ours, _) = render_cpu(&Frame::of(scene, &sol.e_indirect, camera), &p, Some(&bvh)).unwrap();
    let reference = render(scene, &bvh, &camera, w, h, 64, &ReferenceParams::default(), &|| {});
    let s = score(&ours, &reference).unwrap();
    eprintln!(
        "cornell 64x48: mean ratio {:.4}, block error {:.4} over {} blocks",
        s.mean_ratio, s.block_error, s.blocks
    );
    // Auto bounces: with the scene's 3 the picture is 13% dark (0.87).
    assert!((s.mean_ratio - 1.0).abs() < 0.03, "{s:?}");
    assert!(s.block_error < 0.06, "{s:?}");
    assert!(s.blocks >= 40);
}
