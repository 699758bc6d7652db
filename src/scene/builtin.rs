//! Built-in scenes, generated in code (deterministic: the same scene every call).
//!
//! Units are metres, y up. Every room but `window`'s is a closed box whose
//! faces point inward, so no ray leaves the scene; cameras stand inside the rooms; all
//! albedos are below 0.9. Furniture and figures are separate meshes from the
//! room. No face lies hidden against, or buried in, another surface (as in
//! the original Cornell box data): what stands on the floor, a table top or
//! a seat stands exactly on it and has no bottom face there; legs run from
//! the floor to the underside of their top, open at both ends; ends that
//! reach inside another part (the figure's legs and neck, the spout) have
//! no cap. Such meshes are open there but consistently wound. Pieces of one
//! mesh never share a position, so the exact-position weld of mesh
//! preparation never joins unrelated surfaces; where they interpenetrate
//! (handles, spout, limbs) the buried ends lie strictly inside the other
//! piece. Vertex counts below are unique positions (after welding exact
//! positions).
//!
//! - `cornell`: the Cornell box as a closed 2 m room (x, z in [-1, 1], y in
//!   [0, 2]), red wall at x = -1, green wall at x = +1, white elsewhere; a
//!   short and a tall box turned about y on the floor; a point light of
//!   intensity 4 W/sr near the ceiling at (0, 1.85, 0). About 3000 vertices.
//! - `furnace`: the white-furnace test, [`furnace`]`(0.5, 4, (0.3, -0.2, 0.1),
//!   1.0)`: the inside of a closed unit icosphere (2562 vertices) of grey
//!   albedo 0.5 lit by one point light.
//! - `colorlamp`: a 4 x 2.5 x 4 m room with a pale blue wall and a floor
//!   lamp: base disc and thin stand (one surface of revolution), a low
//!   cabinet, and an orange conical shade with inner and
//!   outer surfaces (a thin closed shell, open at top and bottom) around a
//!   point light, so the room is lit mostly by light bounced off the shade.
//!   About 1600 vertices (the paper's COLORLAMP).
//! - `window`: `colorlamp`'s room with a 2 x 1.25 m window in the +x wall
//!   onto a gradient sky (zenith (4.0, 5.2, 7.2), horizon (4.4, 4.4, 4.2),
//!   ground (1.0, 0.9, 0.7) W/(m^2 sr)), the cabinet, and the lamp whose
//!   shade glows (exitance (30, 17, 4) W/m^2) with no point light: the
//!   scene of emitters and sky light, solved with `auto` bounces (3 leave
//!   `E_i` 11% short here). The only built-in scene that is not closed.
//! - `torso`: a figure (superellipsoid body, sphere head, neck, cylinder arms
//!   and legs, separate pieces in one *dynamic* mesh) standing in a
//!   4 x 2.8 x 4 m room, two point lights. About 7100 vertices (TORSO).
//! - `tearoom`: a warm-coloured 5 x 2.6 x 5 m room with a table (top and four
//!   legs) carrying a teapot (squashed sphere cut flat at its foot, with its
//!   knob, a torus handle and a spout), cups with handles on saucers, and
//!   bowls, all standing exactly on the table top; two point lights. About 11900
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
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// Names accepted by [`builtin`].
pub const NAMES: &[&str] =
    &["cornell", "furnace", "colorlamp", "window", "torso", "tearoom", "dancer", "sculpture", "conference"];

/// The built-in scene of this name, if there is one.
pub fn builtin(name: &str) -> Option<SceneDesc> {
    Some(match name {
        "cornell" => cornell(),
        "furnace" => furnace(0.5, 4, Vec3::new(0.3, -0.2, 0.1), 1.0),
        "colorlamp" => colorlamp(),
        "window" => window(),
        "torso" => torso(),
        "tearoom" => tearoom(),
        "dancer" => dancer(),
        "sculpture" => sculpture(),
        "conference" => conference(),
        _ => return None,
    })
}

fn scene(name: &str, camera: Camera, meshes: Vec<MeshDesc>, lights: Vec<Light>) -> SceneDesc {
    SceneDesc {
        name: name.to_string(),
        settings: Settings::default(),
        camera,
        meshes,
        lights,
        sky: None,
        warnings: Vec::new(),
    }
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

/// Face materials (ordered -x, +x, -y, +y, -z, +z) of a box standing on
/// the floor or a table: `mat` everywhere but the hidden bottom (-y), which
/// is left out.
fn standing(mat: u32) -> [Option<u32>; 6] {
    [Some(mat), Some(mat), None, Some(mat), Some(mat), Some(mat)]
}

/// Face materials of a post from the floor to the underside of a top (a
/// table or chair leg): the four sides only, open at both ends.
fn post(mat: u32) -> [Option<u32>; 6] {
    [Some(mat), Some(mat), None, None, Some(mat), Some(mat)]
}

/// Points `(r0 + rr sin a, y0 - ry cos a)` for `a` in `n` equal steps from
/// `a0` to `a1` (a = 0 is the bottom of the ellipse, a = pi its top):
/// an elliptic arc of a revolution profile, walked upward.
fn arc(r0: f32, y0: f32, rr: f32, ry: f32, a0: f32, a1: f32, n: u32) -> Vec<Vec2> {
    (0..=n)
        .map(|k| {
            let a = a0 + (a1 - a0) * (k as f32 / n as f32);
            Vec2::new(r0 + rr * a.sin(), y0 - ry * a.cos())
        })
        .collect()
}

/// A horizontal slab that other parts stand on or end at (a table top, a
/// seat): heights of its underside and top, and its footprint in x and z.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Slab {
    bottom: f32,
    top: f32,
    min_xz: Vec2,
    max_xz: Vec2,
}

impl Slab {
    /// A slab centred on `at` (x, z) with half extents `half` (x, z).
    fn centred(at: Vec3, half: Vec2, bottom: f32, top: f32) -> Slab {
        let c = Vec2::new(at.x, at.z);
        Slab { bottom, top, min_xz: c - half, max_xz: c + half }
    }
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
fn window() -> SceneDesc {
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

/// Signed power `sign(x) |x|^e`.
fn spow(x: f32, e: f32) -> f32 {
    x.signum() * x.abs().powf(e)
}

/// The deformable figure of `torso` and `dancer` (body, head, arms, legs;
/// about 5k vertices) standing on the floor at `at`, with its deformers: a
/// twist about its vertical axis (40 deg/m, 4 s) and a bend above the hips
/// (12 deg/m, 6 s) toward +x.
fn figure(name: &str, at: Vec3) -> MeshDesc {
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
    // The neck's ends lie inside the body and the head: no caps.
    b.cylinder_caps(Vec3::new(0.0, 1.50, 0.0), 0.045, 0.14, 16, 6, skin, false, false);
    // Arms hang from the shoulders, splayed a little.
    for side in [-1.0f32, 1.0] {
        let first = b.positions.len();
        b.cylinder(Vec3::new(0.0, -0.66, 0.0), 0.05, 0.66, 24, 16, cloth, true);
        b.transform_from(first, turn_z(0.2 * side, Vec3::new(0.2 * side, 1.46, 0.0)));
        // Hand.
        let hand = turn_z(0.2 * side, Vec3::new(0.2 * side, 1.46, 0.0))(Vec3::new(0.0, -0.7, 0.0));
        b.icosphere(hand, 0.055, 2, skin, false);
    }
    // Legs from the floor into the hips, open at both ends: the bottom
    // stands on the floor, the top lies inside the body (about 3 mm clear of
    // its surface).
    for side in [-1.0f32, 1.0] {
        b.cylinder_caps(Vec3::new(0.085 * side, 0.0, 0.0), 0.07, 1.1, 24, 22, trousers, false, false);
    }
    if at != Vec3::ZERO {
        b.transform_from(0, |p| p + at);
    }
    let mut figure = b.finish(name, 60.0);
    figure.dynamic = true;
    // The figure twists about its vertical axis and sways a little.
    let mut twist = super::deform::Deform::new(super::deform::DeformKind::Twist, 40.0);
    twist.period_s = 4.0;
    twist.toward = Vec3::X;
    twist.center = at;
    let mut bend = super::deform::Deform::new(super::deform::DeformKind::Bend, 12.0);
    bend.center = Vec3::new(0.0, 0.6, 0.0) + at;
    bend.toward = Vec3::X;
    bend.period_s = 6.0;
    figure.deform = vec![twist, bend];
    figure
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

    let figure = figure("torso/figure", Vec3::ZERO);

    scene(
        "torso",
        camera(Vec3::new(0.5, 1.35, 1.85), Vec3::new(0.0, 0.95, 0.0), 62.0),
        vec![r.finish("torso/room", 30.0), figure],
        vec![
            point(Vec3::new(1.2, 2.4, 1.1), Vec3::splat(3.0)),
            point(Vec3::new(-1.4, 2.2, -0.9), Vec3::new(1.4, 1.5, 1.9)),
        ],
    )
}

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
fn tearoom_table() -> Slab {
    Slab::centred(Vec3::ZERO, Vec2::new(0.7, 0.45), 0.71, 0.75)
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

/// The deformable figure of `torso` standing in the furnished tearoom,
/// between the table and the corner, lit by the tearoom's lights (about
/// 17k vertices): the scene of selective updates, where most of the
/// room's rays never meet the figure.
fn dancer() -> SceneDesc {
    let mut s = tearoom();
    s.name = "dancer".into();
    s.meshes.push(figure("dancer/figure", Vec3::new(1.4, 0.0, -1.1)));
    s.camera = camera(Vec3::new(-0.9, 1.6, 2.0), Vec3::new(0.7, 0.95, -0.7), 60.0);
    s
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

/// Seat of a chair standing on `at` (not turned): 0.44 x 0.44 m, from 0.43
/// to 0.47 m.
fn chair_seat(at: Vec3) -> Slab {
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
fn table_top(at: Vec3) -> Slab {
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
fn conference_layout() -> (Vec<Vec3>, Vec<Vec3>) {
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

/// The slabs (table tops, seats) that parts of the built-in scene `name`
/// stand on or end at, for tests.
#[cfg(test)]
fn supports(name: &str) -> Vec<Slab> {
    match name {
        "tearoom" | "dancer" => vec![tearoom_table()],
        "conference" => {
            let (tables, chairs) = conference_layout();
            tables.into_iter().map(table_top).chain(chairs.into_iter().map(chair_seat)).collect()
        }
        _ => Vec::new(),
    }
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
            let emits = s.meshes.iter().any(|m| m.materials.iter().any(|mat| mat.emission != Vec3::ZERO));
            assert!(!s.lights.is_empty() || emits || s.sky.is_some(), "{name}: no light, emitter or sky");
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
            ("dancer", 16900),
            ("sculpture", 76500),
            ("conference", 122800),
        ];
        for (name, target) in targets {
            let n = unique_positions(&builtin(name).unwrap()) as f64;
            assert!((n / target as f64 - 1.0).abs() < 0.15, "{name}: {n} unique positions, target {target}");
        }
    }

    /// Welded position ids of a mesh's vertices (exact-position weld).
    fn weld(m: &MeshDesc) -> Vec<u32> {
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        m.positions
            .iter()
            .map(|&p| {
                let n = ids.len() as u32;
                *ids.entry(key(p)).or_insert(n)
            })
            .collect()
    }

    fn find(parent: &mut HashMap<u32, u32>, x: u32) -> u32 {
        let mut r = x;
        while let Some(&p) = parent.get(&r) {
            if p == r {
                break;
            }
            r = p;
        }
        parent.insert(x, r);
        r
    }

    fn union(parent: &mut HashMap<u32, u32>, a: u32, b: u32) {
        parent.entry(a).or_insert(a);
        parent.entry(b).or_insert(b);
        let (ra, rb) = (find(parent, a), find(parent, b));
        parent.insert(ra.max(rb), ra.min(rb));
    }

    /// Every mesh is consistently wound once exact positions are welded
    /// (each edge used at most once in each direction); rooms are closed
    /// (each edge used exactly once in each direction). Faces hidden
    /// against a support are left out, so other meshes may be open: their
    /// signed volume, with every border loop closed by a flat fan, is
    /// negative for rooms (facing inward) and positive for everything else.
    #[test]
    fn meshes_are_consistently_wound_and_rooms_closed() {
        for &name in NAMES {
            let s = builtin(name).unwrap();
            for (k, m) in s.meshes.iter().enumerate() {
                let remap = weld(m);
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
                let bad = edges.values().filter(|&&(f, b)| f > 1 || b > 1).count();
                assert_eq!(bad, 0, "{}: {bad} edges used twice in one direction", m.name);
                let room = k == 0;
                let border: Vec<(u32, u32)> = edges
                    .iter()
                    .filter(|(_, &(f, b))| f + b == 1)
                    .map(|(&(lo, hi), &(f, _))| if f == 1 { (lo, hi) } else { (hi, lo) })
                    .collect();
                if room && s.sky.is_none() {
                    assert!(border.is_empty(), "{}: room has {} border edges", m.name, border.len());
                }
                if room && name == "window" {
                    // The window: 5 x 8 cells of 0.25 m.
                    assert_eq!(border.len(), 2 * (5 + 8), "{}: the window's border", m.name);
                }
                // Close each border loop (they are planar) by a fan from one of its vertices.
                let mut pos = vec![Vec3::ZERO; remap.len()];
                for (i, &w) in remap.iter().enumerate() {
                    pos[w as usize] = m.positions[i];
                }
                let mut parent = HashMap::new();
                for &(a, b) in &border {
                    union(&mut parent, a, b);
                }
                for &(a, b) in &border {
                    let apex = pos[find(&mut parent, a) as usize].as_dvec3();
                    let (pa, pb) = (pos[a as usize].as_dvec3(), pos[b as usize].as_dvec3());
                    volume += apex.dot(pb.cross(pa)) / 6.0;
                }
                assert!((volume < 0.0) == room, "{}: signed volume {volume}", m.name);
            }
        }
    }

    /// No two parts of a mesh share a vertex: around every welded position
    /// the incident triangles form one fan (connected through shared edges).
    #[test]
    fn parts_share_no_vertex() {
        for &name in NAMES {
            let s = builtin(name).unwrap();
            for m in &s.meshes {
                let remap = weld(m);
                // For every welded vertex, join the other two corners of each incident triangle.
                let mut links: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
                for t in &m.triangles {
                    let w = t.map(|i| remap[i as usize]);
                    for e in 0..3 {
                        links.entry(w[e]).or_default().push((w[(e + 1) % 3], w[(e + 2) % 3]));
                    }
                }
                for (v, link) in &links {
                    let mut parent = HashMap::new();
                    for &(a, b) in link {
                        union(&mut parent, a, b);
                    }
                    let root = find(&mut parent, link[0].0);
                    assert!(
                        link.iter().all(|&(a, _)| find(&mut parent, a) == root),
                        "{}: vertex {v} joins separate fans",
                        m.name
                    );
                }
            }
        }
    }

    /// Nothing is hidden in contact with, or buried in, what it stands on:
    /// no vertex of a non-room mesh lies below the floor, and no face lies
    /// on the floor facing down. Likewise for table tops and seats: no face
    /// lies on a top facing down or on an underside facing up (a buried leg
    /// top) inside the footprint, and no vertex lies strictly inside a slab
    /// unless it belongs to the slab's own box.
    #[test]
    fn nothing_hidden_on_supports() {
        const EPS: f32 = 1e-5;
        for &name in NAMES {
            let s = builtin(name).unwrap();
            let floor = s.meshes[0].positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
            let slabs = supports(name);
            if matches!(name, "tearoom" | "dancer" | "conference") {
                assert!(!slabs.is_empty(), "{name}: no supports");
            }
            let on = |y: f32, h: f32| (y - h).abs() <= EPS;
            let inside = |sl: &Slab, x: f32, z: f32, margin: f32| {
                x > sl.min_xz.x + margin
                    && x < sl.max_xz.x - margin
                    && z > sl.min_xz.y + margin
                    && z < sl.max_xz.y - margin
            };
            for m in &s.meshes[1..] {
                for p in &m.positions {
                    assert!(p.y >= floor, "{}: vertex {p} below the floor", m.name);
                }
                for t in &m.triangles {
                    let [a, b, c] = t.map(|i| m.positions[i as usize]);
                    let n = (b - a).cross(c - a);
                    let centre = (a + b + c) / 3.0;
                    let flat_at = |h: f32| on(a.y, h) && on(b.y, h) && on(c.y, h);
                    assert!(!(flat_at(floor) && n.y < 0.0), "{}: face {a} {b} {c} lies on the floor", m.name);
                    for sl in &slabs {
                        if !inside(sl, centre.x, centre.z, 0.0) {
                            continue;
                        }
                        assert!(!(flat_at(sl.top) && n.y < 0.0), "{}: face {a} {b} {c} lies on a top", m.name);
                        assert!(!(flat_at(sl.bottom) && n.y > 0.0), "{}: face {a} {b} {c} buried under a top", m.name);
                    }
                }
                // Vertices strictly inside a slab: only a slab's own sides
                // (on its footprint's border) may lie between its faces.
                for p in &m.positions {
                    for sl in &slabs {
                        let between = p.y > sl.bottom + EPS && p.y < sl.top - EPS;
                        assert!(!(between && inside(sl, p.x, p.z, EPS)), "{}: vertex {p} inside a slab", m.name);
                    }
                }
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
