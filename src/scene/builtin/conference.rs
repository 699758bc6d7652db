//! The `conference` hall: rows of tables with chairs, a lectern and six
//! ceiling lights, with the table and chair shapes and their layout.

use super::{camera, point, post, room, scene, standing, turn_y, Slab};
use crate::scene::shapes::{divisions, MeshBuilder};
use crate::scene::SceneDesc;
use glam::{Vec2, Vec3};

/// Seat of a chair standing on `at` (not turned): 0.44 x 0.44 m, from 0.43
/// to 0.47 m.
pub(super) fn chair_seat(at: Vec3) -> Slab {
    Slab::centred(at, Vec2::splat(0.22), 0.43, 0.47)
}

/// A chair facing -z (its back at +z), standing on `at` and turned `deg`
/// about y: a seat, a back standing on the seat (open at its bottom), and
/// four legs from the floor to the seat's underside (open at both ends).
/// The back and the legs keep their corners off the seat's grid, so no
/// vertex of one part coincides with one of another.
fn chair(b: &mut MeshBuilder, at: Vec3, deg: f32, mat: u32) {
    let first = b.positions.len();
    let seat = chair_seat(Vec3::ZERO);
    b.cuboid_faces(
        Vec3::new(seat.min_xz.x, seat.bottom, seat.min_xz.y),
        Vec3::new(seat.max_xz.x, seat.top, seat.max_xz.y),
        [6, 1, 6],
        [mat; 6],
        false,
    );
    b.cuboid_open(Vec3::new(-0.21, seat.top, 0.17), Vec3::new(0.21, 0.92, 0.21), [6, 6, 1], standing(mat), false);
    for (x, z) in [(-0.19f32, -0.19f32), (0.19, -0.19), (-0.19, 0.19), (0.19, 0.19)] {
        b.cuboid_open(
            Vec3::new(x - 0.015, 0.0, z - 0.015),
            Vec3::new(x + 0.015, seat.bottom, z + 0.015),
            [1, 6, 1],
            post(mat),
            false,
        );
    }
    b.transform_from(first, turn_y(deg, at));
}

/// Top of a conference table standing on `at`: 1.8 x 0.6 m, 3 cm thick,
/// top at 0.75 m.
pub(super) fn table_top(at: Vec3) -> Slab {
    Slab::centred(at, Vec2::new(0.9, 0.3), 0.72, 0.75)
}

/// A conference table standing on `at`: the top, and four legs from the
/// floor to its underside (open at both ends), their corners off the top's
/// 7.5 cm grid.
fn table(b: &mut MeshBuilder, at: Vec3, mat: u32) {
    let first = b.positions.len();
    let top = table_top(Vec3::ZERO);
    b.cuboid_faces(
        Vec3::new(top.min_xz.x, top.bottom, top.min_xz.y),
        Vec3::new(top.max_xz.x, top.top, top.max_xz.y),
        [24, 1, 8],
        [mat; 6],
        false,
    );
    for (x, z) in [(-0.845f32, -0.245f32), (0.845, -0.245), (-0.845, 0.245), (0.845, 0.245)] {
        b.cuboid_open(
            Vec3::new(x - 0.025, 0.0, z - 0.025),
            Vec3::new(x + 0.025, top.bottom, z + 0.025),
            [1, 9, 1],
            post(mat),
            false,
        );
    }
    b.transform_from(first, move |p| p + at);
}

/// Where the conference hall's tables and chairs stand (on the floor, none
/// turned): eight rows of eight tables in two blocks, three chairs per table.
pub(super) fn conference_layout() -> (Vec<Vec3>, Vec<Vec3>) {
    let (mut tables, mut chairs) = (Vec::new(), Vec::new());
    for row in 0..8 {
        let z = -5.0 + 1.4 * row as f32;
        for block in [-1.0f32, 1.0] {
            for k in 0..4 {
                let x = block * (1.9 + 1.9 * k as f32);
                tables.push(Vec3::new(x, 0.0, z));
                for s in [-0.6f32, 0.0, 0.6] {
                    chairs.push(Vec3::new(x + s, 0.0, z + 0.55));
                }
            }
        }
    }
    (tables, chairs)
}

pub(super) fn conference() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::new(0.7, 0.68, 0.62));
    let carpet = r.add_material("carpet", Vec3::new(0.3, 0.32, 0.4));
    let ceiling = r.add_material("ceiling", Vec3::splat(0.8));
    let front = r.add_material("front wall", Vec3::new(0.55, 0.6, 0.7));
    let (min, max) = (Vec3::new(-9.0, 0.0, -7.0), Vec3::new(9.0, 3.5, 7.0));
    room(&mut r, min, max, divisions(max - min, 0.17), [wall, wall, carpet, ceiling, front, wall]);

    let mut t = MeshBuilder::new();
    let wood = t.add_material("table", Vec3::new(0.55, 0.42, 0.3));
    let mut c = MeshBuilder::new();
    let seat = c.add_material("chair", Vec3::new(0.2, 0.25, 0.5));
    let (tables, chairs) = conference_layout();
    for &at in &tables {
        table(&mut t, at, wood);
    }
    for &at in &chairs {
        chair(&mut c, at, 0.0, seat);
    }
    // Lectern at the front, facing the rows, standing on the floor.
    let (lo, hi) = (Vec3::new(-0.35, 0.0, -6.4), Vec3::new(0.35, 1.1, -5.9));
    t.cuboid_open(lo, hi, divisions(hi - lo, 0.05), standing(wood), false);

    let mut lights = Vec::new();
    for x in [-6.0f32, 0.0, 6.0] {
        for z in [-3.5f32, 3.5] {
            lights.push(point(Vec3::new(x, 3.3, z), Vec3::splat(15.0)));
        }
    }
    scene(
        "conference",
        camera(Vec3::new(0.0, 1.7, 6.5), Vec3::new(0.0, 1.0, 0.0), 60.0),
        vec![
            r.finish("conference/room", 30.0),
            t.finish("conference/tables", 30.0),
            c.finish("conference/chairs", 30.0),
        ],
        lights,
    )
}
