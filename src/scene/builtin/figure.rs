//! The deformable figure (body, head, arms, legs, with a twist and a bend)
//! and its scenes: `torso` (the figure alone in a room) and `dancer` (the
//! figure in the furnished tearoom).

use super::tearoom::tearoom;
use super::{camera, point, room, scene, turn_z};
use crate::scene::shapes::MeshBuilder;
use crate::scene::{MeshDesc, SceneDesc};
use glam::Vec3;
use std::f32::consts::{PI, TAU};

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
    let mut twist = crate::scene::deform::Deform::new(crate::scene::deform::DeformKind::Twist, 40.0);
    twist.period_s = 4.0;
    twist.toward = Vec3::X;
    twist.center = at;
    let mut bend = crate::scene::deform::Deform::new(crate::scene::deform::DeformKind::Bend, 12.0);
    bend.center = Vec3::new(0.0, 0.6, 0.0) + at;
    bend.toward = Vec3::X;
    bend.period_s = 6.0;
    figure.deform = vec![twist, bend];
    figure
}

pub(super) fn torso() -> SceneDesc {
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

/// The deformable figure of `torso` standing in the furnished tearoom,
/// between the table and the corner, lit by the tearoom's lights (about
/// 17k vertices): the scene of selective updates, where most of the
/// room's rays never meet the figure.
pub(super) fn dancer() -> SceneDesc {
    let mut s = tearoom();
    s.name = "dancer".into();
    s.meshes.push(figure("dancer/figure", Vec3::new(1.4, 0.0, -1.1)));
    s.camera = Some(camera(Vec3::new(-0.9, 1.6, 2.0), Vec3::new(0.7, 0.95, -0.7), 60.0));
    s
}
