//! The lamp rooms: `colorlamp` (a room lit by light bounced off a lamp
//! shade) and `window` (the same room with a window onto a sky and a
//! glowing shade), with their shared floor lamp and cabinet.

use super::{camera, point, room, scene, standing};
use crate::scene::shapes::{divisions, MeshBuilder};
use crate::scene::{MeshDesc, SceneDesc};
use glam::{Vec2, Vec3};

/// A closed thin conical shell (lamp shade): outer surface facing out, inner
/// surface facing the axis, joined by flat rims; open at top and bottom.
#[allow(clippy::too_many_arguments)]
fn shade(
    b: &mut MeshBuilder,
    base: Vec3,
    r_bottom: f32,
    r_top: f32,
    height: f32,
    thickness: f32,
    segments: u32,
    rings: u32,
    mat: u32,
) {
    let mut profile = Vec::new();
    for k in 0..=rings {
        let t = k as f32 / rings as f32;
        let (r, y) = if k == rings { (r_top, height) } else { (r_bottom + (r_top - r_bottom) * t, height * t) };
        profile.push(Vec2::new(r, y));
    }
    for k in (0..=rings).rev() {
        let p = profile[k as usize];
        profile.push(Vec2::new(p.x - thickness, p.y));
    }
    b.revolve(base, &profile, segments, mat, true);
}

pub(super) fn colorlamp() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::splat(0.7));
    let blue = r.add_material("blue wall", Vec3::new(0.3, 0.4, 0.65));
    let floor = r.add_material("floor", Vec3::new(0.55, 0.4, 0.28));
    let ceiling = r.add_material("ceiling", Vec3::splat(0.8));
    room(
        &mut r,
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 2.5, 2.0),
        [12, 8, 12],
        [blue, wall, floor, ceiling, wall, wall],
    );

    let lamp_at = Vec3::new(-1.0, 0.0, -1.0);
    scene(
        "colorlamp",
        camera(Vec3::new(1.6, 1.4, 1.7), Vec3::new(-0.6, 0.9, -0.7), 60.0),
        vec![r.finish("colorlamp/room", 30.0), floor_lamp("colorlamp/lamp", lamp_at, Vec3::ZERO), cabinet("colorlamp")],
        vec![point(lamp_at + Vec3::new(0.0, 1.47, 0.0), Vec3::new(2.5, 2.3, 2.0))],
    )
}

/// The floor lamp of `colorlamp` and `window` standing at `at`: base disc
/// and stand, and the orange conical shade, whose material emits
/// `shade_emission` (W/m^2, both sides).
fn floor_lamp(name: &str, at: Vec3, shade_emission: Vec3) -> MeshDesc {
    let lamp_at = at;
    let mut l = MeshBuilder::new();
    let metal = l.add_material("metal", Vec3::new(0.3, 0.3, 0.32));
    let orange = l.add_material("shade", Vec3::new(0.8, 0.45, 0.1));
    l.materials[orange as usize].emission = shade_emission;
    // Base disc and stand as one surface of revolution, open at the bottom
    // where the base stands on the floor.
    let mut profile = vec![
        Vec2::new(0.18, 0.0),
        Vec2::new(0.18, 0.03),
        Vec2::new(0.135, 0.03),
        Vec2::new(0.09, 0.03),
        Vec2::new(0.045, 0.03),
    ];
    profile.extend((0..=14).map(|k| Vec2::new(0.015, if k == 14 { 1.38 } else { 0.03 + 1.35 * k as f32 / 14.0 })));
    profile.push(Vec2::new(0.0, 1.38));
    l.revolve(lamp_at, &profile, 16, metal, false);
    shade(&mut l, lamp_at + Vec3::new(0.0, 1.32, 0.0), 0.26, 0.15, 0.3, 0.006, 36, 5, orange);
    l.finish(name, 50.0)
}

/// The low cabinet against the far wall of `colorlamp` and `window`.
fn cabinet(scene: &str) -> MeshDesc {
    let mut f = MeshBuilder::new();
    let wood = f.add_material("wood", Vec3::new(0.5, 0.32, 0.18));
    let (lo, hi) = (Vec3::new(0.2, 0.0, -1.95), Vec3::new(1.4, 0.6, -1.5));
    f.cuboid_open(lo, hi, divisions(hi - lo, 0.15), standing(wood), false);
    f.finish(&format!("{scene}/cabinet"), 30.0)
}

/// `colorlamp`'s room with a window: a 2 x 1.25 m opening in the +x wall
/// (y in [0.75, 2], z in [-1, 1], a sky portal over it) onto a gradient sky, the cabinet, and
/// the floor lamp with its shade glowing (exitance (30, 17, 4) W/m^2 on
/// both sides) instead of a point light.
pub(super) fn window() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::splat(0.7));
    let blue = r.add_material("blue wall", Vec3::new(0.3, 0.4, 0.65));
    let floor = r.add_material("floor", Vec3::new(0.55, 0.4, 0.28));
    let ceiling = r.add_material("ceiling", Vec3::splat(0.8));
    // A 0.25 m grid (exact in binary); the +x face's cells are (y, z): the
    // window is cells y 3..8, z 4..12.
    r.cuboid_holed(
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 2.5, 2.0),
        [16, 10, 16],
        [Some(blue), Some(wall), Some(floor), Some(ceiling), Some(wall), Some(wall)],
        true,
        Some((1, [3, 8, 4, 12])),
    );
    let mut s = scene(
        "window",
        camera(Vec3::new(-1.7, 1.5, 1.8), Vec3::new(0.4, 0.9, -0.8), 70.0),
        vec![
            r.finish("window/room", 30.0),
            floor_lamp("window/lamp", Vec3::new(-1.0, 0.0, -1.0), Vec3::new(30.0, 17.0, 4.0)),
            cabinet("window"),
        ],
        vec![],
    );
    let mut sky =
        crate::sky::Sky::gradient(Vec3::new(4.0, 5.2, 7.2), Vec3::new(4.4, 4.4, 4.2), Vec3::new(1.0, 0.9, 0.7));
    // A portal over the opening: the room's rays toward it find the sky (`crate::sky::portal`).
    sky.portals.push(crate::sky::Portal {
        corner: Vec3::new(2.0, 0.75, -1.0),
        edge_u: Vec3::new(0.0, 1.25, 0.0),
        edge_v: Vec3::new(0.0, 0.0, 2.0),
    });
    s.sky = Some(sky);
    // Light walls and a source that is itself a surface: three bounces
    // leave E_i 11% short (`linkgi error window`), auto bounces 1%.
    s.settings.bounces = crate::scene::Bounces::Auto;
    s
}
