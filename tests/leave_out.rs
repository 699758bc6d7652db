//! Work a scene does not need is left out, observably: auto bounces stop as
//! soon as a bounce adds less than the tolerance, and smoothing is skipped
//! at a feature angle of 0.

mod common;

use glam::Vec3;
use linkgi::exchange::bounce::gather::{gather, gather_bounce, GatherParams};
use linkgi::scene::{builtin, Bounces};
use std::f32::consts::PI;

/// Auto bounces stop at the first bounce `b >= 2` whose total (over
/// vertices, per channel) is below `tolerance` of the running total;
/// recomputed here bounce by bounce with `gather_bounce`.
#[test]
fn auto_bounces_stop_at_the_tolerance() {
    for (rho, tol) in [(0.5f32, 1e-4f32), (0.8, 1e-3), (0.3, 1e-2)] {
        let desc = common::with_settings(builtin::closed_room(4, rho), 64, Bounces::Auto, 0.0);
        let (solver, sol) = common::solve(&desc);
        let params = GatherParams { bounces: Bounces::Auto, tolerance: tol, ..Default::default() };
        let result = gather(&solver.links(), &solver.scene().albedo, &sol.e_source, &params);
        // Manual: bounce until the newest adds less than tol of the running total.
        let n = sol.e_source.len();
        let mut b: Vec<Vec3> = sol.e_source.iter().zip(&solver.scene().albedo).map(|(e, r)| *e * *r / PI).collect();
        let mut e = vec![Vec3::ZERO; n];
        let mut running = 0f64;
        let mut expected = 0;
        let mut newest_rel = Vec::new();
        for bounce in 1..=200u32 {
            gather_bounce(&solver.links(), &b, &mut e);
            let t: f64 = e.iter().map(|v| v.x as f64).sum();
            running += t;
            newest_rel.push(t / running);
            b = e.iter().zip(&solver.scene().albedo).map(|(e, r)| *e * *r / PI).collect();
            if bounce >= 2 && t / running < tol as f64 {
                expected = bounce;
                break;
            }
        }
        eprintln!("rho {rho}, tolerance {tol}: {} bounces (manual {expected})", result.bounces);
        assert!(expected > 0);
        assert_eq!(result.bounces, expected, "rho {rho} tol {tol}: relative bounce sizes {newest_rel:?}");
        // The bounce before the last was still above the tolerance: it did not stop early.
        assert!(newest_rel[expected as usize - 2] >= tol as f64);
        // A tighter tolerance needs more bounces, a looser one fewer.
        let tighter = gather(
            &solver.links(),
            &solver.scene().albedo,
            &sol.e_source,
            &GatherParams { tolerance: tol / 10.0, ..params },
        );
        assert!(tighter.bounces > result.bounces);
    }
}

/// Feature angle 0: smoothing is skipped (flag off, E_i bit-identical to
/// the raw gather); at 30 degrees it runs and changes E_i.
#[test]
fn smoothing_skipped_at_zero_angle() {
    let off = common::with_settings(builtin::builtin("cornell").unwrap(), 16, Bounces::Fixed(2), 0.0);
    let (_, sol) = common::solve(&off);
    assert!(!sol.smoothed);
    assert_eq!(sol.e_indirect, sol.e_indirect_raw);
    let on = common::with_settings(builtin::builtin("cornell").unwrap(), 16, Bounces::Fixed(2), 30.0);
    let (_, sol_on) = common::solve(&on);
    assert!(sol_on.smoothed);
    assert_eq!(sol_on.e_indirect_raw, sol.e_indirect_raw, "same links and gather");
    assert!(sol_on.e_indirect != sol_on.e_indirect_raw, "smoothing at 30 degrees changes E_i");
}
