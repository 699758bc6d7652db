//! The skip rule of rays from a vertex on flat-shaded and creased meshes
//! (issue 32, "black speckles on flat-shaded meshes").
//!
//! A ray from solver vertex `v` skips the triangles with `v` as a corner;
//! crease and border vertices shoot from an origin nudged into their own
//! face group (docs/DESIGN.md §3). Triangles of the *other* copies of
//! `v`'s position (other face groups at a crease) are traced.
//!
//! - On convex flat-shaded meshes (crease angle 0: every vertex split per
//!   face) that is exact: every vertex facing a point light reads
//!   `I cos / r^2`, and no link ray meets the mesh again (from a point of
//!   a convex body's surface, no direction above its face meets the body).
//! - At concave creases the other copies' faces must stay in the way:
//!   skipping every copy of the position (the welded id) would let the
//!   light of a sun outside a closed one-mesh room onto the floor along
//!   the walls, and link rays along the walls would leave the room.

mod common;

use glam::{Vec2, Vec3};
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::exchange::{LightLinkParams, LightLinks};
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::links::{LinkParams, RaySetup, HIT_BACK, HIT_MISS};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, prep, Bounces, Light, MeshDesc};
use linkgi::trace::Tracer;

/// A flat-shaded geodesic sphere (radius 0.5) off the origin.
fn flat_icosphere(subdivisions: u32) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.icosphere(Vec3::new(0.1, 1.0, -0.2), 0.5, subdivisions, m, false);
    b.finish("icosphere", 0.0)
}

/// A flat-shaded UV sphere (radius 0.5, poles on the y axis).
fn flat_uv_sphere(segments: u32, rings: u32) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    let profile: Vec<Vec2> = (0..=rings)
        .map(|k| {
            let a = std::f32::consts::PI * k as f32 / rings as f32;
            let r = if k == 0 || k == rings { 0.0 } else { 0.5 * a.sin() };
            Vec2::new(r, -0.5 * a.cos())
        })
        .collect();
    b.revolve(Vec3::new(0.1, 1.0, -0.2), &profile, segments, m, false);
    b.finish("uv_sphere", 0.0)
}

/// A flat-shaded box with a 4x4 grid per face.
fn flat_cube() -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.cuboid(Vec3::new(-0.4, 0.6, -0.5), Vec3::new(0.5, 1.3, 0.3), 4, m, false);
    b.finish("cube", 0.0)
}

fn prepared(mesh: MeshDesc, lights: Vec<Light>) -> prep::PreparedScene {
    let desc = common::scene_desc("skip_rule", vec![mesh], lights, None, 64, Bounces::Fixed(1));
    prep::prepare(&desc).unwrap()
}

fn convex_meshes() -> Vec<MeshDesc> {
    vec![flat_icosphere(3), flat_uv_sphere(32, 16), flat_cube()]
}

/// Every vertex of a convex flat-shaded mesh that faces the light sees it
/// (nothing of a convex body lies between a surface point and a light in
/// front of its face): `E_d = I cos / r^2` to float rounding, with both
/// CPU structures; the others read 0.
#[test]
fn flat_shaded_convex_vertices_read_exact_direct_light() {
    let intensity = Vec3::new(3.0, 2.0, 1.0);
    let lights = [Vec3::new(1.5, 2.5, 1.0), Vec3::new(-2.0, 1.1, 0.3), Vec3::new(0.3, 3.0, -2.5)];
    for mesh in convex_meshes() {
        for &lp in &lights {
            let scene = prepared(mesh.clone(), vec![Light::Point { position: lp, intensity }]);
            // Crease angle 0: every position of a curved mesh has several solver vertices.
            let copies =
                scene.position_id.iter().filter(|&&p| scene.position_id.iter().filter(|&&q| q == p).count() > 1);
            assert!(copies.count() > scene.vertex_count() / 2, "{}: the mesh is split", mesh.name);
            let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
            let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
            for tracer in [&bvh as &dyn Tracer, &kd] {
                let ll = LightLinks::compute(&scene, tracer, &LightLinkParams::default());
                let e = ll.direct(&scene.lights, scene.vertex_count());
                let mut facing = 0;
                for (v, &ev) in e.iter().enumerate() {
                    let d = lp - scene.positions[v];
                    let cos = scene.normals[v].dot(d) / d.length();
                    let expect = if cos > 0.0 { intensity * cos / d.length_squared() } else { Vec3::ZERO };
                    facing += (cos > 0.0) as usize;
                    let tol = 1e-5 * expect.max_element();
                    assert!(
                        (ev - expect).abs().max_element() <= tol,
                        "{} ({}), light {lp}: vertex {v} (cos {cos}) reads {ev}, expected {expect}",
                        mesh.name,
                        tracer.name()
                    );
                }
                // At least a whole face of the cube, a third of a sphere.
                assert!(facing * 7 > scene.vertex_count(), "{}: {facing} vertices face the light", mesh.name);
            }
        }
    }
}

/// No link ray of a convex flat-shaded mesh meets the mesh: no hit at a
/// distance of zero on a neighbouring face, nor anywhere else (and no ray
/// dives under its own face, whose normal is the vertex's).
#[test]
fn flat_shaded_convex_link_rays_never_meet_the_mesh() {
    for mesh in convex_meshes() {
        let scene = prepared(mesh.clone(), vec![]);
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
        let setup = RaySetup::new(&scene, &LinkParams { rays_per_vertex: 64, ..Default::default() });
        let mut out = Vec::new();
        let mut rays = 0;
        for v in 0..scene.vertex_count() {
            setup.trace_vertex(&bvh, v, &mut out);
            rays += out.len();
            for r in &out {
                assert_eq!(r.tri, HIT_MISS, "{}: a ray of vertex {v} met triangle {} at t = {}", mesh.name, r.tri, r.t);
            }
        }
        assert_eq!(rays, 64 * scene.vertex_count());
    }
}

/// At the concave creases of a closed one-mesh room the other copies'
/// faces stay in the way: a sun outside lights no vertex inside (skipping
/// every copy of a position would light the floor's copies along the
/// wall between it and the sun), and link rays of crease vertices do meet
/// the wall's copies next to them (with every copy skipped they would
/// pass the wall and leave the room).
#[test]
fn copies_at_concave_creases_stay_in_the_way() {
    let mut desc = builtin::closed_room(10, 0.5);
    // Through the +x wall and down onto the floor.
    desc.lights = vec![Light::Directional { direction: Vec3::new(-1.0, -1.0, 0.3), irradiance: Vec3::ONE }];
    let scene = prep::prepare(&desc).unwrap();
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
    let ll = LightLinks::compute(&scene, &bvh, &LightLinkParams::default());
    let e = ll.direct(&scene.lights, scene.vertex_count());
    let facing = (0..scene.vertex_count()).filter(|&v| scene.normals[v].dot(Vec3::new(1.0, 1.0, -0.3)) > 0.0).count();
    assert!(facing > 100, "{facing} vertices face the sun");
    let lit: Vec<usize> = (0..scene.vertex_count()).filter(|&v| e[v] != Vec3::ZERO).collect();
    assert!(lit.is_empty(), "the sun outside lights vertices {lit:?}");

    let setup = RaySetup::new(&scene, &LinkParams { rays_per_vertex: 64, ..Default::default() });
    let (mut out, mut on_copies) = (Vec::new(), 0);
    for v in 0..scene.vertex_count() {
        setup.trace_vertex(&bvh, v, &mut out);
        let p = scene.position_id[v];
        for r in out.iter().filter(|r| r.tri != HIT_MISS) {
            let t = scene.triangles[(r.tri & !HIT_BACK) as usize];
            on_copies += (!t.contains(&(v as u32)) && t.iter().any(|&c| scene.position_id[c as usize] == p)) as usize;
        }
    }
    // About 17% of the room's rays (measured: 32263 of 185856 at 256 rays a vertex).
    assert!(on_copies * 10 > 64 * scene.vertex_count(), "{on_copies} rays met another copy's face");
}
