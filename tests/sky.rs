//! Sky light: analytic cases, rotation against re-shooting, the scene
//! file's `[sky]`, and the link solver against the reference path tracer
//! on `window` (emitters and sky together).

mod common;

use glam::Vec3;
use linkgi::links::RaySetup;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, Bounces, SceneDesc};
use linkgi::sky::{EnvMap, Sky};
use linkgi::solver::Solver;
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

fn scene_of(name: &str, meshes: Vec<linkgi::scene::MeshDesc>, sky: Sky, rays: u32) -> SceneDesc {
    common::scene_desc(name, meshes, vec![], Some(sky), rays, Bounces::Fixed(3))
}

/// A 2 x 2 m plane at y = 0 facing up, 10 x 10 quads.
fn plane() -> linkgi::scene::MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), 10, 10, m);
    b.finish("plane", 30.0)
}

/// A 2 x 2 x `h` box open at the top (x, z in [-1, 1], y in [0, h]), faces inward.
fn open_box(h: f32, res: u32) -> linkgi::scene::MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    let mats = [Some(m), Some(m), Some(m), None, Some(m), Some(m)];
    b.cuboid_open(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, h, 1.0), [res; 3], mats, true);
    b.finish("open box", 30.0)
}

/// Form factor from a differential area facing up to a parallel `a x b`
/// rectangle at height `h` with one corner straight above it.
fn corner_form_factor(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let (sx, sy) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Form factor from a point `(px, pz)` at the bottom of [`open_box`] to its opening.
fn opening_form_factor(px: f64, pz: f64, h: f64) -> f64 {
    let mut f = 0.0;
    for a in [1.0 - px, 1.0 + px] {
        for b in [1.0 - pz, 1.0 + pz] {
            f += corner_form_factor(a, b, h);
        }
    }
    f
}

#[test]
fn open_plane_under_a_uniform_sky_gets_pi_l() {
    let l = Vec3::new(1.5, 0.7, 0.2);
    let (solver, sol) = common::solve(&scene_of("plane", vec![plane()], Sky::uniform(l), 64));
    assert_eq!(solver.links().stats.misses, solver.links().stats.rays, "every ray leaves the plane");
    for (v, e) in sol.e_sky.iter().enumerate() {
        assert!((*e / (PI * l) - Vec3::ONE).abs().max_element() < 1e-5, "vertex {v}: {e} vs {}", PI * l);
    }
    // Nothing else is seen: no indirect light; the total is pi L.
    assert!(sol.e_indirect.iter().all(|e| *e == Vec3::ZERO));
    assert_eq!(sol.total(), sol.e_sky);
}

/// A gradient sky `H + (Z - H) cos` over the open plane:
/// `E = pi H + 2 pi / 3 (Z - H)`, within the stratified estimate's error
/// (a smooth integrand: measured 0.24% at 256 rays; allowed 0.5%).
#[test]
fn open_plane_under_a_gradient_sky() {
    let (z, h) = (Vec3::new(3.0, 2.0, 1.0), Vec3::new(1.0, 1.0, 1.0));
    let sky = Sky::gradient(z, h, Vec3::ZERO);
    let (_, sol) = common::solve(&scene_of("plane", vec![plane()], sky, 256));
    let exact = PI * h + 2.0 * PI / 3.0 * (z - h);
    let worst = sol.e_sky.iter().fold(0f32, |m, e| m.max(((*e - exact) / exact).abs().max_element()));
    eprintln!("gradient sky on a plane: worst relative error {worst} (exact {exact})");
    assert!(worst < 5e-3, "{worst}");
}

/// At the bottom of a box open at the top, a vertex sees the sky through
/// the opening: `E_sky = pi L F` with the analytic point-to-rectangle form
/// factor `F`. 1024 rays per vertex; the stratified estimate's noise at an
/// opening's edge is about 0.5% of F's range, so per vertex `|dF| <= 0.02`
/// and over the bottom the mean error of F within 0.3%.
#[test]
fn open_box_bottom_sees_the_opening_form_factor() {
    let l = Vec3::splat(2.0);
    let h = 1.0f32;
    let (solver, sol) = common::solve(&scene_of("open box", vec![open_box(h, 10)], Sky::uniform(l), 1024));
    let (mut n, mut sum_err, mut worst, mut sum_f) = (0, 0f64, 0f64, 0f64);
    for (f, d) in bottom_form_factors(&solver, &sol, l, h) {
        sum_err += d;
        sum_f += f;
        worst = worst.max(d.abs());
        n += 1;
    }
    let mean_err = sum_err / n as f64;
    eprintln!(
        "open box: {n} bottom vertices, mean F {:.4}, mean error {mean_err:.5}, worst {worst:.4}",
        sum_f / n as f64
    );
    assert!(n >= 64);
    assert!(mean_err.abs() < 3e-3 * (sum_f / n as f64), "mean error of F {mean_err}");
    assert!(worst < 0.02, "worst per-vertex error of F {worst}");
}

/// The open box's bottom vertices away from the walls (the border ones are
/// nudged): each one's analytic form factor `F` of the opening and the
/// error of the solver's `E_sky / (pi L)` against it, for a uniform sky of
/// radiance `l` over a box of height `h`.
fn bottom_form_factors(
    solver: &linkgi::solver::Solver,
    sol: &linkgi::solver::Solution,
    l: Vec3,
    h: f32,
) -> Vec<(f64, f64)> {
    let s = &solver.scene();
    (0..s.vertex_count())
        .filter(|&v| {
            let p = s.positions[v];
            p.y == 0.0 && p.x.abs() <= 0.95 && p.z.abs() <= 0.95
        })
        .map(|v| {
            let p = s.positions[v];
            let f = opening_form_factor(p.x as f64, p.z as f64, h as f64);
            (f, sol.e_sky[v].x as f64 / (PI as f64 * l.x as f64) - f)
        })
        .collect()
}

/// Sky refinement ([`linkgi::sky::refine`]) on the open box, unsmoothed, at
/// 256 rays: the per-vertex RMS error of the opening's form factor falls
/// by at least 1.6x against one ray a cell, the mean stays unbiased
/// (within 0.3% of F, as one ray a cell), and the same seed gives the same
/// refined cells and rays.
#[test]
fn sky_refinement_sharpens_the_opening_without_bias() {
    let l = Vec3::splat(2.0);
    let h = 1.0f32;
    let desc = scene_of("open box", vec![open_box(h, 10)], Sky::uniform(l), 256);
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let errors = |sub: u32| {
        let mut params = linkgi::solver::SolveParams::from_settings(&scene.settings);
        params.smoothing_angle_deg = 0.0;
        // 0: the `sky_refine` term off.
        (params.sky.sub, params.terms.sky_refine) = (sub.max(1), sub > 0);
        let (solver, sol) = common::solve_with(scene.clone(), params);
        let (mut n, mut sum, mut sum2, mut sum_f) = (0, 0f64, 0f64, 0f64);
        for (f, d) in bottom_form_factors(&solver, &sol, l, h) {
            (n, sum, sum2, sum_f) = (n + 1, sum + d, sum2 + d * d, sum_f + f);
        }
        let (mean_f, bias, rms) = (sum_f / n as f64, sum / n as f64, (sum2 / n as f64).sqrt());
        (solver.sky_rays().refine.clone(), rms, bias / mean_f)
    };
    let (none, rms_plain, bias_plain) = errors(0);
    let (refined, rms_refined, bias_refined) = errors(3);
    eprintln!(
        "open box, 256 rays: RMS error of F {rms_plain:.5} -> {rms_refined:.5} ({} refined cells, {} rays), \
         relative bias {bias_plain:+.5} -> {bias_refined:+.5}",
        refined.cells.items.len(),
        refined.rays
    );
    assert!(none.is_empty() && !refined.is_empty());
    assert!(rms_refined * 1.6 < rms_plain, "{rms_plain} -> {rms_refined}");
    assert!(bias_plain.abs() < 3e-3 && bias_refined.abs() < 3e-3, "{bias_plain} {bias_refined}");
    let (mut again, rms_again, _) = errors(3);
    again.ms = refined.ms; // times differ from run to run
    assert_eq!(again, refined);
    assert_eq!(rms_again, rms_refined);
}

/// A smooth synthetic sky image: a blue-white gradient with a broad warm
/// lobe toward +x (low) and a cool one toward -z, radiance W/(m^2 sr).
fn synthetic_sky(w: usize, h: usize) -> EnvMap {
    let probe = EnvMap { width: w, height: h, pixels: vec![Vec3::ZERO; w * h] };
    let lobe = |d: Vec3, to: Vec3, k: f32| (k * (d.dot(to.normalize()) - 1.0)).exp();
    let pixels = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = probe.direction(i, j);
            let base = Vec3::new(0.6, 0.8, 1.2) * (0.5 + 0.5 * d.y.max(0.0)) + Vec3::splat(0.1);
            base + Vec3::new(4.0, 2.5, 1.0) * lobe(d, Vec3::new(1.0, 0.3, 0.0), 6.0)
                + Vec3::new(0.5, 1.0, 2.0) * lobe(d, Vec3::new(0.0, 0.5, -1.0), 3.0)
        })
        .collect();
    EnvMap::new(w, h, pixels).unwrap()
}

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `E_sky` at every vertex from its rays traced again, the full sky
/// evaluated along every missed direction: `pi / n sum L(w_k)`.
fn reshoot_sky(solver: &Solver, sky: &Sky) -> Vec<(Vec3, f32)> {
    let setup = RaySetup::new(&solver.scene(), &solver.params().links);
    let n = setup.directions.len() as f32;
    let mut records = Vec::new();
    (0..solver.scene().vertex_count())
        .map(|v| {
            setup.trace_vertex(solver.accel(), v, &mut records);
            let mut e = Vec3::ZERO;
            let mut missed = 0;
            for (r, d) in records.iter().zip(setup.world_directions(v)) {
                if r.tri == linkgi::links::HIT_MISS {
                    e += sky.radiance(d);
                    missed += 1;
                }
            }
            (e * PI / n, missed as f32 / n)
        })
        .collect()
}

/// An image sky loaded through the scene file and turned: `E_sky` from
/// the stored visibility equals re-shooting every ray with the turned sky
/// (to f32 rounding: the same sum); turning is a gather-only update (the
/// same solver, no rays) whose result is bit for bit a fresh solve with
/// the turned sky.
#[test]
fn rotated_image_sky_equals_reshooting() {
    let dir = tmp("sky-rotate");
    linkgi::sky::envmap::write_exr(&synthetic_sky(128, 64), &dir.join("sky.exr")).unwrap();
    linkgi::scene::obj::write_obj(&open_box(0.6, 8), &dir.join("box.obj")).unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        "[settings]\nrays_per_vertex = 256\nsmoothing_angle_deg = 0\n\n[[mesh]]\nobj = \"box.obj\"\n\n[sky]\nimage = \"sky.exr\"\nrotate_deg = 73\n",
    )
    .unwrap();
    let desc = linkgi::scene::load(dir.join("scene.toml").to_str().unwrap()).unwrap();
    let sky = desc.sky.clone().expect("the scene file's [sky]");
    assert_eq!(sky.rotate_deg, 73.0);
    // The link rays' misses alone (no refined cells) against their re-trace.
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let mut plain = linkgi::solver::SolveParams::from_settings(&scene.settings);
    plain.terms.sky_refine = false;
    let (solver, sol) = common::solve_with(scene, plain);
    let mean_sky = sol.e_sky.iter().sum::<Vec3>() / sol.e_sky.len() as f32;
    eprintln!("image sky: mean E_sky {mean_sky}");
    let check = |solver: &Solver, e_sky: &[Vec3], sky: &Sky| {
        let mut seen = 0;
        for (v, (want, missed)) in reshoot_sky(solver, sky).into_iter().enumerate() {
            let err = (e_sky[v] - want).abs();
            assert!(err.cmple(want * 1e-5).all(), "vertex {v}: {} vs re-shot {want}", e_sky[v]);
            seen += (missed > 0.0) as usize;
        }
        assert!(seen > solver.scene().vertex_count() / 2, "only {seen} vertices see the sky");
    };
    check(&solver, &sol.e_sky, &sky);
    // Turned again on the same solver: a gather-only update.
    let mut turned = solver;
    let mut sky2 = sky.clone();
    sky2.rotate_deg = -40.0;
    assert!(!turned.set_sky(Some(sky2.clone())));
    let sol2 = turned.solve();
    check(&turned, &sol2.e_sky, &sky2);
    let moved = sol.e_sky.iter().zip(&sol2.e_sky).map(|(a, b)| (*a - *b).abs().max_element()).fold(0.0, f32::max);
    assert!(moved > 0.05 * mean_sky.max_element(), "turning the sky changed E_sky by only {moved}");
    // With refined cells (the default): turning is gather-only, and bit for
    // bit a fresh solve with the turned sky.
    let (mut refined, _) = common::solve(&desc);
    assert!(!refined.sky_rays().refine.is_empty());
    assert!(!refined.set_sky(Some(sky2.clone())));
    let rays = refined.sky_rays().refine.rays;
    let turned_refined = refined.solve();
    assert_eq!(refined.sky_rays().refine.rays, rays);
    let mut fresh_desc = desc.clone();
    fresh_desc.sky = Some(sky2.clone());
    let (_, fresh) = common::solve(&fresh_desc);
    assert_eq!(fresh.e_sky, turned_refined.e_sky);
    assert_eq!(fresh.e_indirect, turned_refined.e_indirect);
    // With a portal over the opening (from the scene file): turning traces
    // nothing, and equals a fresh solve; the bottom's mean E_sky agrees
    // with the link rays' re-trace (both unbiased) within 1%.
    let toml = std::fs::read_to_string(dir.join("scene.toml")).unwrap()
        + "portals = [[[-1, 0.6, -1], [1, 0.6, -1], [1, 0.6, 1], [-1, 0.6, 1]]]\n";
    std::fs::write(dir.join("portal.toml"), toml).unwrap();
    let desc = linkgi::scene::load(dir.join("portal.toml").to_str().unwrap()).unwrap();
    assert_eq!(desc.sky.as_ref().unwrap().portals.len(), 1);
    let (mut portal, _) = common::solve(&desc);
    let rays = portal.sky_rays().portals.rays;
    assert!(rays > 0);
    let mut sky3 = desc.sky.clone().unwrap();
    sky3.rotate_deg = -40.0;
    assert!(!portal.set_sky(Some(sky3.clone())));
    let turned_portal = portal.solve();
    assert_eq!(portal.sky_rays().portals.rays, rays, "no new portal rays");
    let mut fresh_desc = desc.clone();
    fresh_desc.sky = Some(sky3.clone());
    let (_, fresh) = common::solve(&fresh_desc);
    assert_eq!(fresh.e_sky, turned_portal.e_sky);
    let bottom: Vec<usize> =
        (0..portal.scene().vertex_count()).filter(|&v| portal.scene().positions[v].y == 0.0).collect();
    let reshot = reshoot_sky(&portal, &sky3);
    let mean = |f: &dyn Fn(usize) -> Vec3| bottom.iter().map(|&v| f(v)).sum::<Vec3>() / bottom.len() as f32;
    let (ours, theirs) = (mean(&|v| turned_portal.e_sky[v]), mean(&|v| reshot[v].0));
    eprintln!("image sky through a portal: bottom mean E_sky {ours} against the link rays' {theirs}");
    assert!(((ours - theirs) / theirs).abs().max_element() < 0.01, "{ours} against {theirs}");
}

/// `[sky]` errors name the scene file, or the image file.
#[test]
fn bad_sky_tables_are_errors_naming_the_file() {
    let dir = tmp("sky-bad");
    linkgi::scene::obj::write_obj(&plane(), &dir.join("plane.obj")).unwrap();
    std::fs::write(dir.join("broken.exr"), b"not an exr").unwrap();
    // A Radiance header that declares 10^10 pixels in a file of a few bytes.
    std::fs::write(
        dir.join("huge.hdr"),
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n\x02\x02\x00\x01",
    )
    .unwrap();
    let cases = [
        ("radiance = [1, 1, 1]\nimage = \"sky.exr\"", "scene.toml", "exactly one"),
        ("radiance = [1, -1, 1]", "scene.toml", "negative"),
        ("zenith = [1, 1, 1]", "scene.toml", "exactly one"),
        ("radiance = [1, 1, 1]\nintensity = -2", "scene.toml", "intensity"),
        ("radiance = [1, 1, 1]\nrotate = 3", "scene.toml", "unknown field"),
        ("image = \"missing.exr\"", "missing.exr", "no such file"),
        ("image = \"broken.exr\"", "broken.exr", "OpenEXR"),
        ("image = \"plane.obj\"", "plane.obj", ".exr or .hdr"),
        ("image = \"huge.hdr\"", "huge.hdr", "declares 100000 x 100000 pixels"),
        (
            "radiance = [1, 1, 1]\nportals = [[[0, 1, 0], [1, 1, 0], [1, 1, 1.5], [0, 1, 1]]]",
            "scene.toml",
            "parallelogram",
        ),
        ("radiance = [1, 1, 1]\nportals = [[[0, 1, 0], [1, 1, 0], [2, 1, 0], [1, 1, 0]]]", "scene.toml", "no area"),
        ("radiance = [1, 1, 1]\nportals = [[[0, 1, 0], [1, 1, 0], [1, 1, 1]]]", "scene.toml", "length"),
    ];
    for (table, file, what) in cases {
        let toml = dir.join("scene.toml");
        std::fs::write(&toml, format!("[[mesh]]\nobj = \"plane.obj\"\n\n[sky]\n{table}\n")).unwrap();
        let e = linkgi::scene::load(toml.to_str().unwrap()).unwrap_err().to_string();
        assert!(e.contains(file) && e.contains(what), "[sky] {table:?}: {e}");
    }
}

/// `window` (a glowing lamp shade and a gradient sky through a window, no
/// point light) against the reference path tracer (4096 paths a vertex),
/// which handles emitters and the sky on its own. Total relative RMSE,
/// noise-corrected: 1.90% at 256 rays and 1.06% at 1024 with the emitter
/// links, the sky's portal over the window, the emission of the band
/// under the shade's own triangles and the emitters' light at near hits
/// (2.7% and 1.7% before the last three; the vertex links alone gave 7.1%
/// and 2.5%); held to 3% and 2%, falling with the rays by at least a third. What remains is the error issue's contact
/// interpolation (the cabinet's back, 5 cm from the wall, 30% low; the
/// lamp's base on the floor 50% high). The mean must agree: total bias
/// within 2% (measured -0.5% and -0.5%), sky bias within 2% at 256 rays
/// and 1% at 1024 (measured -0.06% and -0.13%).
#[test]
fn window_scene_agrees_with_the_reference_path_tracer() {
    use linkgi::accuracy::metrics::error_stats;
    use linkgi::reference::{self, ReferenceParams};
    let mut errors = Vec::new();
    for rays in [256, 1024] {
        let mut desc = builtin::builtin("window").unwrap();
        desc.settings.rays_per_vertex = rays;
        desc.settings.bounces = Bounces::Auto;
        let (solver, sol) = common::solve(&desc);
        let params = ReferenceParams { samples_per_vertex: 4096, ..Default::default() };
        let r = reference::compute_cached(&solver.scene(), &params, &reference::cache::default_dir());
        let total = error_stats(&sol.total(), &r.total(), &r.e_total_stderr);
        let sky = error_stats(&sol.e_sky, &r.e_sky, &[]);
        eprintln!("window, {rays} rays: total {total:?}\n sky {sky:?}");
        assert!(total.bias.abs() < 0.02, "{rays} rays: total {total:?}");
        let sky_tolerance = if rays == 256 { 0.02 } else { 0.01 };
        assert!(sky.bias.abs() < sky_tolerance, "{rays} rays: sky {sky:?}");
        errors.push(total.rel_rmse_corrected);
    }
    assert!(
        errors[0] < 0.03 && errors[1] < 0.02 && errors[1] < 0.67 * errors[0],
        "relative RMSE at 256 and 1024 rays: {errors:?}"
    );
}

/// `linkgi bench` rows carry the sky-turn figure for scenes with a sky
/// (and null without one).
#[test]
fn bench_rows_report_the_sky_turn() {
    use linkgi::bench::{run_once, BenchRow};
    use linkgi::solver::{Compute, SolveParams};
    for (name, has_sky) in [("window", true), ("cornell", false)] {
        let mut desc = builtin::builtin(name).unwrap();
        desc.settings.rays_per_vertex = 16;
        let scene = linkgi::scene::prep::prepare(&desc).unwrap();
        let params = SolveParams::from_settings(&scene.settings);
        let (times, sizes, _) = run_once(&scene, &params, &Compute::Cpu).unwrap();
        let row = BenchRow::from_runs(name, &sizes, 16, &[times]);
        let median = &serde_json::to_value(&row).unwrap()["sky_turn_ms"]["median"];
        assert_eq!(median.as_f64().is_some_and(|m| m > 0.0), has_sky, "{name}: {median}");
        assert_eq!(median.is_null(), !has_sky, "{name}: {median}");
    }
}

/// A portal over part of an open plane changes how the sky is sampled,
/// not what it brings: every vertex still gets `pi L` on average (its
/// directions through the portal are the portal's samples' and the link
/// rays' by their weights, the rest the link rays'), within the noise of
/// the samples (measured below), and the same seed gives the same samples.
#[test]
fn a_portal_over_an_open_plane_keeps_pi_l() {
    let l = Vec3::new(1.5, 0.7, 0.2);
    let mut sky = Sky::uniform(l);
    sky.portals.push(
        linkgi::sky::Portal::from_corners([
            Vec3::new(-0.5, 1.0, -0.5),
            Vec3::new(0.5, 1.0, -0.5),
            Vec3::new(0.5, 1.0, 0.5),
            Vec3::new(-0.5, 1.0, 0.5),
        ])
        .unwrap(),
    );
    for rays in [64, 1024] {
        let desc = scene_of("plane", vec![plane()], sky.clone(), rays);
        let scene = linkgi::scene::prep::prepare(&desc).unwrap();
        let mut params = linkgi::solver::SolveParams::from_settings(&scene.settings);
        params.smoothing_angle_deg = 0.0;
        let (solver, sol) = common::solve_with(scene, params);
        assert_eq!(solver.sky_rays().portals.portals.len(), 1);
        let ratios: Vec<f64> = sol.e_sky.iter().map(|e| (e.x / (PI * l.x)) as f64).collect();
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        let rms = (ratios.iter().map(|r| (r - 1.0).powi(2)).sum::<f64>() / ratios.len() as f64).sqrt();
        eprintln!("plane under a portal, {rays} rays: mean E_sky / (pi L) {mean:.5}, RMS error {rms:.5}");
        assert!((mean - 1.0).abs() < 3.0 * rms / (ratios.len() as f64).sqrt() + 1e-4, "mean {mean}, rms {rms}");
    }
}

/// A portal over the opening of a deep open box (3 m deep, 2 x 2 m
/// opening: the bottom sees it in about a tenth of its cosine-weighted
/// hemisphere, a window's case), at 64 rays and unsmoothed: the bottom's
/// per-vertex RMS error of the opening's analytic form factor falls at
/// least 3x against the link rays alone (measured 10.8x). A portal over
/// only half of the opening leaves the other half to the link rays, whose
/// view then has the portal's edge too: no better (measured 1.14x worse),
/// but as unbiased: each mean agrees with F within three standard errors
/// of its own noise.
#[test]
fn a_portal_over_the_opening_cuts_its_noise_without_bias() {
    let (l, h) = (Vec3::splat(2.0), 3.0f32);
    let portal = |x1: f32| {
        linkgi::sky::Portal::from_corners([
            Vec3::new(-1.0, h, -1.0),
            Vec3::new(x1, h, -1.0),
            Vec3::new(x1, h, 1.0),
            Vec3::new(-1.0, h, 1.0),
        ])
        .unwrap()
    };
    let errors = |portals: Vec<linkgi::sky::Portal>| {
        let mut sky = Sky::uniform(l);
        sky.portals = portals;
        let desc = scene_of("open box", vec![open_box(h, 10)], sky, 64);
        let scene = linkgi::scene::prep::prepare(&desc).unwrap();
        let mut params = linkgi::solver::SolveParams::from_settings(&scene.settings);
        params.smoothing_angle_deg = 0.0;
        let (solver, sol) = common::solve_with(scene, params);
        let (mut n, mut sum, mut sum2, mut sum_f) = (0, 0f64, 0f64, 0f64);
        for (f, d) in bottom_form_factors(&solver, &sol, l, h) {
            (n, sum, sum2, sum_f) = (n + 1, sum + d, sum2 + d * d, sum_f + f);
        }
        let rms = (sum2 / n as f64).sqrt();
        // Relative bias of the mean and three standard errors of it.
        (rms, sum / sum_f, 3.0 * rms * n as f64 / sum_f / (n as f64).sqrt(), solver.sky_rays().portals.rays)
    };
    let (rms_links, bias_links, tol_links, none) = errors(vec![]);
    let (rms_portal, bias_portal, tol_portal, rays) = errors(vec![portal(1.0)]);
    let (rms_half, bias_half, tol_half, _) = errors(vec![portal(0.0)]);
    eprintln!(
        "deep open box, 64 rays: RMS error of F {rms_links:.5} links alone, {rms_portal:.5} with a portal ({rays} rays), \
         {rms_half:.5} half covered; relative bias {bias_links:+.5} / {bias_portal:+.5} / {bias_half:+.5} \
         (3 standard errors {tol_links:.5} / {tol_portal:.5} / {tol_half:.5})"
    );
    assert_eq!(none, 0);
    assert!(rms_portal * 3.0 < rms_links, "{rms_links} -> {rms_portal}");
    assert!(rms_half < 2.0 * rms_links, "{rms_links} -> {rms_half}");
    for (b, tol) in [(bias_links, tol_links), (bias_portal, tol_portal), (bias_half, tol_half)] {
        assert!(b.abs() < tol + 1e-3, "relative bias {b} (3 standard errors {tol})");
    }
}
