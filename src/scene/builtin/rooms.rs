//! The plain closed scenes: [`closed_room`] (a grey box for tests), the
//! white-furnace sphere [`furnace`], and the Cornell box (`cornell`).

use super::{camera, point, room, scene, standing, turn_y};
use crate::scene::shapes::MeshBuilder;
use crate::scene::SceneDesc;
use glam::Vec3;

/// A closed white-grey room 2 x 2 x 2 m (x, z in [-1, 1], y in [0, 2]) with
/// inward faces, an `n x n` grid per face, albedo `albedo`, and one point
/// light of intensity 1 W/sr at (0.2, 1.5, 0.1).
#[cfg(any(test, feature = "internals"))]
pub fn closed_room(n: u32, albedo: f32) -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(albedo));
    b.cuboid(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), n, m, true);
    scene(
        "closed_room",
        camera(Vec3::new(0.0, 1.3, 0.98), Vec3::new(0.0, 0.55, -0.2), 80.0),
        vec![b.finish("closed_room/room", 30.0)],
        vec![point(Vec3::new(0.2, 1.5, 0.1), Vec3::ONE)],
    )
}

/// The inside of a closed icosphere of radius 1 at the origin (faces
/// inward, `10 * 4^subdivisions + 2` vertices), one grey material of
/// `albedo`, one point light of `intensity` W/sr (all channels) at
/// `light_position`. With no escape, the exact irradiance is known in
/// closed form, which makes it a test of energy conservation.
pub fn furnace(albedo: f32, subdivisions: u32, light_position: Vec3, intensity: f32) -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(albedo));
    b.icosphere(Vec3::ZERO, 1.0, subdivisions, m, true);
    scene(
        "furnace",
        camera(Vec3::new(0.0, 0.0, 0.8), Vec3::ZERO, 60.0),
        vec![b.finish("furnace/sphere", 60.0)],
        vec![point(light_position, Vec3::splat(intensity))],
    )
}

pub(super) fn cornell() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let white = r.add_material("white", Vec3::splat(0.73));
    let red = r.add_material("red", Vec3::new(0.63, 0.065, 0.05));
    let green = r.add_material("green", Vec3::new(0.14, 0.45, 0.09));
    room(
        &mut r,
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(1.0, 2.0, 1.0),
        [20; 3],
        [red, green, white, white, white, white],
    );

    let mut b = MeshBuilder::new();
    let w = b.add_material("white", Vec3::splat(0.73));
    // Short box, front right, turned -17 degrees.
    let first = b.positions.len();
    b.cuboid_open(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 0.6, 0.3), [6; 3], standing(w), false);
    b.transform_from(first, turn_y(-17.0, Vec3::new(0.35, 0.0, 0.25)));
    // Tall box, back left, turned 17 degrees.
    let first = b.positions.len();
    b.cuboid_open(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 1.2, 0.3), [6, 12, 6], standing(w), false);
    b.transform_from(first, turn_y(17.0, Vec3::new(-0.35, 0.0, -0.35)));

    scene(
        "cornell",
        // Against the front wall, looking down a little with a wide lens: the
        // whole box from the ceiling (and the light under it) to the floor
        // between the boxes, red wall left, green wall right.
        camera(Vec3::new(0.0, 1.55, 0.99), Vec3::new(0.0, 0.6, -1.0), 95.0),
        vec![r.finish("cornell/room", 30.0), b.finish("cornell/boxes", 30.0)],
        vec![point(Vec3::new(0.0, 1.85, 0.0), Vec3::splat(4.0))],
    )
}
