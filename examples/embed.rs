//! Embedding linkgi synchronously: a room built in code from buffers, a
//! solve, the irradiance read on the caller's own vertices, a light moved
//! and the result read again. Prints what it computes.
//!
//! Run: `cargo run --release --example embed`

use glam::Vec3;
use linkgi::{prepare, Light, MeshInput, SceneBuilder, SolveParams, Solver};

/// An n x n grid of quads from `origin` along `u` and `v` (front: u x v)
/// as position and index buffers, as an engine would hold them.
fn grid(origin: Vec3, u: Vec3, v: Vec3, n: u32) -> (Vec<Vec3>, Vec<u32>) {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push(origin + u * (i as f32 / n as f32) + v * (j as f32 / n as f32));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (positions, indices)
}

fn main() -> linkgi::Result<()> {
    // A floor (white) and a red back wall, 3 m, in the caller's buffers.
    let (floor_p, floor_i) = grid(Vec3::new(-1.5, 0.0, 1.5), Vec3::X * 3.0, Vec3::Z * -3.0, 12);
    let (wall_p, wall_i) = grid(Vec3::new(-1.5, 0.0, -1.5), Vec3::X * 3.0, Vec3::Y * 3.0, 12);
    let lamp = |z: f32| Light::Point { position: Vec3::new(0.0, 1.2, z), intensity: Vec3::splat(5.0) };
    let scene = SceneBuilder::new("corner")
        .mesh(MeshInput::new("floor", &floor_p, &floor_i).albedo(Vec3::splat(0.7)))
        .mesh(MeshInput::new("wall", &wall_p, &wall_i).albedo(Vec3::new(0.7, 0.1, 0.1)))
        .light(lamp(1.0))
        .build()?;
    let mut solver = Solver::new(prepare(&scene)?, SolveParams::from_settings(&scene.settings), &|_, _| {})?;
    // The floor's vertex nearest the wall's foot, in the caller's numbering.
    let probe = (0..floor_p.len())
        .min_by(|&a, &b| floor_p[a].z.total_cmp(&floor_p[b].z).then(floor_p[a].x.abs().total_cmp(&floor_p[b].x.abs())))
        .unwrap();
    for (label, z) in [("light 1 m from the wall", 1.0), ("light 0.3 m from the wall", -1.2)] {
        solver.set_lights(vec![lamp(z)]);
        let s = solver.solve();
        let indirect = solver.scene().on_input(0, &s.e_indirect)[probe].expect("used");
        let direct = solver.scene().on_input(0, &s.e_direct)[probe].expect("used");
        println!(
            "{label}: floor vertex {probe} at {}: direct {:.3} W/m^2, indirect {:.3} {:.3} {:.3} W/m^2 (red from the wall)",
            floor_p[probe], direct.x, indirect.x, indirect.y, indirect.z
        );
    }
    Ok(())
}
