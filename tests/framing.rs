//! A right first picture of a scene without a camera: automatic framing
//! (`render::framing`) and automatic exposure (`render::exposure`).
//!
//! The scenes stand far from the origin, where the old default camera
//! ((0, 1, 3.5) looking at (0, 1, 0)) sees nothing of them.

mod common;

use common::scene_desc;
use glam::Vec3;
use linkgi::bvh::Bvh;
use linkgi::render::cpu::render_cpu;
use linkgi::render::exposure::auto_exposure;
use linkgi::render::framing::{auto_camera, camera_or_framed};
use linkgi::render::{pixel_ray, tone_map, Frame, RenderParams};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, prep, Bounces, Camera, Light, SceneDesc};

const W: u32 = 96;
const H: u32 = 72;

/// A closed room 6 x 3 x 8 m (faces inward) with a block in it, lit by a
/// point light under the ceiling, at (40, -7, -25).
fn room() -> SceneDesc {
    let o = Vec3::new(40.0, -7.0, -25.0);
    let mut b = MeshBuilder::new();
    let wall = b.add_material("wall", Vec3::splat(0.6));
    let red = b.add_material("red", Vec3::new(0.6, 0.1, 0.1));
    b.cuboid(o, o + Vec3::new(6.0, 3.0, 8.0), 6, wall, true);
    b.cuboid(o + Vec3::new(3.5, 0.0, 2.0), o + Vec3::new(4.5, 1.2, 3.0), 3, red, false);
    let light = Light::Point { position: o + Vec3::new(2.0, 2.6, 5.0), intensity: Vec3::splat(30.0) };
    scene_desc("room", vec![b.finish("room", 30.0)], vec![light], None, 16, Bounces::Fixed(2))
}

/// A sphere of radius 0.3 at (-12, 5, 30) under a directional light.
fn object() -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("ball", Vec3::splat(0.7));
    b.icosphere(Vec3::new(-12.0, 5.0, 30.0), 0.3, 3, m, false);
    let sun = Light::Directional { direction: Vec3::new(-0.3, -1.0, -0.5).normalize(), irradiance: Vec3::splat(3.0) };
    scene_desc("ball", vec![b.finish("ball", 30.0)], vec![sun], None, 16, Bounces::Fixed(2))
}

struct Shot {
    camera: Camera,
    inside: bool,
    /// Tone-mapped luma per pixel, 0-255.
    luma: Vec<f32>,
    /// Pixels whose primary ray meets the scene.
    hits: Vec<bool>,
}

fn shoot(desc: &SceneDesc) -> Shot {
    let (solver, sol) = common::solve(desc);
    let scene = solver.scene();
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
    let framing = auto_camera(scene, &bvh);
    // The same camera as the CLI's path (camera_or_framed builds its own BVH).
    assert_eq!(camera_or_framed(None, scene, None).0, framing.camera);
    let camera = framing.camera;
    let p = RenderParams { width: W, height: H, ..Default::default() };
    let frame = Frame::of(scene, &sol.e_indirect, camera);
    let (img, _) = render_cpu(&frame, &p, None).unwrap();
    let png = tone_map(&img, auto_exposure(&img));
    let luma = png.pixels().map(|q| 0.2126 * q[0] as f32 + 0.7152 * q[1] as f32 + 0.0722 * q[2] as f32).collect();
    let extent = frame.extent();
    let hits = (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| bvh.intersect(&pixel_ray(&camera, W, H, extent, x, y)).is_some())
        .collect();
    Shot { camera, inside: framing.inside, luma, hits }
}

fn mean_and_spread(v: &[f32]) -> (f32, f32) {
    let m = v.iter().sum::<f32>() / v.len() as f32;
    (m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32).sqrt())
}

fn centre_hits(s: &Shot) -> bool {
    s.hits[((H / 2) * W + W / 2) as usize]
}

#[test]
fn an_enclosure_is_framed_from_inside_and_its_picture_is_neither_black_nor_flat() {
    let desc = room();
    let shot = shoot(&desc);
    let o = Vec3::new(40.0, -7.0, -25.0);
    eprintln!("room: {:?} inside {}", shot.camera, shot.inside);
    assert!(shot.inside, "the room was not recognised as an enclosure");
    let c = shot.camera.position;
    assert!(c.cmpgt(o).all() && c.cmplt(o + Vec3::new(6.0, 3.0, 8.0)).all(), "camera {c} outside the room");
    // Not inside the block.
    let (bl, bh) = (o + Vec3::new(3.5, 0.0, 2.0), o + Vec3::new(4.5, 1.2, 3.0));
    assert!(!(c.cmpge(bl).all() && c.cmple(bh).all()), "camera {c} inside the block");
    assert!(shot.hits.iter().all(|&h| h), "a closed room seen from inside: every pixel sees a wall");
    let (m, s) = mean_and_spread(&shot.luma);
    eprintln!("room: mean luma {m:.1}, spread {s:.1}");
    assert!(m > 40.0 && m < 215.0, "mean luma {m}: black or blown out");
    assert!(s > 8.0, "luma spread {s}: a flat picture");
    assert!(centre_hits(&shot));
}

#[test]
fn an_object_is_framed_whole_from_outside() {
    let desc = object();
    let shot = shoot(&desc);
    eprintln!("ball: {:?} inside {}", shot.camera, shot.inside);
    assert!(!shot.inside, "the ball was taken for an enclosure");
    assert!(centre_hits(&shot), "the picture's centre does not see the ball");
    let covered = shot.hits.iter().filter(|&&h| h).count() as f32 / shot.hits.len() as f32;
    assert!(covered > 0.05 && covered < 0.9, "the ball covers {covered} of the picture");
    // Framed whole: no pixel on the border sees it.
    let border = (0..W).flat_map(|x| [(x, 0), (x, H - 1)]).chain((0..H).flat_map(|y| [(0, y), (W - 1, y)]));
    for (x, y) in border {
        assert!(!shot.hits[(y * W + x) as usize], "the ball touches the border at ({x}, {y})");
    }
    let lit: Vec<f32> = shot.luma.iter().zip(&shot.hits).filter(|(_, &h)| h).map(|(l, _)| *l).collect();
    let (m, s) = mean_and_spread(&lit);
    eprintln!("ball: mean luma {m:.1}, spread {s:.1} over {} pixels", lit.len());
    assert!(m > 40.0 && s > 8.0, "the ball is black or flat: mean {m}, spread {s}");
}

#[test]
fn the_old_default_camera_sees_nothing_of_these_scenes() {
    // What these tests guard against: without framing, both pictures were black.
    for desc in [room(), object()] {
        let scene = prep::prepare(&desc).unwrap();
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
        let extent = Frame::of(&scene, &scene.positions, Camera::default()).extent();
        let seen = (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .filter(|&(x, y)| bvh.intersect(&pixel_ray(&Camera::default(), W, H, extent, x, y)).is_some())
            .count();
        assert_eq!(seen, 0, "{}", desc.name);
    }
}

#[test]
fn builtin_rooms_are_framed_from_inside_their_rooms() {
    for name in ["cornell", "window", "tearoom", "colorlamp"] {
        let desc = builtin::builtin(name).unwrap();
        let scene = prep::prepare(&desc).unwrap();
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
        let f = auto_camera(&scene, &bvh);
        eprintln!("{name}: {}", f.describe());
        assert!(f.inside, "{name}");
        let room = &scene.meshes[0];
        let r = room.vertices.start as usize..room.vertices.end as usize;
        let (lo, hi) =
            scene.positions[r].iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let c = f.camera.position;
        // Inside the room, or standing in an opening of its walls (the window's).
        assert!(c.cmpge(lo).all() && c.cmple(hi).all(), "{name}: camera {c} outside [{lo}, {hi}]");
    }
}

#[test]
fn auto_exposure_renders_the_same_png_with_lights_1000_times_stronger() {
    let base = room();
    let mut bright = room();
    for l in &mut bright.lights {
        *l = l.with_strength(l.strength() * 1000.0);
    }
    let imgs: Vec<linkgi::render::HdrImage> = [base, bright]
        .iter()
        .map(|d| {
            let (solver, sol) = common::solve(d);
            let camera = camera_or_framed(None, solver.scene(), None).0;
            let p = RenderParams { width: W, height: H, ..Default::default() };
            render_cpu(&Frame::of(solver.scene(), &sol.e_indirect, camera), &p, None).unwrap().0
        })
        .collect();
    let pngs: Vec<image::RgbImage> = imgs.iter().map(|i| tone_map(i, auto_exposure(i))).collect();
    let diff = pngs[0].as_raw().iter().zip(pngs[1].as_raw()).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    let same = pngs[0].as_raw().iter().zip(pngs[1].as_raw()).filter(|(a, b)| a == b).count();
    eprintln!("largest difference {diff} of 255; {same}/{} channels equal", pngs[0].as_raw().len());
    assert!(diff <= 1, "the 1000x brighter scene renders differently (up to {diff} levels)");
    // A fixed exposure would not: one of the two is black or white.
    let mean = |i: &image::RgbImage| i.as_raw().iter().map(|&v| v as f32).sum::<f32>() / i.as_raw().len() as f32;
    let fixed: Vec<f32> = imgs.iter().map(|i| mean(&tone_map(i, linkgi::render::DEFAULT_EXPOSURE))).collect();
    eprintln!("mean level at the fixed exposure: {fixed:?}; auto: {}", mean(&pngs[0]));
    assert!(fixed[0] < 10.0 || fixed[1] > 245.0, "{fixed:?}");
}
