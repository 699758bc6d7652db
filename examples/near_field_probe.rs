//! Prototype measurement for the error issue's contact floor: how much of
//! the error against the reference goes if the first bounce of *near* link
//! rays (hit closer than `c` times the hit triangle's longest edge) uses
//! the exact direct light at the hit point instead of the vertices'
//! interpolated one, and with `SECONDARY=m` also their second bounce from
//! `m` rays shot at each near hit (the first bounce's radiosity of what
//! they meet, against the corners' interpolated one).
//! `cargo run --release --example near_field_probe -- tearoom 1024 16384 [c]`.
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
    // The solver without its own near hits: "now" is the vertex links alone.
    let mut params = SolveParams::from_settings(&desc.settings);
    params.links.near.factor = 0.0;
    let solver = Solver::new(s, params, &|_, _| {});
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
    let m: u32 = std::env::var("SECONDARY").ok().and_then(|x| x.parse().ok()).unwrap_or(0);
    // First-bounce irradiance at every vertex (one bounce from the lights' source).
    let one = linkgi::exchange::GatherParams { bounces: Bounces::Fixed(1), ..solver.params.gather };
    let e1 = solver.gather_corrected(&sol.e_source, &one).e_indirect;
    let b0: Vec<Vec3> = (0..s.vertex_count()).map(|v| s.albedo[v] * sol.e_source[v] / std::f32::consts::PI).collect();
    // E^(1) at a surface point: m cosine rays, the hits' B_0 interpolated.
    let e1_at = |p: Vec3, n: Vec3, l: f32, seed: u32| -> Vec3 {
        let (t, b) = linkgi::sampling::basis(n);
        let o = p + n * (1e-4 * l);
        let k = (m as f32).sqrt() as u32;
        let mut e = Vec3::ZERO;
        for i in 0..k * k {
            let j = ((seed.wrapping_mul(2654435761).wrapping_add(i * 40503)) % 1000) as f32 / 1000.0;
            let u = glam::Vec2::new(((i % k) as f32 + j) / k as f32, ((i / k) as f32 + 0.5) / k as f32);
            let d = linkgi::sampling::cosine_hemisphere(u);
            let dir = (t * d.x + b * d.y + n * d.z).normalize();
            let ray = Ray { origin: o, dir, tmin: 0.0, tmax: f32::INFINITY, skip: NO_SKIP };
            if let Some(h) = solver.accel.intersect(&ray) {
                if h.front {
                    let tri = s.triangles[h.tri as usize];
                    let w = h.barycentrics();
                    e += (0..3).map(|c| b0[tri[c] as usize] * w[c]).sum::<Vec3>();
                }
            }
        }
        e * std::f32::consts::PI / (k * k) as f32
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
                if m > 0 {
                    let interp1: Vec3 = (0..3).map(|c| s.albedo[tri[c] as usize] * e1[tri[c] as usize] * w[c]).sum();
                    d += rho * e1_at(p, normal, edge, v as u32 * 7919 + count) - interp1;
                }
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
