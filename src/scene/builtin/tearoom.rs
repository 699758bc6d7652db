//! The `tearoom`: a warm room with a table carrying a teapot, cups on
//! saucers and bowls, and the tableware shapes it is built from.

use super::{arc, camera, point, post, room, scene, stand_up, turn_z, Slab};
use crate::scene::shapes::MeshBuilder;
use crate::scene::SceneDesc;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};

/// A cup on its saucer, one surface of revolution standing on `base` (open
/// at the bottom, where the saucer rests on the table): the saucer's rim and
/// top, then the cup's outer wall, rim ring, inner wall and inner bottom;
/// `rings` bands on each wall. The saucer carries `saucer_mat`, the cup `mat`.
#[allow(clippy::too_many_arguments)]
fn cup_on_saucer(
    b: &mut MeshBuilder,
    base: Vec3,
    saucer: (f32, f32),
    radius: f32,
    height: f32,
    thickness: f32,
    segments: u32,
    rings: u32,
    saucer_mat: u32,
    mat: u32,
) {
    let (sr, sh) = saucer;
    let inner = radius - thickness;
    let mut p = vec![Vec2::new(sr, 0.0), Vec2::new(sr, sh), Vec2::new((sr + radius) * 0.5, sh)];
    let saucer_bands = p.len();
    for k in 0..=rings {
        p.push(Vec2::new(radius, sh + height * k as f32 / rings as f32));
    }
    for k in (0..=rings).rev() {
        p.push(Vec2::new(inner, sh + thickness + (height - thickness) * k as f32 / rings as f32));
    }
    p.push(Vec2::new(inner * 0.5, sh + thickness));
    p.push(Vec2::new(0.0, sh + thickness));
    b.revolve_with(base, &p, segments, |k| if k < saucer_bands { saucer_mat } else { mat }, false);
}

/// A bowl standing on `base`: a hemispherical shell of outer `radius` and
/// `thickness` whose outer surface is cut flat 3 mm above its lowest point,
/// where it rests (open there); the rim is `radius - 0.003` above `base`.
/// `rings` bands per wall.
fn bowl_on(b: &mut MeshBuilder, base: Vec3, radius: f32, thickness: f32, segments: u32, rings: u32, mat: u32) {
    let rim = radius - 0.003;
    let inner = radius - thickness;
    let a0 = (rim / radius).acos();
    let mut p = arc(0.0, rim, radius, radius, a0, FRAC_PI_2, rings);
    p[0].y = 0.0;
    let mut inside = arc(0.0, rim, inner, inner, FRAC_PI_2, 0.0, rings);
    *inside.last_mut().unwrap() = Vec2::new(0.0, rim - inner);
    p.extend(inside);
    b.revolve(base, &p, segments, mat, false);
}

/// Torus handle standing upright (in the plane containing the y axis at
/// angle `deg` about y), centred at `center`.
#[allow(clippy::too_many_arguments)]
fn handle(b: &mut MeshBuilder, center: Vec3, deg: f32, major: f32, minor: f32, nu: u32, nv: u32, mat: u32) {
    let first = b.positions.len();
    b.torus(Vec3::ZERO, major, minor, nu, nv, mat);
    b.transform_from(first, stand_up(deg, center));
}

/// The tearoom's table top: 1.4 x 0.9 m, 4 cm thick, top at 0.75 m.
pub(super) fn tearoom_table() -> Slab {
    Slab::centred(Vec3::ZERO, Vec2::new(0.7, 0.45), 0.71, 0.75)
}

pub(super) fn tearoom() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::new(0.75, 0.62, 0.48));
    let floor = r.add_material("floor", Vec3::new(0.45, 0.28, 0.16));
    let ceiling = r.add_material("ceiling", Vec3::new(0.8, 0.75, 0.68));
    let accent = r.add_material("red wall", Vec3::new(0.6, 0.25, 0.18));
    room(
        &mut r,
        Vec3::new(-2.5, 0.0, -2.5),
        Vec3::new(2.5, 2.6, 2.5),
        [24, 13, 24],
        [wall, wall, floor, ceiling, accent, wall],
    );

    // Table: the top, and four legs from the floor to its underside, open
    // at both ends. Leg corners stay off the top's 5 cm grid, so no leg
    // vertex coincides with one of the top.
    let mut t = MeshBuilder::new();
    let wood = t.add_material("table", Vec3::new(0.5, 0.3, 0.15));
    let slab = tearoom_table();
    let top_y = slab.top;
    t.cuboid_spaced(
        Vec3::new(slab.min_xz.x, slab.bottom, slab.min_xz.y),
        Vec3::new(slab.max_xz.x, slab.top, slab.max_xz.y),
        0.05,
        wood,
        false,
    );
    for (x, z) in [(-0.615f32, -0.365f32), (0.615, -0.365), (-0.615, 0.365), (0.615, 0.365)] {
        t.cuboid_open(
            Vec3::new(x - 0.03, 0.0, z - 0.03),
            Vec3::new(x + 0.03, slab.bottom, z + 0.03),
            [2, 12, 2],
            post(wood),
            false,
        );
    }

    // Everything on the table stands exactly on its top (y = top_y) and is
    // open at the bottom there.
    let mut w = MeshBuilder::new();
    let china = w.add_material("china", Vec3::new(0.82, 0.78, 0.7));
    let glaze = w.add_material("glaze", Vec3::new(0.7, 0.35, 0.15));
    let green = w.add_material("green glaze", Vec3::new(0.35, 0.5, 0.3));
    // Teapot: a squashed sphere (semi-axes 0.125 and 0.1 m) cut flat where
    // it stands, with the lid knob on the same surface of revolution; a
    // handle and a spout reach into it.
    let (ra, rc, h) = (0.125f32, 0.1f32, 0.092f32);
    let neck = 0.012f32;
    let mut profile = arc(0.0, h, ra, rc, (h / rc).acos(), PI - (neck / ra).asin(), 20);
    profile[0].y = 0.0;
    let (knob_y, knob_r) = (h + rc + 0.015, 0.018f32);
    let mut knob = arc(0.0, knob_y, knob_r, knob_r, (neck / knob_r).asin(), PI, 6);
    *knob.last_mut().unwrap() = Vec2::new(0.0, knob_y + knob_r);
    profile.extend(knob);
    w.revolve(Vec3::new(0.0, top_y, 0.0), &profile, 32, glaze, false);
    let body_c = Vec3::new(0.0, top_y + h, 0.0);
    handle(&mut w, body_c + Vec3::new(-0.13, 0.0, 0.0), 0.0, 0.065, 0.014, 32, 10, glaze);
    // The spout's base lies inside the body: no cap there.
    let first = w.positions.len();
    w.cylinder_caps(Vec3::ZERO, 0.018, 0.15, 16, 10, glaze, false, true);
    w.transform_from(first, turn_z(-0.9, body_c + Vec3::new(0.06, -0.02, 0.0)));
    // Cups on saucers, with handles.
    let saucer = (0.075f32, 0.008f32);
    for (k, (x, z)) in [(-0.42f32, -0.22f32), (0.42, -0.22), (-0.42, 0.22), (0.42, 0.22)].into_iter().enumerate() {
        let base = Vec3::new(x, top_y, z);
        let mat = if k % 2 == 0 { china } else { green };
        cup_on_saucer(&mut w, base, saucer, 0.042, 0.08, 0.004, 32, 10, china, mat);
        let deg = if x < 0.0 { 180.0 } else { 0.0 };
        // The ring reaches into the cup's wall but not through it.
        handle(&mut w, base + Vec3::new(0.068 * x.signum(), saucer.1 + 0.044, 0.0), deg, 0.022, 0.006, 16, 8, mat);
    }
    // Bowls.
    for (x, z, rad) in [(0.0f32, 0.3f32, 0.09f32), (-0.2, -0.3, 0.07), (0.22, -0.3, 0.07)] {
        bowl_on(&mut w, Vec3::new(x, top_y, z), rad, 0.005, 36, 10, china);
    }

    scene(
        "tearoom",
        camera(Vec3::new(1.2, 1.5, 1.7), Vec3::new(0.0, 0.8, 0.0), 55.0),
        vec![r.finish("tearoom/room", 30.0), t.finish("tearoom/table", 30.0), w.finish("tearoom/tableware", 60.0)],
        vec![
            point(Vec3::new(0.3, 2.3, 0.2), Vec3::new(3.0, 2.7, 2.2)),
            point(Vec3::new(-1.8, 1.9, 1.6), Vec3::new(1.2, 1.0, 0.8)),
        ],
    )
}
