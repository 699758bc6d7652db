//! A second analytic case: two parallel unit squares 1 m apart. The lower
//! square A (albedo rho_A, facing up) is lit uniformly by a directional light
//! at 42 degrees that cannot reach the upper square B (facing down, albedo 0,
//! lit only from the back, which brings nothing). After one bounce B's
//! vertices receive `E_i(x) = rho_A * E_A * F(x -> A)`, with the
//! point-to-parallel-rectangle form factor of the handbook (Howell's
//! catalogue, case B-3) summed over the four rectangles cornered under x:
//! `F = 1/(2 pi) [X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))]`,
//! `X = a/h, Y = b/h`. Stated tolerance: 2% on the mean ratio over B's
//! vertices, 15% per vertex (1024 rays, no smoothing).

mod common;

use glam::Vec3;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{Bounces, Light, SceneDesc, Settings};
use std::f64::consts::PI;

fn corner_ff(a: f64, b: f64, h: f64) -> f64 {
    if a <= 0.0 || b <= 0.0 {
        return 0.0;
    }
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * PI)
}

/// Form factor from a point at (px, pz), distance h, to the square [0,1]^2.
fn point_to_square(px: f64, pz: f64, h: f64) -> f64 {
    corner_ff(px, pz, h) + corner_ff(1.0 - px, pz, h) + corner_ff(px, 1.0 - pz, h) + corner_ff(1.0 - px, 1.0 - pz, h)
}

#[test]
fn parallel_squares_match_the_analytic_form_factor() {
    let rho_a = 0.6f32;
    let mut a = MeshBuilder::new();
    let ma = a.add_material("A", Vec3::splat(rho_a));
    // Facing up: edge_u x edge_v = +y.
    a.quad_grid(Vec3::new(0.0, 0.0, 1.0), Vec3::X, Vec3::new(0.0, 0.0, -1.0), 16, 16, ma);
    let mut b = MeshBuilder::new();
    let mb = b.add_material("B", Vec3::ZERO);
    // Facing down.
    b.quad_grid(Vec3::new(0.0, 1.0, 0.0), Vec3::X, Vec3::Z, 12, 12, mb);
    // 42 degrees rather than 45: at 45 the shadow rays of A's vertices on
    // x = 1 would graze B's edge x = 0 exactly (a tie the tracer counts as
    // blocked, and `E_d` is the point value at the vertex); tilted, the
    // light passes beside B and A is lit uniformly, corners and edges too.
    let dir = Vec3::new(1.0, -0.9, 0.0).normalize();
    let e0 = 2.0f32;
    let desc = SceneDesc {
        name: "squares".into(),
        settings: Settings {
            rays_per_vertex: 1024,
            bounces: Bounces::Fixed(1),
            smoothing_angle_deg: 0.0,
            seed: 5,
            ..Default::default()
        },
        camera: None,
        meshes: vec![a.finish("A", 30.0), b.finish("B", 30.0)],
        lights: vec![Light::Directional { direction: dir, irradiance: Vec3::splat(e0) }],
        sky: None,
        warnings: vec![],
        notes: vec![],
    };
    let (solver, sol) = common::solve(&desc);
    let s = &solver.scene();
    let e_a = e0 * (-dir).dot(Vec3::Y);
    let b_range = s.meshes[1].vertices.clone();
    // A is lit uniformly (the light passes beside B), B not at all.
    for v in s.meshes[0].vertices.clone() {
        let p = s.positions[v as usize];
        assert!((sol.e_direct[v as usize].x - e_a).abs() < 1e-5 * e_a, "A at {p}: {}", sol.e_direct[v as usize]);
    }
    let (mut sum_ratio, mut count, mut worst) = (0.0f64, 0usize, 0.0f64);
    for v in b_range {
        let v = v as usize;
        assert_eq!(sol.e_direct[v], Vec3::ZERO);
        let p = s.positions[v];
        let expect = rho_a as f64 * e_a as f64 * point_to_square(p.x as f64, 1.0 - p.z as f64, 1.0);
        let ratio = sol.e_indirect[v].x as f64 / expect;
        sum_ratio += ratio;
        count += 1;
        worst = worst.max((ratio - 1.0).abs());
    }
    let mean = sum_ratio / count as f64;
    eprintln!("parallel squares: mean ratio {mean:.4}, worst per-vertex {worst:.4} over {count} vertices");
    assert!((mean - 1.0).abs() < 0.02, "mean ratio {mean}");
    assert!(worst < 0.15, "worst per-vertex error {worst}");
}
