//! Work a scene does not need is left out, observably: auto bounces stop as
//! soon as a bounce adds less than the tolerance, and smoothing is skipped
//! at a feature angle of 0; a switched-off term traces nothing.

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

/// A term is switched off one way, through `Terms`, and each traced term
/// so switched off traces none of its rays while the others trace theirs
/// (`window`: emitters, a sky and a portal; its sky's refined cells
/// without the portal, which otherwise takes every direction they would
/// refine); a count of 0, the old way, is refused by name.
#[test]
fn a_switched_off_term_traces_nothing_and_a_zero_count_is_refused() {
    use linkgi::scene::terms::Terms;
    use linkgi::solver::{SolveParams, SolveStats, Solver};
    let desc = common::with_settings(builtin::builtin("window").unwrap(), 64, Bounces::Fixed(2), 30.0);
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let base = SolveParams { pay_share: 0.0, ..SolveParams::from_settings(&scene.settings) };
    let mut no_portal = scene.clone();
    no_portal.sky.as_mut().unwrap().portals.clear();
    let stats_of = |scene: &linkgi::scene::prep::PreparedScene, terms: Terms| -> SolveStats {
        let s = Solver::new(scene.clone(), SolveParams { terms, ..base }, &|_, _| {}).unwrap();
        s.validate().unwrap();
        let sol = s.solve();
        assert!(sol.total().iter().all(|e| e.is_finite()));
        s.stats(&sol, 0.0)
    };
    let stats = |terms: Terms| stats_of(&scene, terms);
    type Rays = fn(&SolveStats) -> u64;
    let parts: [(&str, Rays); 6] = [
        ("emitter_links", |s| s.emitter_rays),
        ("near", |s| s.near_hits),
        ("near_emitters", |s| s.near_emitter_rays),
        ("near_sky", |s| s.near_sky_rays),
        ("near_gather", |s| s.near_gather_rays),
        ("sky_portals", |s| s.portal_rays),
    ];
    let all = stats(Terms::ALL);
    assert!(all.noise_check_rays > 0);
    for (name, rays) in parts {
        assert!(rays(&all) > 0, "{name} traces something with every term on");
        let off = stats(Terms::with_off([name]).unwrap());
        assert_eq!(rays(&off), 0, "{name} off");
        assert_eq!(off.links.rays, all.links.rays, "{name} off: the link rays are the same");
    }
    assert_eq!(stats(Terms::with_off(["noise_check"]).unwrap()).noise_check_rays, 0);
    assert!(stats_of(&no_portal, Terms::ALL).sky_rays > 0);
    assert_eq!(stats_of(&no_portal, Terms::with_off(["sky_refine"]).unwrap()).sky_rays, 0);
    // The near field goes with `near`.
    let no_near = stats(Terms::with_off(["near"]).unwrap());
    assert_eq!((no_near.near_emitter_rays, no_near.near_sky_rays, no_near.near_gather_rays), (0, 0, 0));

    let mut zero = base;
    zero.near_gather.rays = 0;
    let e = Solver::new(scene.clone(), zero, &|_, _| {}).err().expect("a count of 0 is refused").to_string();
    assert!(e.contains("near_gather.rays"), "{e}");
    let mut s = Solver::new(scene, base, &|_, _| {}).unwrap();
    assert!(s.set_params(zero).is_err());
    assert_eq!(s.params().near_gather.rays, base.near_gather.rays, "a refused change changes nothing");
}
