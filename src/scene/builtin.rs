//! Built-in scenes, generated in code (deterministic: the same scene every call).
//!
//! Units are metres, y up. Every room is a closed box whose faces point
//! inward, so no ray leaves the scene; cameras stand inside the rooms; all
//! albedos are below 0.9. Furniture and figures are separate meshes from the
//! room, and pieces of one mesh overlap rather than touch, so the
//! exact-position weld of mesh preparation never joins unrelated surfaces.
//! Vertex counts below are unique positions (after welding exact positions).
//!
//! - `cornell`: the Cornell box as a closed 2 m room (x, z in [-1, 1], y in
//!   [0, 2]), red wall at x = -1, green wall at x = +1, white elsewhere; a
//!   short and a tall box turned about y on the floor; a point light of
//!   intensity 4 W/sr near the ceiling at (0, 1.85, 0). About 3000 vertices.
//! - `furnace`: the white-furnace test, [`furnace`]`(0.5, 4, (0.3, -0.2, 0.1),
//!   1.0)`: the inside of a closed unit icosphere (2562 vertices) of grey
//!   albedo 0.5 lit by one point light.
//! - `colorlamp`: a 4 x 2.5 x 4 m room with a pale blue wall and a floor
//!   lamp: base disc, thin stand, and an orange conical shade with inner and
//!   outer surfaces (a thin closed shell, open at top and bottom) around a
//!   point light, so the room is lit mostly by light bounced off the shade.
//!   About 1600 vertices (the paper's COLORLAMP).
//! - `torso`: a figure (superellipsoid body, sphere head, neck, cylinder arms
//!   and legs, separate closed pieces in one *dynamic* mesh) standing in a
//!   4 x 2.8 x 4 m room, two point lights. About 7100 vertices (TORSO).
//! - `tearoom`: a warm-coloured 5 x 2.6 x 5 m room with a table (top and four
//!   legs) carrying a teapot (squashed sphere, torus handle, spout, knob),
//!   cups with handles on saucers, and bowls; two point lights. About 11900
//!   vertices (TEAROOM).
//! - `sculpture`: a large (2, 3) torus-knot tube floating in a 5 x 3 x 5 m
//!   room, two point lights. About 76500 vertices (the paper's IPHI
//!   sculpture).
//! - `conference`: an 18 x 3.5 x 14 m hall with eight rows of long tables
//!   (eight tables of 1.8 m per row, in two blocks) and three chairs per
//!   table (seat, back, four legs), a lectern, and six ceiling lights. About
//!   122800 vertices (CONFERENCE).
//!
//! [`closed_room`] is a plain closed grey room for tests.

use super::shapes::{divisions, MeshBuilder};
use super::{Camera, Light, MeshDesc, SceneDesc, Settings};
use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Names accepted by [`builtin`].
pub const NAMES: &[&str] = &["cornell", "furnace", "colorlamp", "torso", "tearoom", "sculpture", "conference"];

/// The built-in scene of this name, if there is one.
pub fn builtin(name: &str) -> Option<SceneDesc> {
    Some(match name {
        "cornell" => cornell(),
        "furnace" => furnace(0.5, 4, Vec3::new(0.3, -0.2, 0.1), 1.0),
        "colorlamp" => colorlamp(),
        "torso" => torso(),
        "tearoom" => tearoom(),
        "sculpture" => sculpture(),
        "conference" => conference(),
        _ => return None,
    })
}

fn scene(name: &str, camera: Camera, meshes: Vec<MeshDesc>, lights: Vec<Light>) -> SceneDesc {
    SceneDesc { name: name.to_string(), settings: Settings::default(), camera, meshes, lights, warnings: Vec::new() }
}

fn point(position: Vec3, intensity: Vec3) -> Light {
    Light::Point { position, intensity }
}

fn camera(position: Vec3, target: Vec3, fov_deg: f32) -> Camera {
    Camera { position, target, fov_deg }
}

/// Rotation about +y by `deg` degrees (counter-clockwise seen from above),
/// then translation; y is left bit-exact.
fn turn_y(deg: f32, offset: Vec3) -> impl Fn(Vec3) -> Vec3 {
    let (s, c) = deg.to_radians().sin_cos();
    move |p: Vec3| Vec3::new(c * p.x + s * p.z, p.y, -s * p.x + c * p.z) + offset
}

/// Rotation about +z by `rad` radians, then translation.
fn turn_z(rad: f32, offset: Vec3) -> impl Fn(Vec3) -> Vec3 {
    let (s, c) = rad.sin_cos();
    move |p: Vec3| Vec3::new(c * p.x - s * p.y, s * p.x + c * p.y, p.z) + offset
}

/// Rotation about +x by 90 degrees (the xz plane becomes the xy plane),
/// then rotation about y by `deg`, then translation.
fn stand_up(deg: f32, offset: Vec3) -> impl Fn(Vec3) -> Vec3 {
    let turn = turn_y(deg, offset);
    move |p: Vec3| turn(Vec3::new(p.x, -p.z, p.y))
}

/// A closed room with inward faces and materials ordered -x, +x, -y
/// (floor), +y (ceiling), -z, +z.
fn room(b: &mut MeshBuilder, min: Vec3, max: Vec3, res: [u32; 3], mats: [u32; 6]) {
    b.cuboid_faces(min, max, res, mats, true);
}

/// A closed white-grey room 2 x 2 x 2 m (x, z in [-1, 1], y in [0, 2]) with
/// inward faces, an `n x n` grid per face, albedo `albedo`, and one point
/// light of intensity 1 W/sr at (0.2, 1.5, 0.1).
pub fn closed_room(n: u32, albedo: f32) -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(albedo));
    b.cuboid(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), n, m, true);
    scene(
        "closed_room",
        camera(Vec3::new(0.0, 1.0, 0.95), Vec3::new(0.0, 1.0, 0.0), 60.0),
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

fn cornell() -> SceneDesc {
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
    b.cuboid(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 0.6, 0.3), 6, w, false);
    b.transform_from(first, turn_y(-17.0, Vec3::new(0.35, 0.0, 0.25)));
    // Tall box, back left, turned 17 degrees.
    let first = b.positions.len();
    b.cuboid_faces(Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 1.2, 0.3), [6, 12, 6], [w; 6], false);
    b.transform_from(first, turn_y(17.0, Vec3::new(-0.35, 0.0, -0.35)));

    scene(
        "cornell",
        camera(Vec3::new(0.0, 1.0, 0.95), Vec3::new(0.0, 1.0, 0.0), 60.0),
        vec![r.finish("cornell/room", 30.0), b.finish("cornell/boxes", 30.0)],
        vec![point(Vec3::new(0.0, 1.85, 0.0), Vec3::splat(4.0))],
    )
}

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

fn colorlamp() -> SceneDesc {
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
    let mut l = MeshBuilder::new();
    let metal = l.add_material("metal", Vec3::new(0.3, 0.3, 0.32));
    let orange = l.add_material("shade", Vec3::new(0.8, 0.45, 0.1));
    l.cylinder(lamp_at, 0.18, 0.03, 24, 1, metal, true);
    l.cylinder(lamp_at + Vec3::new(0.0, 0.02, 0.0), 0.015, 1.36, 10, 14, metal, true);
    shade(&mut l, lamp_at + Vec3::new(0.0, 1.32, 0.0), 0.26, 0.15, 0.3, 0.006, 36, 5, orange);

    // A low cabinet against the far wall catches the lamp's light.
    let mut f = MeshBuilder::new();
    let wood = f.add_material("wood", Vec3::new(0.5, 0.32, 0.18));
    f.cuboid_spaced(Vec3::new(0.2, 0.0, -1.95), Vec3::new(1.4, 0.6, -1.5), 0.15, wood, false);

    scene(
        "colorlamp",
        camera(Vec3::new(1.6, 1.4, 1.7), Vec3::new(-0.6, 0.9, -0.7), 60.0),
        vec![r.finish("colorlamp/room", 30.0), l.finish("colorlamp/lamp", 50.0), f.finish("colorlamp/cabinet", 30.0)],
        vec![point(lamp_at + Vec3::new(0.0, 1.47, 0.0), Vec3::new(2.5, 2.3, 2.0))],
    )
}

/// Signed power `sign(x) |x|^e`.
fn spow(x: f32, e: f32) -> f32 {
    x.signum() * x.abs().powf(e)
}

fn torso() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::new(0.7, 0.7, 0.68));
    let floor = r.add_material("floor", Vec3::new(0.45, 0.45, 0.5));
    room(
        &mut r,
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 2.8, 2.0),
        [20, 14, 20],
        [wall, wall, floor, wall, wall, wall],
    );

    let mut b = MeshBuilder::new();
    let skin = b.add_material("skin", Vec3::new(0.75, 0.55, 0.45));
    let cloth = b.add_material("cloth", Vec3::new(0.2, 0.35, 0.6));
    let trousers = b.add_material("trousers", Vec3::new(0.25, 0.22, 0.2));

    // Body: a superellipsoid-like capsule from y = 0.82 to 1.56, wider at
    // hips and shoulders than at the waist.
    let (y0, y1) = (0.82f32, 1.56f32);
    let (yc, hh) = ((y0 + y1) / 2.0, (y1 - y0) / 2.0);
    b.parametric(
        56,
        32,
        |u, v| {
            if v == 0.0 {
                return Vec3::new(0.0, y0, 0.0);
            }
            if v == 1.0 {
                return Vec3::new(0.0, y1, 0.0);
            }
            let (sp, cp) = (PI * v).sin_cos();
            let y = yc - hh * cp;
            let s = sp.powf(0.6);
            let waist = (-((v - 0.45) / 0.18).powi(2)).exp();
            let shoulders = (-((v - 0.82) / 0.12).powi(2)).exp();
            let rx = 0.19 - 0.03 * waist + 0.04 * shoulders;
            let rz = 0.12 - 0.015 * waist + 0.01 * shoulders;
            let (st, ct) = (TAU * u).sin_cos();
            Vec3::new(rx * s * spow(ct, 0.7), y, -rz * s * spow(st, 0.7))
        },
        true,
        false,
        cloth,
    );
    // Head and neck.
    b.icosphere(Vec3::new(0.0, 1.70, 0.0), 0.11, 3, skin, false);
    b.cylinder(Vec3::new(0.0, 1.50, 0.0), 0.045, 0.14, 16, 6, skin, true);
    // Arms hang from the shoulders, splayed a little.
    for side in [-1.0f32, 1.0] {
        let first = b.positions.len();
        b.cylinder(Vec3::new(0.0, -0.66, 0.0), 0.05, 0.66, 24, 16, cloth, true);
        b.transform_from(first, turn_z(0.2 * side, Vec3::new(0.2 * side, 1.46, 0.0)));
        // Hand.
        let hand = turn_z(0.2 * side, Vec3::new(0.2 * side, 1.46, 0.0))(Vec3::new(0.0, -0.7, 0.0));
        b.icosphere(hand, 0.055, 2, skin, false);
    }
    // Legs from the floor into the hips.
    for side in [-1.0f32, 1.0] {
        b.cylinder(Vec3::new(0.085 * side, 0.0, 0.0), 0.07, 1.0, 24, 20, trousers, true);
    }
    let mut figure = b.finish("torso/figure", 60.0);
    figure.dynamic = true;

    scene(
        "torso",
        camera(Vec3::new(0.4, 1.4, 1.8), Vec3::new(0.0, 1.1, 0.0), 60.0),
        vec![r.finish("torso/room", 30.0), figure],
        vec![
            point(Vec3::new(1.2, 2.4, 1.1), Vec3::splat(3.0)),
            point(Vec3::new(-1.4, 2.2, -0.9), Vec3::new(1.4, 1.5, 1.9)),
        ],
    )
}

/// A closed cup standing on `base`: outer wall and bottom, a rim ring, the
/// inner wall and inner bottom; `rings` bands on each wall.
#[allow(clippy::too_many_arguments)]
fn cup(b: &mut MeshBuilder, base: Vec3, radius: f32, height: f32, thickness: f32, segments: u32, rings: u32, mat: u32) {
    let inner = radius - thickness;
    let mut p = vec![Vec2::new(0.0, 0.0), Vec2::new(radius * 0.5, 0.0)];
    for k in 0..=rings {
        p.push(Vec2::new(radius, height * k as f32 / rings as f32));
    }
    for k in (0..=rings).rev() {
        p.push(Vec2::new(inner, thickness + (height - thickness) * k as f32 / rings as f32));
    }
    p.push(Vec2::new(inner * 0.5, thickness));
    p.push(Vec2::new(0.0, thickness));
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

fn tearoom() -> SceneDesc {
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

    // Table: top 1.4 x 0.9 m at 0.75 m, legs reaching 1 cm into the top.
    let mut t = MeshBuilder::new();
    let wood = t.add_material("table", Vec3::new(0.5, 0.3, 0.15));
    let top_y = 0.75f32;
    t.cuboid_spaced(Vec3::new(-0.7, top_y - 0.04, -0.45), Vec3::new(0.7, top_y, 0.45), 0.05, wood, false);
    for (x, z) in [(-0.62f32, -0.37f32), (0.62, -0.37), (-0.62, 0.37), (0.62, 0.37)] {
        t.cuboid_faces(
            Vec3::new(x - 0.03, 0.0, z - 0.03),
            Vec3::new(x + 0.03, top_y - 0.03, z + 0.03),
            [2, 12, 2],
            [wood; 6],
            false,
        );
    }

    let mut w = MeshBuilder::new();
    let china = w.add_material("china", Vec3::new(0.82, 0.78, 0.7));
    let glaze = w.add_material("glaze", Vec3::new(0.7, 0.35, 0.15));
    let green = w.add_material("green glaze", Vec3::new(0.35, 0.5, 0.3));
    let sink = 0.003; // objects sit 3 mm into the table top.
                      // Teapot: squashed sphere, lid knob, handle, spout.
    let body_c = Vec3::new(0.0, top_y + 0.1 - sink, 0.0);
    let first = w.positions.len();
    w.icosphere(Vec3::ZERO, 0.125, 3, glaze, false);
    w.transform_from(first, |p| Vec3::new(p.x, p.y * 0.8, p.z) + body_c);
    w.icosphere(body_c + Vec3::new(0.0, 0.105, 0.0), 0.022, 2, glaze, false);
    handle(&mut w, body_c + Vec3::new(-0.13, 0.0, 0.0), 0.0, 0.065, 0.014, 32, 10, glaze);
    let first = w.positions.len();
    w.cylinder(Vec3::ZERO, 0.018, 0.15, 16, 10, glaze, true);
    w.transform_from(first, turn_z(-0.9, body_c + Vec3::new(0.06, -0.02, 0.0)));
    // Cups with handles on saucers.
    for (k, (x, z)) in [(-0.42f32, -0.22f32), (0.42, -0.22), (-0.42, 0.22), (0.42, 0.22)].into_iter().enumerate() {
        let base = Vec3::new(x, top_y - sink, z);
        let mat = if k % 2 == 0 { china } else { green };
        w.cylinder(base, 0.075, 0.008 + sink, 32, 1, china, true);
        cup(&mut w, base + Vec3::new(0.0, 0.006, 0.0), 0.042, 0.08, 0.004, 32, 10, mat);
        let deg = if x < 0.0 { 180.0 } else { 0.0 };
        // The ring reaches into the cup's wall but not through it.
        handle(&mut w, base + Vec3::new(0.068 * x.signum(), 0.05, 0.0), deg, 0.022, 0.006, 16, 8, mat);
    }
    // Bowls.
    for (x, z, rad) in [(0.0f32, 0.3f32, 0.09f32), (-0.2, -0.3, 0.07), (0.22, -0.3, 0.07)] {
        w.bowl(Vec3::new(x, top_y + rad - sink, z), rad, 0.005, 36, 10, china);
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

fn sculpture() -> SceneDesc {
    let mut r = MeshBuilder::new();
    let wall = r.add_material("wall", Vec3::splat(0.72));
    let floor = r.add_material("floor", Vec3::new(0.4, 0.38, 0.36));
    let warm = r.add_material("warm wall", Vec3::new(0.75, 0.55, 0.35));
    room(
        &mut r,
        Vec3::new(-2.5, 0.0, -2.5),
        Vec3::new(2.5, 3.0, 2.5),
        [30, 18, 30],
        [warm, wall, floor, wall, wall, wall],
    );

    // A (2, 3) torus knot: centre line C(phi) = ((R + a cos 3phi) cos 2phi,
    // a sin 3phi, (R + a cos 3phi) sin 2phi), a tube of radius `tube` around it.
    let mut b = MeshBuilder::new();
    let stone = b.add_material("stone", Vec3::new(0.7, 0.68, 0.62));
    let center = Vec3::new(0.0, 1.3, 0.0);
    let (big_r, a, tube) = (0.62f32, 0.3f32, 0.11f32);
    let curve = move |phi: f32| {
        let w = big_r + a * (3.0 * phi).cos();
        Vec3::new(w * (2.0 * phi).cos(), a * (3.0 * phi).sin(), w * (2.0 * phi).sin())
    };
    let tangent = move |phi: f32| {
        let (s3, c3) = (3.0 * phi).sin_cos();
        let (s2, c2) = (2.0 * phi).sin_cos();
        let w = big_r + a * c3;
        let dw = -3.0 * a * s3;
        Vec3::new(dw * c2 - 2.0 * w * s2, 3.0 * a * c3, dw * s2 + 2.0 * w * c2).normalize()
    };
    b.parametric(
        1210,
        60,
        |u, v| {
            let phi = TAU * u;
            let c = curve(phi);
            let t = tangent(phi);
            // Normal: away from the core circle, made orthogonal to t.
            let core = Vec3::new(big_r * (2.0 * phi).cos(), 0.0, big_r * (2.0 * phi).sin());
            let d = c - core;
            let n = (d - t * d.dot(t)).normalize();
            let bn = t.cross(n);
            // Angle runs so that d/du x d/dv faces out of the tube.
            let (s, co) = (TAU * v).sin_cos();
            center + c + (n * co - bn * s) * tube
        },
        true,
        true,
        stone,
    );

    scene(
        "sculpture",
        camera(Vec3::new(0.3, 1.5, 2.3), Vec3::new(0.0, 1.25, 0.0), 60.0),
        vec![r.finish("sculpture/room", 30.0), b.finish("sculpture/knot", 60.0)],
        vec![
            point(Vec3::new(1.5, 2.6, 1.2), Vec3::splat(4.0)),
            point(Vec3::new(-1.6, 2.3, -1.0), Vec3::new(2.0, 2.2, 2.6)),
        ],
    )
}

/// A chair facing -z (its back at +z), standing on `at` and turned `deg`
/// about y: seat, back and four legs, each a box overlapping the next.
fn chair(b: &mut MeshBuilder, at: Vec3, deg: f32, mat: u32) {
    let first = b.positions.len();
    b.cuboid_faces(Vec3::new(-0.22, 0.43, -0.22), Vec3::new(0.22, 0.47, 0.22), [6, 1, 6], [mat; 6], false);
    b.cuboid_faces(Vec3::new(-0.22, 0.45, 0.18), Vec3::new(0.22, 0.92, 0.22), [6, 6, 1], [mat; 6], false);
    for (x, z) in [(-0.19f32, -0.19f32), (0.19, -0.19), (-0.19, 0.19), (0.19, 0.19)] {
        b.cuboid_faces(
            Vec3::new(x - 0.015, 0.0, z - 0.015),
            Vec3::new(x + 0.015, 0.45, z + 0.015),
            [1, 6, 1],
            [mat; 6],
            false,
        );
    }
    b.transform_from(first, turn_y(deg, at));
}

/// A 1.8 x 0.6 m table, top at 0.75 m, standing on `at`.
fn table(b: &mut MeshBuilder, at: Vec3, mat: u32) {
    let first = b.positions.len();
    b.cuboid_faces(Vec3::new(-0.9, 0.72, -0.3), Vec3::new(0.9, 0.75, 0.3), [24, 1, 8], [mat; 6], false);
    for (x, z) in [(-0.85f32, -0.25f32), (0.85, -0.25), (-0.85, 0.25), (0.85, 0.25)] {
        b.cuboid_faces(
            Vec3::new(x - 0.025, 0.0, z - 0.025),
            Vec3::new(x + 0.025, 0.73, z + 0.025),
            [1, 9, 1],
            [mat; 6],
            false,
        );
    }
    b.transform_from(first, move |p| p + at);
}

fn conference() -> SceneDesc {
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
    for row in 0..8 {
        let z = -5.0 + 1.4 * row as f32;
        for block in [-1.0f32, 1.0] {
            for k in 0..4 {
                let x = block * (1.9 + 1.9 * k as f32);
                table(&mut t, Vec3::new(x, 0.0, z), wood);
                for s in [-0.6f32, 0.0, 0.6] {
                    chair(&mut c, Vec3::new(x + s, 0.0, z + 0.55), 0.0, seat);
                }
            }
        }
    }
    // Lectern at the front, facing the rows.
    t.cuboid_spaced(Vec3::new(-0.35, 0.0, -6.4), Vec3::new(0.35, 1.1, -5.9), 0.05, wood, false);

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

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn key(p: Vec3) -> [u32; 3] {
        [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
    }

    /// Unique positions per mesh (exact-position weld), summed.
    fn unique_positions(s: &SceneDesc) -> usize {
        s.meshes
            .iter()
            .map(|m| m.positions.iter().map(|&p| key(p)).collect::<std::collections::HashSet<_>>().len())
            .sum()
    }

    #[test]
    fn builtins_are_valid() {
        for &name in NAMES {
            let t0 = std::time::Instant::now();
            let s = builtin(name).expect(name);
            let dt = t0.elapsed();
            assert!(!s.lights.is_empty(), "{name}: no light");
            assert!(!s.meshes.is_empty(), "{name}: no mesh");
            let mut tris = 0;
            for m in &s.meshes {
                assert_eq!(m.triangles.len(), m.triangle_material.len(), "{}", m.name);
                assert!(m.positions.iter().all(|p| p.is_finite()), "{}: non-finite position", m.name);
                for (k, t) in m.triangles.iter().enumerate() {
                    assert!(
                        t.iter().all(|&i| (i as usize) < m.positions.len()),
                        "{}: triangle {k} out of range",
                        m.name
                    );
                    assert!((m.triangle_material[k] as usize) < m.materials.len(), "{}: material of {k}", m.name);
                    let [a, b, c] = t.map(|i| m.positions[i as usize]);
                    assert!((b - a).cross(c - a).length() > 0.0, "{}: triangle {k} has zero area", m.name);
                }
                for mat in &m.materials {
                    assert!(mat.albedo.max_element() < 0.9 && mat.albedo.min_element() >= 0.0, "{}", mat.name);
                }
                tris += m.triangles.len();
            }
            eprintln!(
                "{name:>11}: {:>7} unique positions, {:>7} triangles, {} meshes, {} lights, built in {:.1} ms",
                unique_positions(&s),
                tris,
                s.meshes.len(),
                s.lights.len(),
                dt.as_secs_f64() * 1e3
            );
            for m in &s.meshes {
                let n = m.positions.iter().map(|&p| key(p)).collect::<std::collections::HashSet<_>>().len();
                eprintln!("{:>30}: {n:>7} unique positions, {:>7} triangles", m.name, m.triangles.len());
            }
        }
    }

    #[test]
    fn builtins_are_deterministic() {
        for &name in NAMES {
            let (a, b) = (builtin(name).unwrap(), builtin(name).unwrap());
            assert_eq!(a.meshes.len(), b.meshes.len());
            for (ma, mb) in a.meshes.iter().zip(&b.meshes) {
                let bits =
                    |m: &MeshDesc| m.positions.iter().map(|&p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
                assert_eq!(bits(ma), bits(mb), "{name}");
                assert_eq!(ma.triangles, mb.triangles, "{name}");
            }
            assert_eq!(a.lights, b.lights);
        }
        assert!(builtin("nonesuch").is_none());
    }

    #[test]
    fn unique_positions_near_targets() {
        let targets = [
            ("cornell", 3000),
            ("furnace", 2562),
            ("colorlamp", 1600),
            ("torso", 7100),
            ("tearoom", 11900),
            ("sculpture", 76500),
            ("conference", 122800),
        ];
        for (name, target) in targets {
            let n = unique_positions(&builtin(name).unwrap()) as f64;
            assert!((n / target as f64 - 1.0).abs() < 0.15, "{name}: {n} unique positions, target {target}");
        }
    }

    /// Every mesh is closed and consistently wound once exact positions are
    /// welded (each edge used once in each direction), rooms face inward
    /// (negative signed volume) and everything else outward.
    #[test]
    fn meshes_are_closed_and_oriented() {
        for &name in NAMES {
            let s = builtin(name).unwrap();
            for (k, m) in s.meshes.iter().enumerate() {
                let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
                let remap: Vec<u32> = m
                    .positions
                    .iter()
                    .map(|&p| {
                        let n = ids.len() as u32;
                        *ids.entry(key(p)).or_insert(n)
                    })
                    .collect();
                let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
                let mut volume = 0.0f64;
                for t in &m.triangles {
                    for e in 0..3 {
                        let (a, b) = (remap[t[e] as usize], remap[t[(e + 1) % 3] as usize]);
                        let entry = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
                        if a < b {
                            entry.0 += 1;
                        } else {
                            entry.1 += 1;
                        }
                    }
                    let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
                    volume += a.dot(b.cross(c)) / 6.0;
                }
                let bad = edges.values().filter(|&&(f, b)| f != 1 || b != 1).count();
                assert_eq!(bad, 0, "{}: {bad} edges not shared by exactly two opposite triangles", m.name);
                let inward = k == 0;
                assert!((volume < 0.0) == inward, "{}: signed volume {volume}", m.name);
            }
        }
    }

    /// Every triangle of the room mesh faces the room's centre.
    fn assert_inward(m: &MeshDesc, centre: Vec3) {
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(centre - (a + b + c) / 3.0) > 0.0, "{}: triangle faces out", m.name);
        }
    }

    #[test]
    fn rooms_face_inward() {
        let centre = Vec3::new(0.0, 1.0, 0.0);
        assert_inward(&closed_room(8, 0.5).meshes[0], centre);
        let c = builtin("cornell").unwrap();
        assert_inward(&c.meshes[0], centre);
        let f = furnace(0.5, 2, Vec3::ZERO, 1.0);
        assert_inward(&f.meshes[0], Vec3::ZERO);
    }

    #[test]
    fn cameras_and_lights_inside_rooms() {
        for &name in NAMES.iter().filter(|&&n| n != "furnace") {
            let s = builtin(name).unwrap();
            let room = &s.meshes[0];
            let (lo, hi) =
                room.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
            let inside = |p: Vec3| p.cmpgt(lo).all() && p.cmplt(hi).all();
            assert!(inside(s.camera.position), "{name}: camera outside");
            for l in &s.lights {
                if let Light::Point { position, .. } = l {
                    assert!(inside(*position), "{name}: light outside");
                }
            }
        }
    }
}
