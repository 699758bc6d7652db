//! Times the stages of a selective deformation update against a full one
//! on a built-in scene with deformers: `cargo run --release --example
//! deform_probe -- [scene] [rays] [t0] [t1]`.

use linkgi::scene::deform::deform_scene;
use linkgi::scene::{builtin, prep};
use linkgi::solver::{SolveParams, Solver};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("dancer", |s| s.as_str());
    let rays: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let t0: f32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let t1: f32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.25);
    let mut desc = builtin::builtin(name).expect("a built-in scene");
    desc.settings.rays_per_vertex = rays;
    let rest = prep::prepare(&desc).expect("prepares");
    let at = |t: f32| {
        let (positions, normals) = deform_scene(&rest, &rest.positions, &rest.normals, t);
        prep::PreparedScene { positions, normals, ..rest.clone() }
    };
    let params = SolveParams::from_settings(&rest.settings);
    println!("ray setup: {:.1} ms", setup_ms(&rest, &params));
    if args.get(5).is_some_and(|a| a == "solve") {
        let solver = Solver::new(at(t0), params, &|_, _| {});
        for _ in 0..3 {
            solve_stages(&solver);
            let t = Instant::now();
            let _ = solver.solve();
            let a = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            let _ = solver.solve_quick();
            println!("solve {a:.1} ms, solve_quick {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
        }
        hidden_tolerance(&solver);
        return;
    }
    if args.get(5).is_some_and(|a| a == "preview") {
        let mut solver = Solver::new(at(t0), params, &|_, _| {});
        for k in 0..4 {
            let t = Instant::now();
            let mut show = |s: &Solver| {
                let a = t.elapsed().as_secs_f64() * 1e3;
                let _ = s.solve_quick();
                println!("preview {k}: solve from {a:.1} to {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
            };
            let (s, _) = solver.deform(at(if k % 2 == 0 { t1 } else { t0 }), params, Some((16, &mut show)), &|_, _| {});
            solver = s;
        }
        return;
    }
    if args.get(5).is_some_and(|a| a == "loop") {
        // Selective updates only (for profiles): back and forth six times.
        let mut solver = Solver::new(at(t0), params, &|_, _| {});
        for k in 0..6 {
            let t = Instant::now();
            let (s, d) = solver.deform(at(if k % 2 == 0 { t1 } else { t0 }), params, None, &|_, _| {});
            println!("selective {k}: {:.1} ms (links {:.1})", t.elapsed().as_secs_f64() * 1e3, d.links.ms);
            solver = s;
        }
        return;
    }
    let solver = Solver::new(at(t0), params, &|_, _| {});
    let t = Instant::now();
    let c = cpu_ms();
    let (solver, refit) = solver.deformed(at(t1), params, &|_, _| {});
    let _ = solver.solve();
    let full_ms = t.elapsed().as_secs_f64() * 1e3;
    println!("full: cpu {:.0} ms", cpu_ms() - c);
    println!(
        "full: {full_ms:.1} ms (refit {refit}, links {:.1} ms, light {:.1} ms)",
        solver.links.stats.shoot_ms, solver.light_links.ms
    );
    let solver = Solver::new(at(t0), params, &|_, _| {});
    let t = Instant::now();
    let c = cpu_ms();
    let (solver, d) = solver.deform(at(t1), params, None, &|_, _| {});
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let g = Instant::now();
    let _ = solver.solve();
    println!("selective: cpu {:.0} ms", cpu_ms() - c);
    println!(
        "selective: {ms:.1} ms: accel {:.1}, links {:.1} ({} rays re-shot, {} remade vertices of {}, {} groups patched, static fraction {:.4}), light {:.1} ({} entries); gather+smooth {:.1} ms; state {:.1} MB",
        d.accel_ms,
        d.links.ms,
        d.links.rays_reshot,
        d.links.remade_vertices,
        solver.scene.vertex_count(),
        d.links.groups_patched,
        d.static_rays_fraction(),
        d.light_links_ms,
        d.light_links_recomputed,
        g.elapsed().as_secs_f64() * 1e3,
        d.ray_state_bytes as f64 / 1e6
    );
}

fn setup_ms(scene: &prep::PreparedScene, params: &SolveParams) -> f64 {
    let t = Instant::now();
    let s = linkgi::links::RaySetup::new(scene, &params.links);
    std::hint::black_box(&s);
    t.elapsed().as_secs_f64() * 1e3
}

/// CPU time of this process so far (user + system), ms, from /proc (0 elsewhere).
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    // Fields after the command: state is 0, utime 11, stime 12 (clock ticks of 10 ms).
    (ticks(11) + ticks(12)) * 10.0
}

/// Times the stages of `Solver::solve`: the plain gather, the gather with
/// the hidden-vertex substitution, the noise estimate and the smoothing.
pub fn solve_stages(s: &Solver) {
    let n = s.scene.vertex_count();
    let src = s.light_links.bounce_source(&s.scene.lights, n);
    let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let plain = linkgi::exchange::gather(&s.links, &s.scene.albedo, &src, &s.params.gather);
    let gather_ms = ms(t);
    let t = Instant::now();
    let corrected = s.gather_corrected(&src, &s.params.gather);
    let corrected_ms = ms(t);
    let t = Instant::now();
    std::hint::black_box(s.noise_variance(&src, &corrected.e_indirect));
    let noise_ms = ms(t);
    let t = Instant::now();
    std::hint::black_box(s.smooth(&src, &corrected.e_indirect, s.params.smoothing_angle_deg));
    println!(
        "solve stages: gather {gather_ms:.1} ms ({} bounces), with hidden substitution {corrected_ms:.1}, \
         noise {noise_ms:.1}, smoothing (its own noise estimate + filter) {:.1} ms",
        plain.bounces,
        ms(t)
    );
}

/// Hidden-vertex correction at two tolerances: iterations and the largest relative difference.
pub fn hidden_tolerance(s: &Solver) {
    let n = s.scene.vertex_count();
    let src = s.light_links.bounce_source(&s.scene.lights, n);
    let g = linkgi::exchange::gather(&s.links, &s.scene.albedo, &src, &s.params.gather);
    let sc = &s.scene;
    let run = |tol: f32| {
        let p = linkgi::exchange::hidden::HiddenParams { tolerance: tol, ..s.params.hidden };
        let t = Instant::now();
        let (e, it) =
            linkgi::exchange::hidden::correct(&s.links, s.params.links.rays_per_vertex, &sc.albedo, &g.e_indirect, &p);
        (e, it, t.elapsed().as_secs_f64() * 1e3)
    };
    let (a, ia, ta) = run(1e-3);
    for tol in [3e-3f32, 1e-2, 3e-2] {
        let (b, ib, tb) = run(tol);
        let mean = a.iter().map(|x| x.element_sum()).sum::<f32>() / n as f32;
        let worst = a.iter().zip(&b).map(|(x, y)| (*x - *y).abs().max_element()).fold(0f32, f32::max) / (mean / 3.0);
        let rms =
            (a.iter().zip(&b).map(|(x, y)| (*x - *y).length_squared()).sum::<f32>() / n as f32).sqrt() / (mean / 3.0);
        println!("tolerance {tol}: {ib} iterations {tb:.1} ms (1e-3: {ia}, {ta:.1} ms); worst diff {worst:.2e}, rms {rms:.2e} of mean E_i");
    }
}
