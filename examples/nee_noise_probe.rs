//! Noise of the emitter links and of the gathered bounces on a scene: two
//! seeds, half the mean squared difference per vertex, relative to the mean
//! total: `cargo run --release --example nee_noise_probe -- window 256`.
use glam::Vec3;
use linkgi::scene::{self, prep, Bounces};
use linkgi::solver::{SolveParams, Solver};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("window");
    let rays: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let sols: Vec<_> = (1..=2)
        .map(|seed| {
            let mut desc = scene::load(name).unwrap();
            desc.settings.rays_per_vertex = rays;
            desc.settings.bounces = Bounces::Auto;
            desc.settings.seed = seed;
            let s = prep::prepare(&desc).unwrap();
            let mut p = SolveParams::from_settings(&desc.settings);
            if let Ok(n) = std::env::var("EMITTER_SAMPLES") {
                p.emitter.samples = n.parse().unwrap();
            }
            let solver = Solver::new(s, p, &|_, _| {});
            solver.solve()
        })
        .collect();
    let n = sols[0].e_direct.len();
    let mean = sols[0].total().iter().map(|e| e.element_sum() as f64 / 3.0).sum::<f64>() / n as f64;
    let noise = |f: &dyn Fn(usize, usize) -> Vec3| {
        let s: f64 = (0..n).map(|v| ((f(0, v) - f(1, v)).length_squared() / 3.0) as f64 / 2.0).sum();
        (s / n as f64).sqrt() / mean
    };
    println!("{name} {rays} rays: mean total {mean:.3}");
    println!("  emitter links  {:.4}", noise(&|k, v| sols[k].e_emitter[v]));
    println!("  sky            {:.4}", noise(&|k, v| sols[k].e_sky[v]));
    println!("  gathered (raw) {:.4}", noise(&|k, v| sols[k].e_indirect_raw[v] - sols[k].e_emitter[v]));
    println!("  gathered (smoothed) {:.4}", noise(&|k, v| sols[k].e_indirect[v] - sols[k].e_emitter[v]));
    println!("  total          {:.4}", noise(&|k, v| sols[k].total()[v]));
}
