//! Error of the link solver against the reference on a scene, per mesh and
//! per quantity (E_sky, E_i, total): `cargo run --release --example sky_probe -- window 256 1024 [seed]`.
//! Overrides: `EMITTER_SAMPLES=n` (emitter-link rays), `SKY_SUB=s` (sky refinement), `NOISE_SCALE=x`
//! (the smoothing's noise calibration), `NOISE_CHECK=m` (its check's vertices), `NOISE_K=k` (neighbours of its local ratio), `LINKERS=k` (a hidden vertex's stand-ins), `NEAR=c` (near hits' length factor), `SMOOTH_SKY=0|1`, `PORTAL_RAYS=m` (rays a vertex and portal), `NEAR_EMITTER=m` (points a near hit and emitter group), `NEAR_SKY=m`, `NEAR_SKY_PORTAL=m` (near hits' sky directions and portal points), `EMITTER_CV=0|1`, `NEAR_GATHER=m` (the final gather's rays a near hit), `REF_DEPTH=d` (the reference's longest path), `SKY_OFF=1`, `EMIT_OFF=1`, `DUMP=file.csv` (per-vertex values), `RECONSTRUCT=0|1` (the radiosity correction at link hits).
use glam::Vec3;
use linkgi::accuracy::metrics::error_stats;
use linkgi::reference::{self, ReferenceParams};
use linkgi::scene::{self, prep, Bounces};
use linkgi::solver::{SolveParams, Solver};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("window");
    let rays: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let samples: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let mut desc = scene::load(name).unwrap();
    desc.settings.rays_per_vertex = rays;
    desc.settings.bounces = match std::env::var("BOUNCES") {
        Ok(b) => Bounces::Fixed(b.parse().unwrap()),
        Err(_) => Bounces::Auto,
    };
    desc.settings.seed = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1);
    if std::env::var("SKY_OFF").is_ok() {
        desc.sky = None;
    }
    if std::env::var("EMIT_OFF").is_ok() {
        for m in &mut desc.meshes {
            for mat in &mut m.materials {
                mat.emission = Vec3::ZERO;
            }
        }
    }
    let s = prep::prepare(&desc).unwrap();
    let mut sp = SolveParams::from_settings(&desc.settings);
    if let Ok(r) = std::env::var("RECONSTRUCT") {
        sp.reconstruct = r != "0";
    }
    if let Ok(n) = std::env::var("EMITTER_SAMPLES") {
        sp.emitter.samples = n.parse().unwrap();
    }
    if let Ok(x) = std::env::var("SKY_SUB") {
        sp.sky.sub = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NOISE_CHECK") {
        sp.smoothing.noise.check_vertices = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NEAR") {
        sp.links.near.factor = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("LINKERS") {
        sp.hidden.linkers = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NOISE_K") {
        sp.smoothing.noise.check_neighbours = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("SMOOTH_SKY") {
        sp.smoothing.sky = x == "1";
    }
    if let Ok(x) = std::env::var("NEAR_EMITTER") {
        sp.near_emitter.samples = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NEAR_GATHER") {
        sp.near_gather.rays = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("EMITTER_CV") {
        sp.emitter_cv = x == "1";
    }
    if let Ok(x) = std::env::var("NEAR_SKY") {
        sp.near_sky.samples = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NEAR_SKY_PORTAL") {
        sp.near_sky.portal_samples = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("PORTAL_RAYS") {
        sp.sky.portal.rays = x.parse().unwrap();
    }
    if let Ok(x) = std::env::var("NOISE_SCALE") {
        sp.smoothing.noise.scale = x.parse().unwrap();
    }
    let solver = Solver::new(s, sp, &|_, _| {});
    eprintln!("emitter links: {} rays, {:.1} ms", solver.emitter_links.shadow_rays, solver.emitter_links.ms);
    eprintln!(
        "near sky: {} rays, {} kept, {:.1} ms; near hits {}",
        solver.near_sky.shadow_rays,
        solver.near_sky.dirs.len(),
        solver.near_sky.ms,
        solver.links.near.hits.len()
    );
    eprintln!(
        "sky refinement: {} rays ({:.2} a link ray), {:.1} ms",
        solver.sky_refine.rays,
        solver.sky_refine.rays as f64 / (rays as f64 * solver.scene.vertex_count() as f64),
        solver.sky_refine.ms
    );
    let sol = solver.solve();
    eprintln!(
        "noise ratio {:.3} (model {:.3}; check {} vertices, {} rays, {:.1} ms)",
        solver.noise_ratio(&sol.e_source, &sol.e_indirect_raw),
        solver.params.smoothing.noise.ratio(rays),
        solver.noise_check.vertices.len(),
        solver.noise_check.rays,
        solver.noise_check.ms
    );
    let r = reference::compute_cached(
        &solver.scene,
        &ReferenceParams {
            samples_per_vertex: samples,
            max_depth: std::env::var("REF_DEPTH").map(|d| d.parse().unwrap()).unwrap_or(64),
            ..Default::default()
        },
        &reference::cache::default_dir(),
    );
    let total = sol.total();
    let rt = r.total();
    for m in &solver.scene.meshes {
        let rg = m.vertices.start as usize..m.vertices.end as usize;
        let pick = |v: &[Vec3]| v[rg.clone()].to_vec();
        let t = error_stats(&pick(&total), &pick(&rt), &pick(&r.e_total_stderr));
        let k = error_stats(&pick(&sol.e_sky), &pick(&r.e_sky), &[]);
        let i = error_stats(&pick(&sol.e_indirect), &pick(&r.e_indirect), &pick(&r.e_indirect_stderr));
        let mean = |v: &[Vec3]| v[rg.clone()].iter().map(|e| e.element_sum() / 3.0).sum::<f32>() / rg.len() as f32;
        println!(
            "{:24} total {:.4} (bias {:+.4})  sky {:.4} (bias {:+.4}, mean {:.3} vs {:.3})  E_i {:.4} (bias {:+.4}, mean {:.3} vs {:.3})",
            m.name, t.rel_rmse_corrected, t.bias, k.rel_rmse, k.bias, mean(&sol.e_sky), mean(&r.e_sky),
            i.rel_rmse_corrected, i.bias, mean(&sol.e_indirect), mean(&r.e_indirect)
        );
    }
    if let Ok(path) = std::env::var("DUMP") {
        let mut out = String::from("v,mesh,x,y,z,nx,ny,nz,sol,ref,stderr,e_em,sky,refsky,raw\n");
        for (mi, m) in solver.scene.meshes.iter().enumerate() {
            for v in m.vertices.clone() {
                let v = v as usize;
                let (p, n) = (solver.scene.positions[v], solver.scene.normals[v]);
                out += &format!(
                    "{v},{mi},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                    p.x,
                    p.y,
                    p.z,
                    n.x,
                    n.y,
                    n.z,
                    total[v].element_sum() / 3.0,
                    rt[v].element_sum() / 3.0,
                    r.e_total_stderr[v].element_sum() / 3.0,
                    sol.e_emitter[v].element_sum() / 3.0,
                    sol.e_sky[v].element_sum() / 3.0,
                    r.e_sky[v].element_sum() / 3.0,
                    (sol.e_direct[v] + sol.e_sky[v] + sol.e_indirect_raw[v]).element_sum() / 3.0
                );
            }
        }
        std::fs::write(path, out).unwrap();
    }
    let t = error_stats(&total, &rt, &r.e_total_stderr);
    println!("all: total {t:?}");
    println!("all: sky {:?}", error_stats(&sol.e_sky, &r.e_sky, &[]));
    let raw: Vec<Vec3> = (0..total.len()).map(|v| sol.e_direct[v] + sol.e_sky[v] + sol.e_indirect_raw[v]).collect();
    let exact_sky: Vec<Vec3> = (0..total.len()).map(|v| sol.e_direct[v] + r.e_sky[v] + sol.e_indirect[v]).collect();
    println!("all, reference sky: {:?}", error_stats(&exact_sky, &rt, &r.e_total_stderr));
    println!("all, E_i only: {:?}", error_stats(&sol.e_indirect, &r.e_indirect, &r.e_indirect_stderr));
    println!("all, E_em vs reference E_i: {:?}", error_stats(&sol.e_emitter, &r.e_indirect, &r.e_indirect_stderr));
    for m in &solver.scene.meshes {
        let rg = m.vertices.start as usize..m.vertices.end as usize;
        let pick = |v: &[Vec3]| v[rg.clone()].to_vec();
        println!(
            "{:24} E_em vs ref E_i {:?}",
            m.name,
            error_stats(&pick(&sol.e_emitter), &pick(&r.e_indirect), &pick(&r.e_indirect_stderr))
        );
    }
    println!("all, unsmoothed: {:?}", error_stats(&raw, &rt, &r.e_total_stderr));
}
