//! Prototype: per-vertex noise of the gathered `E_i` by collapsed (paired)
//! strata from each vertex's own rays, against the model/check estimate,
//! as the input of the adaptive smoothing; error against the reference.
//! `cargo run --release --example paired_noise_probe -- window 64 16384`
use glam::Vec3;
use linkgi::accuracy::metrics::error_stats;
use linkgi::exchange;
use linkgi::links::{RaySetup, HIT_BACK, HIT_MISS};
use linkgi::reference::{self, ReferenceParams};
use linkgi::scene::{self, prep, Bounces};
use linkgi::solver::{SolveParams, Solver};
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("window");
    let rays: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(64);
    let samples: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(16384);
    let mut desc = scene::load(name).unwrap();
    desc.settings.rays_per_vertex = rays;
    desc.settings.bounces = Bounces::Auto;
    let s = prep::prepare(&desc).unwrap();
    let solver = Solver::new(s, SolveParams::from_settings(&desc.settings), &|_, _| {});
    let sol = solver.solve();
    let r = reference::compute_cached(
        &solver.scene,
        &ReferenceParams { samples_per_vertex: samples, ..Default::default() },
        &reference::cache::default_dir(),
    );
    let rt = r.total();
    let s = &solver.scene;
    let n = s.vertex_count();
    let gathered: Vec<Vec3> = (0..n).map(|v| sol.e_indirect_raw[v] - sol.e_emitter[v] - sol.e_near[v]).collect();
    let emission = solver.emitter_links.carried_emission(&s.emission);
    let bm = exchange::noise::radiosity_moments(&s.albedo, &emission, &sol.e_source, &gathered);
    let b: Vec<Vec3> = bm.iter().map(|x| x[0].truncate()).collect();
    let setup = RaySetup::new(s, &solver.params.links);
    let k = setup.directions.k;
    let cells = linkgi::sampling::block_order(k);
    let nr = (k * k) as usize;
    let pi = std::f32::consts::PI;
    // Per vertex: exact collapsed-strata variance, and one random-sign (Hutchinson) sample of it.
    let (paired, hutch): (Vec<Vec3>, Vec<Vec3>) = (0..n)
        .into_par_iter()
        .map_init(Vec::new, |recs, v| {
            setup.trace_vertex(&solver.accel, v, recs);
            let x: Vec<Vec3> = recs
                .iter()
                .map(|h| {
                    if h.tri == HIT_MISS || h.tri & HIT_BACK != 0 {
                        return Vec3::ZERO;
                    }
                    let t = s.triangles[h.tri as usize];
                    let w = [1.0 - h.u - h.v, h.u, h.v];
                    pi * (0..3).map(|c| b[t[c] as usize] * w[c]).sum::<Vec3>()
                })
                .collect();
            let (mut sum, mut signed) = (Vec3::ZERO, Vec3::ZERO);
            for a in (0..nr).step_by(2) {
                let bb = a + 1;
                if bb >= nr || cells[a].1 != cells[bb].1 {
                    continue;
                }
                let d = x[a] - x[bb];
                sum += d * d;
                let h = linkgi::sampling::splitmix64((v as u64) << 24 ^ a as u64 ^ 0x51ed_270b);
                signed += if h & 1 == 1 { d } else { -d };
            }
            let nn = (nr * nr) as f32;
            (sum / nn, signed * signed / nn)
        })
        .unzip();
    let angle = solver.params.smoothing_angle_deg;
    let passes = solver.params.smoothing.passes;
    let total_of = |e_i: &[Vec3]| -> Vec<Vec3> {
        (0..n)
            .map(|v| sol.e_direct[v] + sol.e_sky[v] + (e_i[v] + sol.e_emitter[v] + sol.e_near[v]).max(Vec3::ZERO))
            .collect()
    };
    let score = |label: &str, var: &[Vec3]| {
        let e = exchange::smooth_adaptive(&gathered, var, &s.rings, &s.normals, angle, passes);
        let st = error_stats(&total_of(&e), &rt, &r.e_total_stderr);
        let vs: f64 = var.iter().map(|x| x.element_sum() as f64).sum();
        println!("  {label:34} total {:.4} (bias {:+.4}); summed variance {:.3e}", st.rel_rmse_corrected, st.bias, vs);
    };
    println!("{name} {rays} rays");
    let raw = error_stats(&total_of(&gathered), &rt, &r.e_total_stderr);
    println!("  {:34} total {:.4} (bias {:+.4})", "unsmoothed", raw.rel_rmse_corrected, raw.bias);
    score("solver's (check ratio, pooled)", &solver.noise_variance(&sol.e_source, &sol.e_indirect_raw));
    let pool = |v: &[Vec3]| exchange::smooth(v, &s.rings, &s.normals, angle);
    score("paired strata, exact, per vertex", &paired);
    score("paired strata, exact, pooled", &pool(&paired));
    score("paired strata, random signs, pooled", &pool(&hutch));
    for f in [0.5f32, 0.25] {
        let scaled: Vec<Vec3> = pool(&hutch).iter().map(|x| *x * f).collect();
        score(&format!("random signs, pooled, x{f}"), &scaled);
    }
}
