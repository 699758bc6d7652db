//! Prototype measurement for the error issue's contact floor: how much of
//! the error against the reference goes if the first bounce of *near* link
//! rays (hit closer than `c` times the hit triangle's longest edge) uses
//! the exact direct light at the hit point instead of the vertices'
//! interpolated one. `cargo run --release --example near_field_probe -- tearoom 1024 16384 [c]`.
use glam::Vec3;
use linkgi::accuracy::metrics::error_stats;
use linkgi::kdtree::traverse::{Ray, NO_SKIP};
use linkgi::links::{RaySetup, HIT_BACK, HIT_MISS};
use linkgi::reference::{self, ReferenceParams};
use linkgi::scene::{self, prep, Bounces, Light};
use linkgi::solver::{SolveParams, Solver};
use linkgi::trace::CpuTracer;
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("tearoom");
    let rays: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let samples: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(16384);
    let c: f32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1.0);
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
    let setup = RaySetup::new(s, &solver.params.links);
    let n_rays = setup.directions.len() as f32;
    let tri_normal = |t: usize| {
        let [a, b, c] = s.triangles[t].map(|i| s.positions[i as usize]);
        ((b - a).cross(c - a).normalize_or_zero(), (b - a).length().max((c - b).length()).max((a - c).length()))
    };
    let direct_at = |p: Vec3, n: Vec3, l: f32| -> Vec3 {
        let mut e = Vec3::ZERO;
        let o = p + n * (1e-4 * l);
        for light in &s.lights {
            match *light {
                Light::Point { position, intensity } => {
                    let d = position - p;
                    let r2 = d.length_squared();
                    let cos = n.dot(d) / r2.sqrt();
                    if cos <= 0.0 {
                        continue;
                    }
                    let to = position - o;
                    let len = to.length();
                    let ray = Ray { origin: o, dir: to / len, tmin: 0.0, tmax: len * (1.0 - 1e-5), skip: NO_SKIP };
                    if !solver.accel.occluded(&ray) {
                        e += intensity * cos / r2;
                    }
                }
                Light::Directional { direction, irradiance } => {
                    let w = -direction.normalize();
                    let cos = n.dot(w);
                    if cos > 0.0 {
                        let ray = Ray { origin: o, dir: w, tmin: 0.0, tmax: f32::INFINITY, skip: NO_SKIP };
                        if !solver.accel.occluded(&ray) {
                            e += irradiance * cos;
                        }
                    }
                }
            }
        }
        e
    };
    let t0 = Instant::now();
    let (delta, near): (Vec<Vec3>, Vec<u32>) = (0..s.vertex_count())
        .into_par_iter()
        .map_init(Vec::new, |recs, v| {
            setup.trace_vertex(&solver.accel, v, recs);
            let mut d = Vec3::ZERO;
            let mut count = 0;
            for rec in recs.iter() {
                if rec.tri == HIT_MISS || rec.tri & HIT_BACK != 0 {
                    continue;
                }
                let t = rec.tri as usize;
                let (normal, edge) = tri_normal(t);
                if rec.t >= c * edge {
                    continue;
                }
                count += 1;
                let tri = s.triangles[t];
                let w = [1.0 - rec.u - rec.v, rec.u, rec.v];
                let p: Vec3 = (0..3).map(|k| s.positions[tri[k] as usize] * w[k]).sum();
                let rho: Vec3 = (0..3).map(|k| s.albedo[tri[k] as usize] * w[k]).sum();
                let interp: Vec3 =
                    (0..3).map(|k| s.albedo[tri[k] as usize] * sol.e_direct[tri[k] as usize] * w[k]).sum();
                d += rho * direct_at(p, normal, edge) - interp;
            }
            (d / n_rays, count)
        })
        .unzip();
    let near_total: u64 = near.iter().map(|&x| x as u64).sum();
    println!(
        "{name} {rays} rays, c {c}: {near_total} near rays of {} ({:.1}%), {:.1} s",
        s.vertex_count() as u64 * n_rays as u64,
        100.0 * near_total as f64 / (s.vertex_count() as f64 * n_rays as f64),
        t0.elapsed().as_secs_f64()
    );
    let base = error_stats(&sol.total(), &rt, &r.e_total_stderr);
    println!("  now:       {:.4} (bias {:+.4})", base.rel_rmse_corrected, base.bias);
    // E_i with the correction: the bounces from E_src + delta, plus delta.
    let src: Vec<Vec3> = sol.e_source.iter().zip(&delta).map(|(a, b)| *a + *b).collect();
    let g = solver.gather_corrected(&src, &solver.params.gather);
    let angle = solver.params.smoothing_angle_deg;
    for smooth_delta in [false, true] {
        let e_i: Vec<Vec3> = if smooth_delta {
            let raw: Vec<Vec3> = g.e_indirect.iter().zip(&delta).map(|(a, b)| *a + *b).collect();
            solver.smooth(&src, &raw, angle)
        } else {
            solver
                .smooth(&src, &g.e_indirect, angle)
                .iter()
                .zip(&delta)
                .map(|(a, b)| (*a + *b).max(Vec3::ZERO))
                .collect()
        };
        let total: Vec<Vec3> = (0..e_i.len()).map(|v| sol.e_direct[v] + sol.e_sky[v] + e_i[v]).collect();
        let e = error_stats(&total, &rt, &r.e_total_stderr);
        println!("  corrected (delta smoothed: {smooth_delta}): {:.4} (bias {:+.4})", e.rel_rmse_corrected, e.bias);
    }
}
