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

mod conference;
mod figure;
mod lamp;
mod rooms;
mod sculpture;
mod tearoom;
#[cfg(test)]
mod tests;

pub use rooms::furnace;
#[cfg(any(test, feature = "internals"))]
pub use rooms::closed_room;

use conference::conference;
use figure::{dancer, torso};
use lamp::{colorlamp, window};
use rooms::cornell;
use sculpture::sculpture;
use tearoom::tearoom;

use super::shapes::MeshBuilder;
use super::{Camera, Light, MeshDesc, SceneDesc, Settings};
use glam::{Vec2, Vec3};

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
        camera: Some(camera),
        meshes,
        lights,
        sky: None,
        warnings: Vec::new(),
        notes: Vec::new(),
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
