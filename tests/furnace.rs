//! The sphere furnace: inside a closed sphere of radius R with uniform
//! albedo rho and a point light of intensity I anywhere inside, every
//! point-to-area form factor is dA / (4 pi R^2), so each bounce is uniform
//! and `E_i = rho / (1 - rho) * I / R^2` everywhere.
//!
//! The tessellated sphere has slightly less area than the true one; its
//! effective radius `sqrt(A / 4 pi)` is used for R (0.2% smaller at 2562
//! vertices).

mod common;

use glam::Vec3;
use linkgi::scene::{builtin, Bounces};

/// Returns (mean relative error, max per-vertex relative error) of smoothed E_i.
fn furnace_error(rho: f32, light: Vec3, intensity: f32, bounces: Bounces) -> (f32, f32, u32) {
    let desc = common::with_settings(builtin::furnace(rho, 4, light, intensity), 256, bounces, 30.0);
    let (solver, sol) = common::solve(&desc);
    let r2 = common::mesh_area(&solver.scene()) / (4.0 * std::f32::consts::PI);
    let expect = rho / (1.0 - rho) * intensity / r2;
    let mut max_err = 0f32;
    for e in &sol.e_indirect {
        // Grey: all channels equal.
        assert!((e.x - e.y).abs() <= 1e-6 * e.x.max(1e-30) && (e.x - e.z).abs() <= 1e-6 * e.x.max(1e-30));
        max_err = max_err.max((e.x / expect - 1.0).abs());
    }
    let mean = common::mean(&sol.e_indirect).x;
    let st = solver.links().stats;
    assert!(st.misses as f64 <= 1e-5 * st.rays as f64, "{} of {} rays escaped the closed sphere", st.misses, st.rays);
    ((mean / expect - 1.0).abs(), max_err, sol.gather.bounces)
}

#[test]
fn furnace_moderate_albedo() {
    for rho in [0.5, 0.9] {
        for light in [Vec3::ZERO, Vec3::new(0.3, -0.2, 0.1), Vec3::new(-0.5, 0.4, 0.3)] {
            let (mean, max, bounces) = furnace_error(rho, light, 1.0, Bounces::Auto);
            eprintln!("rho {rho} light {light}: mean err {mean:.4}, max err {max:.4}, {bounces} bounces");
            assert!(mean < 0.02, "rho {rho}, light {light}: mean error {mean}");
            assert!(max < 0.05, "rho {rho}, light {light}: per-vertex error {max}");
        }
    }
}

#[test]
fn furnace_stiff_albedo_auto_bounces() {
    let (mean, max, bounces) = furnace_error(0.99, Vec3::new(0.3, -0.2, 0.1), 1.0, Bounces::Auto);
    eprintln!("rho 0.99: mean err {mean:.4}, max err {max:.4}, {bounces} bounces");
    assert!(mean < 0.02 && max < 0.05, "rho 0.99: mean {mean}, max {max}");
}

#[test]
fn fixed_bounces_truncate_the_series() {
    // With b bounces the sum is rho (1 - rho^b) / (1 - rho): a known shortfall.
    let rho = 0.5f32;
    let desc = common::with_settings(builtin::furnace(rho, 3, Vec3::ZERO, 2.0), 64, Bounces::Fixed(3), 30.0);
    let (solver, sol) = common::solve(&desc);
    let r2 = common::mesh_area(&solver.scene()) / (4.0 * std::f32::consts::PI);
    let expect = rho * (1.0 - rho.powi(3)) / (1.0 - rho) * 2.0 / r2;
    let mean = common::mean(&sol.e_indirect).x;
    assert!((mean / expect - 1.0).abs() < 0.02, "mean {mean} expected {expect}");
    assert!(!sol.gather.tail_added && sol.gather.tail_relative > 0.05);
}
