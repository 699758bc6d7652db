//! Emitter links (next-event estimation toward emissive surfaces): the
//! analytic form factor of an unshaded panel, a brute-force visibility
//! integral under a blocker, agreement with the vertex links alone, seeds,
//! and the documented fallback above the pair budget.

mod common;

use glam::Vec3;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{prep, Bounces, SceneDesc};
use linkgi::solver::{SolveParams, Solver};
use linkgi::trace::ray::Ray;
use linkgi::trace::CpuTracer;

const M_E: Vec3 = Vec3::new(10.0, 5.0, 2.0);
/// The panel's half size and height, m.
const HALF: f32 = 0.4;
const HEIGHT: f32 = 0.6;

/// A 2 x 2 m floor at y = 0 facing up (10 x 10 quads), a glowing 0.8 x 0.8 m
/// panel at y = 0.6 over its middle, and optionally a 0.5 x 0.5 m blocker at
/// y = 0.3 over one side.
fn scene(blocker: bool, rays: u32) -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), 10, 10, m);
    let mut meshes = vec![b.finish("floor", 30.0)];
    let mut p = MeshBuilder::new();
    let glow = p.add_material("glow", Vec3::splat(0.3));
    p.materials[glow as usize].emission = M_E;
    p.quad_grid(
        Vec3::new(-HALF, HEIGHT, -HALF),
        Vec3::new(2.0 * HALF, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0 * HALF),
        4,
        4,
        glow,
    );
    meshes.push(p.finish("panel", 30.0));
    if blocker {
        let mut k = MeshBuilder::new();
        let dark = k.add_material("dark", Vec3::splat(0.2));
        k.quad_grid(Vec3::new(0.0, 0.3, -0.25), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), 3, 3, dark);
        meshes.push(k.finish("blocker", 30.0));
    }
    common::scene_desc("panel", meshes, vec![], None, rays, Bounces::Fixed(3))
}

/// Signed form factor from an upward differential area to the `a x b`
/// rectangle at height `h` with a corner straight above it (odd in `a` and `b`).
fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Form factor from the floor point `(px, pz)` to the panel.
fn panel_form_factor(px: f64, pz: f64) -> f64 {
    let (s, h) = (HALF as f64, HEIGHT as f64);
    let mut f = 0.0;
    for a in [s - px, s + px] {
        for b in [s - pz, s + pz] {
            f += corner_form_factor(a, b, h);
        }
    }
    f
}

/// The solver of `desc` with `samples` emitter samples (`Some(0)`: the
/// `emitter_links` term off) and `max_pairs`, where given.
fn solver(desc: &SceneDesc, samples: Option<u32>, max_pairs: Option<u64>) -> Solver {
    let scene = prep::prepare(desc).expect("scene prepares");
    let mut params = SolveParams::from_settings(&scene.settings);
    match samples {
        Some(0) => params.terms.emitter_links = false,
        Some(s) => params.emitter.samples = s,
        None => {}
    }
    if let Some(m) = max_pairs {
        params.emitter.max_pairs = m;
    }
    let s = Solver::new(scene, params, &|_, _| {}).unwrap();
    s.accel().validate().expect("acceleration structure valid");
    s.links().validate().expect("links valid");
    s.emitter_links().validate(s.scene().vertex_count()).expect("emitter links valid");
    s
}

fn floor_vertices(s: &Solver) -> std::ops::Range<usize> {
    let m = &s.scene().meshes[0];
    m.vertices.start as usize..m.vertices.end as usize
}

/// Unshaded, the emitter links are Lambert's formula: every floor vertex
/// gets `M_e F` with the analytic point-to-rectangle factor, whatever the
/// sample count; the vertex links alone (no emitter links, 1024 rays)
/// estimate the same light with noise, on average the same.
#[test]
fn unshaded_panel_gives_the_analytic_form_factor() {
    let desc = scene(false, 1024);
    let nee = solver(&desc, Some(16), None);
    let sol = nee.solve();
    let mut worst = 0f64;
    for v in floor_vertices(&nee) {
        let p = nee.scene().positions[v];
        let f = panel_form_factor(p.x as f64, p.z as f64);
        let e = sol.e_emitter[v];
        for c in 0..3 {
            let rel = (e[c] as f64 - M_E[c] as f64 * f).abs() / (M_E[c] as f64 * f);
            worst = worst.max(rel);
        }
        assert!(sol.e_indirect[v].cmpge(e).all(), "vertex {v}: E_i {} below the emitter's {e}", sol.e_indirect[v]);
    }
    assert!(worst < 1e-4, "worst relative error against the analytic factor {worst}");
    // The panel's own vertices see no emitter (it is flat), and its exitance is not in the first radiosity.
    let panel = &nee.scene().meshes[1];
    for v in panel.vertices.clone() {
        assert!(nee.emitter_links().covered[v as usize]);
        assert_eq!(sol.e_emitter[v as usize], Vec3::ZERO);
    }
    // The vertex links alone: the same light on average, with noise per vertex.
    let links_only = solver(&desc, Some(0), None);
    assert!(!links_only.emitter_links().is_active());
    let lo = links_only.solve();
    let (mut nee_sum, mut lo_sum, mut nee_err, mut lo_err) = (0f64, 0f64, 0f64, 0f64);
    for v in floor_vertices(&nee) {
        let p = nee.scene().positions[v];
        let want = M_E.x as f64 * panel_form_factor(p.x as f64, p.z as f64);
        // First bounce off the floor does not reach the floor (it is flat): E_i on the floor is
        // the panel's light plus what the panel reflects back, in both.
        nee_sum += sol.e_indirect_raw[v].x as f64;
        lo_sum += lo.e_indirect_raw[v].x as f64;
        nee_err += (sol.e_emitter[v].x as f64 - want).powi(2);
        let lo_direct = lo.e_indirect_raw[v].x as f64 - (sol.e_indirect_raw[v].x - sol.e_emitter[v].x) as f64;
        lo_err += (lo_direct - want).powi(2);
    }
    let rel = (nee_sum - lo_sum).abs() / lo_sum;
    eprintln!("mean E_i: emitter links {nee_sum:.3}, vertex links alone {lo_sum:.3} (rel {rel:.4}); squared errors {nee_err:.3e} vs {lo_err:.3e}");
    assert!(rel < 0.01, "emitter links and vertex links disagree on average: {rel}");
    assert!(nee_err < 0.01 * lo_err, "emitter links are not less noisy: {nee_err} vs {lo_err}");
}

/// Under a blocker, every floor vertex's emitter factor matches a
/// brute-force integral over the panel (300 x 300 points, each with a
/// shadow ray from the vertex's ray origin); the same seed gives the same
/// factors, another seed other ones.
#[test]
fn shaded_panel_matches_brute_force_visibility() {
    let desc = scene(true, 256);
    let s = solver(&desc, None, None);
    let sol = s.solve();
    let k = 300;
    let cell = (2.0 * HALF / k as f32).powi(2);
    let (mut sum_err, mut worst, mut shaded) = (0f64, 0f64, 0);
    for v in floor_vertices(&s) {
        let (p, n) = (s.scene().positions[v], s.scene().normals[v]);
        let origin = linkgi::links::shoot::ray_origin(&s.scene(), v, s.params().emitter.nudge);
        let (mut seen, mut all) = (0f64, 0f64);
        for i in 0..k {
            for j in 0..k {
                let y = Vec3::new(
                    -HALF + (i as f32 + 0.5) * 2.0 * HALF / k as f32,
                    HEIGHT,
                    -HALF + (j as f32 + 0.5) * 2.0 * HALF / k as f32,
                );
                let d = y - p;
                let r2 = d.length_squared();
                let w = (n.dot(d).max(0.0) * d.y.abs() / (r2 * r2)) as f64 * cell as f64 / std::f64::consts::PI;
                all += w;
                let to = y - origin;
                let dist = to.length();
                let ray = Ray { origin, dir: to / dist, tmin: 1e-5, tmax: dist * (1.0 - 1e-4), skip: v as u32 };
                if !s.accel().occluded(&ray) {
                    seen += w;
                }
            }
        }
        let f = sol.e_emitter[v].x as f64 / M_E.x as f64;
        let err = (f - seen).abs();
        sum_err += err;
        worst = worst.max(err / all);
        shaded += (seen < 0.98 * all && seen > 0.02 * all) as u32;
        assert!(f <= all * 1.001 + 1e-6, "vertex {v}: {f} above the unshaded {all}");
    }
    let count = floor_vertices(&s).len() as f64;
    eprintln!(
        "{shaded} partly shaded vertices; mean |error| {:.2e}, worst {worst:.4} of the unshaded factor",
        sum_err / count
    );
    assert!(shaded >= 10, "the blocker must shade part of the panel for some vertices ({shaded})");
    assert!(worst < 0.05, "worst error {worst} of the unshaded factor");
    assert!(sum_err / count < 2e-3, "mean error {}", sum_err / count);
    // Determinism.
    let again = solver(&desc, None, None);
    assert_eq!(again.emitter_links().rows, s.emitter_links().rows);
    let mut other = desc.clone();
    other.settings.seed += 1;
    let other = solver(&other, None, None);
    assert_ne!(other.emitter_links().rows, s.emitter_links().rows, "the seed must move the samples");
}

/// Above the pair budget there are no emitter links: the emitters' light
/// travels through the vertex links (the documented fallback), and says so.
#[test]
fn above_the_pair_budget_emitters_travel_through_links() {
    let desc = scene(false, 64);
    let s = solver(&desc, None, Some(10));
    assert!(!s.emitter_links().is_active());
    assert!(
        s.emitter_links().fallback.as_deref().is_some_and(|w| w.contains("pairs")),
        "{:?}",
        s.emitter_links().fallback
    );
    let sol = s.solve();
    assert!(sol.e_emitter.iter().all(|e| *e == Vec3::ZERO));
    let floor = floor_vertices(&s);
    let lit = floor.clone().filter(|&v| sol.e_indirect[v].x > 0.0).count();
    assert!(lit > floor.len() / 2, "the panel's light must still reach the floor through links ({lit})");
}
