//! Buried vertices (`links::buried`): a plank whose far end is pushed into
//! a block (the overlapping boxes of a modelled desk) has the corners of
//! its visible top face inside the block. Those corners shoot from a point
//! of their faces out in the open, so the visible top face reads its lit
//! value at every corner, as a path tracer sees it, instead of fading to
//! black toward the block.

mod common;

use glam::Vec3;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{prep, Bounces, Light, SceneDesc};
use linkgi::solver::SolveParams;

/// A floor, a closed block (x in [0.5, 1.5]) and a closed plank (x in
/// [-1, 1], its top at y = 0.5) whose end x = 1 is inside the block; lit
/// from straight above by a directional light. Returns the scene and the
/// plank's mesh index.
fn desk() -> (SceneDesc, usize) {
    let mut f = MeshBuilder::new();
    let grey = f.add_material("grey", Vec3::splat(0.5));
    f.quad_grid(Vec3::new(-3.0, 0.0, 3.0), Vec3::new(6.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -6.0), 6, 6, grey);
    let floor = f.finish("floor", 30.0);
    let mut b = MeshBuilder::new();
    let wood = b.add_material("wood", Vec3::splat(0.6));
    b.cuboid(Vec3::new(0.5, 0.0, -0.6), Vec3::new(1.5, 1.0, 0.6), 1, wood, false);
    let block = b.finish("block", 30.0);
    let mut p = MeshBuilder::new();
    let wood = p.add_material("wood", Vec3::splat(0.6));
    p.cuboid(Vec3::new(-1.0, 0.4, -0.3), Vec3::new(1.0, 0.5, 0.3), 1, wood, false);
    let plank = p.finish("plank", 30.0);
    let light = Light::Directional { direction: Vec3::new(0.1, -1.0, 0.05).normalize(), irradiance: Vec3::splat(3.0) };
    (common::scene_desc("desk", vec![floor, block, plank], vec![light], None, 64, Bounces::Fixed(2)), 2)
}

#[test]
fn a_buried_corner_reads_the_light_of_its_visible_face() {
    let (desc, plank) = desk();
    let scene = prep::prepare(&desc).unwrap();
    let (solver, sol) = common::solve_with(scene, SolveParams::from_settings(&desc.settings));
    let s = solver.scene();
    let m = &s.meshes[plank];
    // The plank's top face corners (y = 0.5, normal up): two out in the open, two inside the block.
    let top: Vec<usize> = (m.vertices.start as usize..m.vertices.end as usize)
        .filter(|&v| s.positions[v].y == 0.5 && s.normals[v].y > 0.9)
        .collect();
    let (inside, outside): (Vec<usize>, Vec<usize>) = top.iter().partition(|&&v| s.positions[v].x > 0.5);
    assert_eq!((inside.len(), outside.len()), (2, 2), "top corners {top:?}");
    let moved: Vec<u32> = s.moved_origins.iter().map(|e| e.0).collect();
    for &v in &inside {
        assert!(moved.contains(&(v as u32)), "buried corner {v} at {} not moved: {moved:?}", s.positions[v]);
        let o = s.moved_origins.iter().find(|e| e.0 == v as u32).unwrap().1;
        assert!(o.x < 0.5 && (o.y - 0.5).abs() < 1e-3, "its origin {o} lies on the visible top face");
    }
    for &v in &outside {
        assert!(!moved.contains(&(v as u32)), "corner {v} in the open moved");
    }
    let total = |v: usize| (sol.e_direct[v] + sol.e_indirect[v]).x;
    let open = outside.iter().map(|&v| total(v)).sum::<f32>() / 2.0;
    for &v in &inside {
        let e = total(v);
        eprintln!("buried corner {v}: E {e:.3} W/m^2 against {open:.3} at the open corners");
        // The top face is lit alike over its visible part (direct 2.98 W/m^2 there).
        assert!((e - open).abs() < 0.1 * open, "buried corner reads {e}, the open ones {open}");
    }
    // Nothing else of the scene is buried but what lies inside the block:
    // the plank's end and the floor under the block.
    let in_block = |p: Vec3| p.x > 0.5 && p.x < 1.5 && p.y < 1.0 && p.z.abs() < 0.6;
    let elsewhere: Vec<u32> = moved.iter().copied().filter(|&v| !in_block(s.positions[v as usize])).collect();
    assert!(elsewhere.is_empty(), "vertices moved outside the block: {elsewhere:?}");
}

/// The built-in scenes: what is buried is inside closed parts (counted;
/// every moved origin lies on one of the vertex's own faces).
#[test]
fn moved_origins_lie_on_their_own_faces() {
    for name in ["cornell", "tearoom", "window", "colorlamp"] {
        let desc = linkgi::scene::builtin::builtin(name).unwrap();
        let scene = prep::prepare(&desc).unwrap();
        let bvh = linkgi::bvh::Bvh::build(&scene.positions, &scene.triangles, &Default::default());
        let found = linkgi::links::buried::find(&scene, &bvh, linkgi::links::LinkParams::default().nudge);
        eprintln!("{name}: {} of {} vertices buried and moved", found.len(), scene.vertex_count());
        for (v, o) in &found {
            let on_a_face = scene.vertex_triangles.row(*v as usize).iter().any(|&t| {
                let [a, b, c] = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
                let n = (b - a).cross(c - a).normalize();
                let l = scene.mean_edge_length(*v as usize);
                (*o - a).dot(n).abs() < 1e-3 * l
            });
            assert!(on_a_face, "{name}: vertex {v}'s origin {o} off its faces");
        }
    }
}
