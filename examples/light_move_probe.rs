//! Stage times of a light move (issue 16's conference light-move target):
//! `cargo run --release --example light_move_probe -- conference`;
//! `RECONSTRUCT=0` turns the radiosity correction off.
use linkgi::exchange;
use linkgi::scene::{self, prep, Light};
use linkgi::solver::{SolveParams, Solver};
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "conference".into());
    let desc = scene::load(&name).unwrap();
    let scene = prep::prepare(&desc).unwrap();
    let mut params = SolveParams::from_settings(&desc.settings);
    params.reconstruct = std::env::var("RECONSTRUCT").map_or(true, |v| v != "0");
    let mut solver = Solver::new(scene, params, &|_, _| {});
    let _ = solver.solve();
    for round in 0..3 {
        if let Some(Light::Point { position, .. }) = solver.scene.lights.first_mut() {
            position.x += 0.05;
        }
        let t = Instant::now();
        solver.update_lights();
        let light_ms = ms(t);
        let s = &solver.scene;
        let n = s.vertex_count();
        let t = Instant::now();
        let e_source = solver.light_links.bounce_source(&s.lights, n);
        let source_ms = ms(t);
        let t = Instant::now();
        let stand_ins =
            exchange::hidden::stand_ins(&solver.links, solver.params.links.rays_per_vertex, &solver.params.hidden);
        let stand_ms = ms(t);
        let t = Instant::now();
        let g = solver.gather_corrected(&e_source, &solver.params.gather);
        let gather_ms = ms(t);
        let t = Instant::now();
        let var = solver.noise_variance(&e_source, &g.e_indirect);
        let noise_ms = ms(t);
        let t = Instant::now();
        let _ =
            exchange::smooth_adaptive(&g.e_indirect, &var, &s.rings, &s.normals, 30.0, solver.params.smoothing.passes);
        let smooth_ms = ms(t);
        let t = Instant::now();
        let _ = solver.solve();
        let solve_ms = ms(t);
        println!(
            "round {round}: light links {light_ms:.1} ms, source {source_ms:.1}, stand-ins {stand_ms:.1} ({} hidden), gather (stand-ins again + {} bounces) {gather_ms:.1}, noise {noise_ms:.1}, smoothing {smooth_ms:.1}; whole solve {solve_ms:.1}",
            stand_ins.len(),
            g.bounces
        );
    }
}
