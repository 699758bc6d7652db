//! The a-priori contact splits (`scene::contact`): a coarse ground plane is
//! cut where geometry stands in it, graded (fine at the walls' feet, as
//! coarse as the uniform step far away), not where geometry only meets its
//! border or lies a millimetre over it; and a closed room standing on a
//! 200 m ground under a sky reads dark inside, where the uniform step alone
//! leaves the room's floor to be interpolated from corners out in the sky.

mod common;

use glam::Vec3;
use linkgi::scene::contact::{CONTACT_FLOOR, CONTACT_SHARE};
use linkgi::scene::refine::{self, RefineSettings};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{Bounces, MeshDesc, SceneDesc};
use linkgi::sky::Sky;
use linkgi::solver::adaptive;
use linkgi::solver::Compute;

/// A square ground of side `2 g` at y = 0, two triangles facing up.
fn ground(g: f32) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("ground", Vec3::splat(0.5));
    // u x v points up (+y).
    b.quad_grid(Vec3::new(-g, 0.0, -g), Vec3::new(0.0, 0.0, 2.0 * g), Vec3::new(2.0 * g, 0.0, 0.0), 1, 1, m);
    b.finish("ground", 30.0)
}

/// A closed box from `lo` to `hi` seen from inside (no bottom face: it
/// stands on the ground, which is its floor).
fn room(lo: Vec3, hi: Vec3) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("wall", Vec3::splat(0.7));
    b.cuboid_open(lo, hi, [1; 3], [Some(m), Some(m), None, Some(m), Some(m), Some(m)], true);
    b.finish("room", 30.0)
}

/// A vertical quad (a wall with no thickness) along x = `x`, `h` high.
fn wall(x: f32, g: f32, h: f32) -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("wall", Vec3::splat(0.7));
    b.quad_grid(Vec3::new(x, 0.0, -g), Vec3::new(0.0, 0.0, 2.0 * g), Vec3::new(0.0, h, 0.0), 1, 1, m);
    b.finish("wall", 30.0)
}

fn scene(meshes: Vec<MeshDesc>) -> SceneDesc {
    let sky = Sky::gradient(Vec3::new(4.0, 5.0, 7.0), Vec3::splat(4.0), Vec3::ZERO);
    let mut desc = common::scene_desc("contact", meshes, vec![], Some(sky), 64, Bounces::Auto);
    desc.settings.refine = RefineSettings::default();
    desc
}

/// The ground's triangles after the a-priori step, as world corners.
fn ground_triangles(desc: &SceneDesc) -> Vec<[Vec3; 3]> {
    let m = &desc.meshes[0];
    m.triangles.iter().map(|t| t.map(|i| m.positions[i as usize])).collect()
}

fn longest(t: &[Vec3; 3]) -> f32 {
    t[0].distance(t[1]).max(t[1].distance(t[2])).max(t[2].distance(t[0]))
}

/// A 200 m ground under a 10 x 8 m room of 3 m walls: every ground
/// triangle with corners on both sides of a wall is cut to half the
/// walls' height (or the floor of the rule); those far from the room keep
/// the uniform step's size; the whole ground stays a few thousand
/// triangles, not the ~35,000 a uniform 1.5 m cut would make.
#[test]
fn a_ground_plane_is_cut_where_walls_stand_and_stays_coarse_far_away() {
    let (lo, hi) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 3.0, 8.0));
    let desc = scene(vec![ground(100.0), room(lo, hi)]);
    let target = desc.settings.refine.target_edge(&desc);
    let (uniform, _) = refine::apriori(&desc, &RefineSettings { max_added: 0, ..Default::default() });
    assert_eq!(uniform.meshes[0].triangles.len(), 2, "no budget: nothing split");
    let (cut, stats) = refine::apriori(&desc, &desc.settings.refine);
    let tris = ground_triangles(&cut);
    let limit = (CONTACT_SHARE * 3.0).max(CONTACT_FLOOR * target) * 1.001;
    let inside = |p: Vec3| p.x > lo.x && p.x < hi.x && p.z > lo.z && p.z < hi.z;
    let outside = |p: Vec3| p.x < lo.x || p.x > hi.x || p.z < lo.z || p.z > hi.z;
    let mut crossing = 0;
    for t in &tris {
        if t.iter().any(|p| inside(*p)) && t.iter().any(|p| outside(*p)) {
            crossing += 1;
            assert!(longest(t) <= limit, "a triangle across a wall keeps {} m (limit {limit})", longest(t));
        }
        let c = (t[0] + t[1] + t[2]) / 3.0;
        if c.distance(Vec3::new(5.0, 0.0, 4.0)) > 60.0 {
            assert!(longest(t) > 0.5 * target, "far from the room: cut to {} m (target {target})", longest(t));
        }
    }
    assert!(crossing >= 20, "{crossing} triangles cross the walls");
    assert!(tris.len() < 5000, "graded: {} ground triangles", tris.len());
    assert!(stats[0].positions_after > stats[0].positions_before, "{:?}", stats[0]);
    // Deterministic: the same scene cuts alike.
    let (again, _) = refine::apriori(&desc, &desc.settings.refine);
    assert_eq!(again.meshes[0].positions, cut.meshes[0].positions);
}

/// A 1 m wall along the ground's border (where the ground ends) and a
/// tile lying 1 mm over it cut nothing beyond the uniform step; the same
/// wall standing across the ground's middle does.
#[test]
fn geometry_at_the_border_or_lying_flat_does_not_cut() {
    let g = 50.0;
    let mut tile = MeshBuilder::new();
    let m = tile.add_material("tile", Vec3::splat(0.5));
    tile.quad_grid(Vec3::new(-1.0, 0.001, -1.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(2.0, 0.0, 0.0), 1, 1, m);
    let tile = tile.finish("tile", 30.0);
    let count = |meshes: Vec<MeshDesc>| {
        let desc = scene(meshes);
        let target = desc.settings.refine.target_edge(&desc);
        let uniform =
            refine::refine_scene(&desc, &refine::RefineParams { max_edge: target, max_vertices: usize::MAX }).0;
        let (cut, _) = refine::apriori(&desc, &desc.settings.refine);
        (uniform.meshes[0].triangles.len(), cut.meshes[0].triangles.len())
    };
    let (uniform, cut) = count(vec![ground(g), wall(-g, g, 1.0), tile]);
    assert_eq!(cut, uniform, "a wall at the border and a tile lying flat cut nothing");
    let (uniform, cut) = count(vec![ground(g), wall(0.3, g, 1.0)]);
    assert!(cut > uniform + 10, "a wall across the middle cuts: {uniform} -> {cut}");
}

/// A closed room on a 200 m ground under a sky: the ground's vertices
/// inside the room read under 5% of the irradiance of the ground out in
/// the open (no light enters), where without the contact splits the room
/// holds no ground vertex at all and its floor reads the sky's light.
#[test]
fn a_closed_room_on_a_ground_plane_reads_dark_inside() {
    let (lo, hi) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 3.0, 8.0));
    let desc = scene(vec![ground(100.0), room(lo, hi)]);
    let r = adaptive::solve(&desc, &Compute::Cpu, &|_, _| {}).expect("solves");
    let s = r.solver.scene();
    let e = |v: usize| {
        let sol = &r.solution;
        let x = sol.e_direct[v] + sol.e_sky[v] + sol.e_indirect[v];
        assert!(x.is_finite() && x.min_element() >= 0.0, "{x}");
        x.element_sum() / 3.0
    };
    let (mut inside, mut open) = (Vec::new(), Vec::new());
    for (v, p) in s.positions.iter().enumerate() {
        if p.y.abs() > 1e-4 || s.normals[v].y < 0.9 {
            continue; // not the ground
        }
        if p.x > lo.x + 0.25 && p.x < hi.x - 0.25 && p.z > lo.z + 0.25 && p.z < hi.z - 0.25 {
            inside.push(e(v));
        } else if p.distance(Vec3::new(5.0, 0.0, 4.0)) > 30.0 {
            open.push(e(v));
        }
    }
    let mean = |x: &[f32]| x.iter().sum::<f32>() / x.len().max(1) as f32;
    assert!(inside.len() >= 4, "{} ground vertices inside the room", inside.len());
    assert!(!open.is_empty() && mean(&open) > 1.0, "open ground reads {}", mean(&open));
    assert!(mean(&inside) < 0.05 * mean(&open), "inside {} against the open ground's {}", mean(&inside), mean(&open));
}
