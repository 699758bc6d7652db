//! Measures the choices of the accuracy work on a built-in scene against
//! the cached reference: exact against one-ring `E_d`, the bounce source,
//! the noise estimate's calibration (two seeds) and the smoothing filters:
//! `cargo run --release --example accuracy_probe -- [scene] [ref samples] [noise scale] [exponent] [rays...]`.

use glam::Vec3;
use linkgi::accuracy::metrics::error_stats;
use linkgi::exchange::{self, NoiseParams, SmoothMode};
use linkgi::reference::{self, ReferenceParams};
use linkgi::scene::{builtin, prep, Bounces};
use linkgi::solver::{SolveParams, Solver};
use std::time::Instant;

fn add(a: &[Vec3], b: &[Vec3]) -> Vec<Vec3> {
    a.iter().zip(b).map(|(x, y)| *x + *y).collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("cornell", |s| s.as_str());
    let ref_samples: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(4096);
    let scale: f32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let exponent: f32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.5);
    let rays: Vec<u32> = if args.len() > 5 {
        args[5..].iter().map(|s| s.parse().expect("rays")).collect()
    } else {
        vec![16, 64, 256, 1024]
    };
    let mut desc = builtin::builtin(name).expect("a built-in scene");
    desc.settings.bounces = Bounces::Auto;
    let scene = prep::prepare(&desc).expect("prepares");
    let t = Instant::now();
    let rp = ReferenceParams { samples_per_vertex: ref_samples, ..Default::default() };
    let r = reference::compute_cached(&scene, &rp, &reference::cache::default_dir());
    let total_ref = add(&r.e_direct, &r.e_indirect);
    let mean = |v: &[Vec3]| v.iter().map(|x| x.element_sum() as f64).sum::<f64>() / (3 * v.len()) as f64;
    let rms = |v: &[Vec3]| (v.iter().map(|x| x.length_squared() as f64).sum::<f64>() / (3 * v.len()) as f64).sqrt();
    println!(
        "{name}: {} vertices, reference {ref_samples} paths ({}; {:.1} s): noise {:.4} of mean E_i, {:.4} of mean total; E_i/total {:.3}",
        scene.vertex_count(),
        if r.from_cache { "cached" } else { "computed" },
        t.elapsed().as_secs_f64(),
        rms(&r.e_indirect_stderr) / mean(&r.e_indirect),
        rms(&r.e_indirect_stderr) / mean(&total_ref),
        mean(&r.e_indirect) / mean(&total_ref)
    );
    println!("rays | Ed exact | Ed ring | Ei raw: no hidden corr. | src ring | src point | noise rel | actual/iid | Ei: off | uniform | adaptive 1 2 3 | total: off | uniform | adaptive 1 2 3 | mean beta | solve ms");
    for &n in &rays {
        let solver_for = |seed: u64| {
            let mut s = scene.settings;
            s.rays_per_vertex = n;
            s.seed = seed;
            let mut p = SolveParams::from_settings(&s);
            p.smoothing.noise = NoiseParams { scale, exponent, ..Default::default() };
            // The one-ring factors too, to compare the bounce sources.
            p.light.oversample = true;
            Solver::new(scene.clone(), p, &|_, _| {})
        };
        let t = Instant::now();
        let s1 = solver_for(1);
        let sol = s1.solve();
        let solve_ms = t.elapsed().as_secs_f64() * 1e3;
        let nv = scene.vertex_count();
        let ed_ring = s1.light_links.direct_ring(&scene.lights, nv);
        let ed = error_stats(&sol.e_direct, &r.e_direct, &[]).rel_rmse;
        let edr = error_stats(&ed_ring, &r.e_direct, &[]).rel_rmse;
        let gp = s1.params.gather;
        let g_ring = exchange::gather(&s1.links, &scene.albedo, &ed_ring, &gp);
        let g_point = exchange::gather(&s1.links, &scene.albedo, &sol.e_direct, &gp);
        let se = &r.e_indirect_stderr;
        let ei_ring = error_stats(&s1.correct_hidden(&g_ring.e_indirect), &r.e_indirect, se).rel_rmse_corrected;
        let ei_point = error_stats(&s1.correct_hidden(&g_point.e_indirect), &r.e_indirect, se).rel_rmse_corrected;
        let ei_uncorrected = error_stats(&sol.gather.e_indirect, &r.e_indirect, se).rel_rmse_corrected;
        // Noise calibration: two seeds.
        let s2 = solver_for(2);
        let sol2 = s2.solve();
        // The gathered part only (emitter links and near-hit corrections are not smoothed).
        let gathered = |sol: &linkgi::solver::Solution| -> Vec<Vec3> {
            (0..nv).map(|v| sol.e_indirect_raw[v] - sol.e_emitter[v] - sol.e_near[v]).collect()
        };
        let (g1, g2) = (gathered(&sol), gathered(&sol2));
        // Independent-ray variance (no stratification ratio).
        let iid_of = |sv: &Solver, sol: &linkgi::solver::Solution, g: &[Vec3]| -> Vec<Vec3> {
            let emission = sv.emitter_links.carried_emission(&sv.scene.emission);
            let b = exchange::noise::radiosity_moments(&sv.scene.albedo, &emission, &sol.e_source, g);
            exchange::noise::variance_iid(&sv.links, &b, n)
        };
        let (iid, iid2) = (iid_of(&s1, &sol, &g1), iid_of(&s2, &sol2, &g2));
        let actual: f64 = g1.iter().zip(&g2).map(|(a, b)| (*a - *b).length_squared() as f64 / 2.0).sum();
        let est: f64 = iid.iter().zip(&iid2).map(|(a, b)| (a.element_sum() + b.element_sum()) as f64 / 2.0).sum();
        let raw = &sol.e_indirect_raw;
        let var = s1.noise_variance(&sol.e_source, raw);
        let uniform = exchange::smooth(raw, &scene.rings, &scene.normals, 30.0);
        let adaptive: Vec<Vec<Vec3>> =
            (1..=3).map(|p| exchange::smooth_adaptive(raw, &var, &scene.rings, &scene.normals, 30.0, p)).collect();
        let beta = exchange::smooth::adaptive_weights(raw, &var, &scene.rings, &scene.normals, 30.0).unwrap();
        let mean_beta = beta.iter().map(|&b| b as f64).sum::<f64>() / beta.len() as f64;
        let ei = |x: &[Vec3]| error_stats(x, &r.e_indirect, se).rel_rmse_corrected;
        let tot = |x: &[Vec3]| error_stats(&add(&sol.e_direct, x), &total_ref, se).rel_rmse_corrected;
        let _ = SmoothMode::Adaptive;
        if let Some(path) = std::env::var_os("DUMP") {
            let mut out = String::from(
                "v,x,y,z,nx,ny,nz,boundary,edge,ei,ei2,ref,stderr,ed,ref_ed,ring_ed,row_sum,ei_gathered,mesh\n",
            );
            for v in 0..nv {
                let (p, nn) = (scene.positions[v], scene.normals[v]);
                out += &format!(
                    "{v},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                    p.x,
                    p.y,
                    p.z,
                    nn.x,
                    nn.y,
                    nn.z,
                    scene.boundary[v] as u8,
                    scene.mean_edge_length(v),
                    raw[v].element_sum() / 3.0,
                    sol2.e_indirect_raw[v].element_sum() / 3.0,
                    r.e_indirect[v].element_sum() / 3.0,
                    r.e_indirect_stderr[v].element_sum() / 3.0,
                    sol.e_direct[v].element_sum() / 3.0,
                    r.e_direct[v].element_sum() / 3.0,
                    ed_ring[v].element_sum() / 3.0,
                    s1.links.row_sum(v),
                    sol.gather.e_indirect[v].element_sum() / 3.0,
                    scene.meshes.iter().position(|m| m.vertices.contains(&(v as u32))).unwrap_or(0),
                );
            }
            std::fs::write(path, out).expect("dump");
        }
        if let Some(th) = std::env::var("HIDDEN").ok().and_then(|s| s.parse::<f64>().ok()) {
            // Experiment: vertices whose rays mostly meet back faces (row sum < th * pi)
            // take the mean radiosity of their visible neighbours; one extra gather.
            let pi = std::f64::consts::PI;
            let hidden: Vec<bool> = (0..nv).map(|v| s1.links.row_sum(v) < th * pi).collect();
            let b: Vec<Vec3> =
                (0..nv).map(|v| scene.albedo[v] / std::f32::consts::PI * (sol.e_source[v] + raw[v])).collect();
            let mut b2 = b.clone();
            let mut count = 0;
            for v in 0..nv {
                if !hidden[v] {
                    continue;
                }
                count += 1;
                let vis: Vec<usize> = scene
                    .rings
                    .row(v)
                    .iter()
                    .map(|&u| u as usize)
                    .filter(|&u| !hidden[u] && scene.normals[u].dot(scene.normals[v]) > 0.9)
                    .collect();
                if !vis.is_empty() {
                    b2[v] = vis.iter().map(|&u| b[u]).sum::<Vec3>() / vis.len() as f32;
                }
            }
            let diff: Vec<Vec3> = b2.iter().zip(&b).map(|(x, y)| *x - *y).collect();
            let mut de = vec![Vec3::ZERO; nv];
            linkgi::exchange::gather::gather_bounce(&s1.links, &diff, &mut de);
            let fixed: Vec<Vec3> = raw.iter().zip(&de).map(|(e, d)| *e + *d).collect();
            println!(
                "  hidden (row sum < {th} pi): {count} vertices; E_i raw {:.4} -> {:.4}; total {:.4} -> {:.4}",
                ei(raw),
                ei(&fixed),
                tot(raw),
                tot(&fixed)
            );
        }
        if std::env::var_os("CORR").is_some() {
            // Noise alone: the difference of two seeds, smoothed by the fixed filter 1..3 times.
            let mut d: Vec<Vec3> = raw.iter().zip(&sol2.e_indirect_raw).map(|(a, b)| *a - *b).collect();
            let v0 = rms(&d);
            let mut line = "  noise reduction of the fixed filter (rms after / before), passes 1..4:".to_string();
            for _ in 0..4 {
                d = exchange::smooth(&d, &scene.rings, &scene.normals, 30.0);
                line += &format!(" {:.3}", rms(&d) / v0);
            }
            // And of the signal: the reference smoothed (bias of the filter), relative to mean E_i.
            let mut t = r.e_indirect.clone();
            line += "; bias of the fixed filter on the reference, passes 1..4:";
            for _ in 0..4 {
                t = exchange::smooth(&t, &scene.rings, &scene.normals, 30.0);
                line += &format!(" {:.4}", error_stats(&t, &r.e_indirect, &[]).rel_rmse);
            }
            println!("{line}");
        }
        if std::env::var_os("DIAG").is_some() {
            let m = mean(&r.e_indirect);
            for mesh in &scene.meshes {
                let range = mesh.vertices.start as usize..mesh.vertices.end as usize;
                let k = range.len() as f64;
                let (mut se2, mut bias, mut refsum) = (0f64, 0f64, 0f64);
                for v in range.clone() {
                    let d = raw[v] - r.e_indirect[v];
                    se2 += (d.length_squared() - r.e_indirect_stderr[v].length_squared()) as f64 / 3.0;
                    bias += d.element_sum() as f64 / 3.0;
                    refsum += r.e_indirect[v].element_sum() as f64 / 3.0;
                }
                println!(
                    "  {:24} {:6} vertices: E_i rmse (corr.) {:.4} of scene mean, bias {:+.4} of own mean, share of squared error {:.3}",
                    mesh.name,
                    k,
                    (se2.max(0.0) / k).sqrt() / m,
                    bias / refsum,
                    se2 / (ei(raw).powi(2) * m * m * nv as f64)
                );
            }
        }
        println!(
            "{n:5} | {ed:.4} | {edr:.4} | {ei_uncorrected:.4} | {ei_ring:.4} | {ei_point:.4} | {:.4} | {:.3} | {:.4} | {:.4} | {:.4} {:.4} {:.4} | {:.4} | {:.4} | {:.4} {:.4} {:.4} | {mean_beta:.3} | {solve_ms:.0}",
            (actual / (3 * nv) as f64).sqrt() / mean(&r.e_indirect),
            actual / est,
            ei(raw),
            ei(&uniform),
            ei(&adaptive[0]),
            ei(&adaptive[1]),
            ei(&adaptive[2]),
            tot(raw),
            tot(&uniform),
            tot(&adaptive[0]),
            tot(&adaptive[1]),
            tot(&adaptive[2]),
        );
    }
}
