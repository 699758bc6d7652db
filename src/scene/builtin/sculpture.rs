//! The `sculpture`: a large (2, 3) torus-knot tube floating in a room.

use super::{camera, point, room, scene};
use crate::scene::shapes::MeshBuilder;
use crate::scene::SceneDesc;
use glam::Vec3;
use std::f32::consts::TAU;

pub(super) fn sculpture() -> SceneDesc {
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
