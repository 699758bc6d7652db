//! `linkgi solve`: build links for a scene, solve, print the figures table,
//! optionally export PLY + JSON.

use super::setup::{compute, setup, Overrides};
use crate::scene::deform::{deform_scene, has_deformers};
use crate::scene::refine::RefineMode;
use crate::scene::Bounces;
use anyhow::{Context, Result};
use std::path::PathBuf;
use std::time::Instant;

pub fn parse_bounces(s: &str) -> Result<Bounces> {
    if s == "auto" {
        return Ok(Bounces::Auto);
    }
    let n: u32 = s.parse().with_context(|| format!("--bounces {s}: expected a number or \"auto\""))?;
    Ok(Bounces::Fixed(n))
}

/// Arguments of `linkgi solve`.
#[derive(clap::Args, Debug, Default)]
pub struct SolveArgs {
    /// Scene file (.toml, .obj, .gltf, .glb) or built-in name (cornell, furnace, colorlamp, torso, tearoom, dancer, sculpture, conference).
    pub scene: String,
    /// Evaluate the scene's deformers at this time, seconds, and solve that pose (default: the rest pose).
    #[arg(long, value_name = "T")]
    pub time: Option<f32>,
    #[command(flatten)]
    pub overrides: Overrides,
    /// Number of bounces or "auto"; overrides the scene's setting.
    #[arg(long)]
    pub bounces: Option<String>,
    /// Seed of the ray directions; overrides the scene's setting.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write DIR/mesh.ply and DIR/scene.json.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
    /// Logical devices per adapter (exercises the multi-device scheduler on one GPU).
    #[arg(long, default_value_t = 1)]
    pub devices: usize,
}

pub fn run(args: SolveArgs) -> Result<()> {
    let SolveArgs { scene: scene_name, time, mut overrides, bounces, seed, export, devices } = args;
    let t0 = Instant::now();
    overrides.bounces = bounces.as_deref().map(parse_bounces).transpose()?;
    overrides.seed = seed;
    let mut setup = setup(&scene_name, &overrides)?;
    let settings = setup.settings;
    if let Some(t) = time {
        if !t.is_finite() {
            anyhow::bail!("--time {t}: expected a finite number of seconds");
        }
        let prepared = &mut setup.prepared;
        if has_deformers(prepared) {
            let (positions, normals) = deform_scene(prepared, &prepared.positions, &prepared.normals, t);
            prepared.positions = positions;
            prepared.normals = normals;
        } else {
            eprintln!("warning: scene {scene_name} has no deformers: --time {t} solves the rest pose");
        }
        // Error-driven rounds re-prepare the rest pose: a posed solve is one solve.
        setup.desc.settings.refine.mode = RefineMode::Off;
    }
    let compute = compute(settings.backend, devices)?;
    let prep_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let refined = super::setup::solve_shown(setup, &compute)?;
    let (solver, solution) = (&refined.solver, &refined.solution);
    let total_ms = t1.elapsed().as_secs_f64() * 1e3;
    let solve_ms = refined.rounds.last().map_or(0.0, |r| r.solve_ms);
    let stats = solver.stats(solution, solve_ms - solution.gather.ms);
    let s = &stats;
    let mb = |b: u64| b as f64 / 1e6;
    println!("scene            {}", solver.scene().name);
    println!("backend          {}", s.backend);
    println!("vertices         {}", s.vertices);
    println!("triangles        {}", s.triangles);
    match solver.gpu() {
        Some(g) => println!("tracer           {} ({})", s.tracer, g.tracer.walk().reason(solver.params().tracer)),
        None => println!("tracer           {}", s.tracer),
    }
    println!(
        "cpu-traced rays  {} of {} ({:.1}%)",
        s.cpu_traced_rays,
        s.traced_rays(),
        100.0 * s.cpu_traced_rays as f64 / s.traced_rays().max(1) as f64
    );
    if let Some(k) = &s.kd {
        println!(
            "kd nodes         {} ({} leaves, {:.2} tris/leaf, depth {}, SAH cost {:.1})",
            k.nodes, k.leaves, k.mean_leaf_triangles, k.max_depth, k.sah_cost
        );
    }
    if let Some(b) = &s.bvh {
        println!(
            "bvh nodes        {} 8-wide ({} leaves, {:.2} tris/leaf, depth {}, SAH cost {:.1}, {:.1} MB)",
            b.nodes,
            b.leaves,
            b.mean_leaf_triangles,
            b.max_depth,
            b.sah_cost,
            s.accel_bytes as f64 / 1e6
        );
    }
    println!("links raw        {} ({:.2} MB)", s.links.raw_links, mb(s.links.raw_bytes));
    println!(
        "links merged     {} ({:.2} MB packed, {:.2} bytes a link, {:.1}x fewer)",
        s.links.merged_links,
        mb(s.links.merged_bytes),
        s.links.merged_bytes as f64 / s.links.merged_links.max(1) as f64,
        s.links.raw_links as f64 / s.links.merged_links.max(1) as f64
    );
    println!("rays             {} ({} missed, {} back faces)", s.links.rays, s.links.misses, s.links.back_hits);
    if s.ray_state_bytes > 0 {
        println!(
            "ray state        {:.2} MB (hit id per ray, for selective updates of dynamic meshes)",
            mb(s.ray_state_bytes)
        );
    }
    if let Some(sky) = &solver.scene().sky {
        let seeing = solution.e_sky.iter().filter(|e| **e != glam::Vec3::ZERO).count();
        println!(
            "sky              {} ({} vertices see it, mean E_sky {:.3} W/m^2, visibility {:.2} MB)",
            sky.describe(),
            seeing,
            solution.e_sky.iter().map(|e| e.element_sum() / 3.0).sum::<f32>() / solution.e_sky.len().max(1) as f32,
            mb(solver.links().sky.bytes())
        );
        let r = &solver.sky_rays().refine;
        if !r.is_empty() {
            println!(
                "sky refinement   {} cells with an edge, {} rays ({}x{} a cell) in {:.1} ms, {:.2} MB",
                r.cells.items.len(),
                r.rays,
                r.sub,
                r.sub,
                r.ms,
                mb(r.bytes())
            );
        }
        let p = &solver.sky_rays().portals;
        if !p.is_empty() {
            println!(
                "sky portals      {} portal(s), {} rays ({} a vertex and portal) in {:.1} ms, {:.2} MB",
                p.portals.len(),
                p.rays,
                p.side * p.side,
                p.ms,
                mb(p.bytes())
            );
        }
    }
    let check = &solver.noise_check();
    if !check.is_empty() && solution.smoothed {
        println!(
            "noise check      {} vertices, {} rays in {:.1} ms: actual / independent-ray variance {:.3} (model {:.3})",
            check.vertices.len(),
            check.rays,
            check.ms,
            solver.noise_ratio(&solution.e_source, &solution.e_gathered),
            solver.params().smoothing.noise.ratio(solver.params().links.rays_per_vertex)
        );
    }
    let emitters = solver.scene().emission.iter().filter(|e| **e != glam::Vec3::ZERO).count();
    if emitters > 0 {
        let e = &solver.emitter_links();
        let mean = solution.e_emitter.iter().map(|e| e.element_sum() / 3.0).sum::<f32>()
            / solution.e_emitter.len().max(1) as f32;
        match &e.fallback {
            None if e.is_active() => {
                println!(
                    "emitters         {emitters} vertices emit, {} groups: mean direct E {mean:.3} W/m^2, {} shadow rays in {:.1} ms ({} of {} vertices in penumbra traced past the pilot)",
                    e.group_vertex.len(),
                    e.shadow_rays,
                    e.ms,
                    e.penumbra.0,
                    e.penumbra.1
                );
                if !solution.e_cv.is_empty() {
                    let mean_abs = solution.e_cv.iter().map(|d| d.abs().element_sum() / 3.0).sum::<f32>()
                        / solution.e_cv.len().max(1) as f32;
                    println!(
                        "                 their control variate of the first bounce: mean |D| {mean_abs:.4} W/m^2"
                    );
                }
            }
            None => println!("emitters         {emitters} vertices emit (their light through the vertex links)"),
            Some(why) => println!("emitters         {emitters} vertices emit; no emitter links: {why}"),
        }
    }
    println!("prep ms          {prep_ms:.1}");
    if refined.rounds.len() > 1 {
        let list: Vec<String> = refined.rounds.iter().map(|r| r.vertices.to_string()).collect();
        println!(
            "refine rounds    {} (vertices {}; {total_ms:.0} ms with every round's links and solve)",
            refined.rounds.len(),
            list.join(" -> ")
        );
        for (i, r) in refined.rounds.iter().enumerate() {
            println!(
                "  round {}        {} vertices, {} edges split{}: links {:.0} ms ({} rays traced, {} carried), \
                 solve {:.0} ms, round {:.0} ms",
                i + 1,
                r.vertices,
                r.marked,
                if r.wanted > r.marked { format!(" of {} marked (budget)", r.wanted) } else { String::new() },
                r.links_ms,
                r.rays_traced,
                r.rays_carried,
                r.solve_ms,
                r.ms
            );
            if r.marked > 0 {
                let parts: Vec<String> = r
                    .parts
                    .iter()
                    .map(|(name, c)| {
                        let how = if c.selective { format!(", {} vertices redone", c.redone) } else { String::new() };
                        format!("{name} {:.0} ms ({} rays{how})", c.ms, c.rays)
                    })
                    .collect();
                if !parts.is_empty() {
                    println!("                 {}", parts.join("; "));
                }
            }
            if r.final_rays > 0 {
                println!(
                    "                 then the final mesh at full rays: {} link rays and every other part in {:.0} ms",
                    r.final_rays, r.final_ms
                );
            }
        }
        let carried: u64 = refined.rounds.iter().map(|r| r.rays_carried).sum();
        let traced: u64 = refined.rounds.iter().map(|r| r.rays_traced).sum();
        if carried > 0 {
            println!(
                "refine rays      {traced} traced, {carried} carried over from the round before ({:.0}%)",
                100.0 * carried as f64 / (carried + traced) as f64
            );
        }
    }
    println!("{} build ms     {:.1}", if s.bvh.is_some() { "bvh" } else { "kd " }, s.accel_build_ms);
    println!("links ms         {:.1} ({:.2} M rays/s)", s.links.shoot_ms, s.links.rays_per_second() / 1e6);
    for d in &s.devices {
        println!(
            "  device         {}: {} batches, {} vertices, {:.2} M rays/s",
            d.label,
            d.batches,
            d.vertices,
            d.rays_per_second / 1e6
        );
    }
    println!(
        "light links ms   {:.1} ({} shadow rays, {:.2} M/s)",
        s.light_links_ms,
        s.shadow_rays,
        s.shadow_rays_per_second / 1e6
    );
    if s.near_hits > 0 {
        println!(
            "near hits        {} ({:.1}% of the rays; exact direct light at them: {} shadow rays, {:.1} ms; \
             emitters' light at them: {} shadow rays, {:.1} ms; the sky's: {} rays, {:.1} ms, {:.2} MB; \
             the final gather from them: {} rays, {:.1} ms, {:.2} MB)",
            s.near_hits,
            100.0 * s.near_hits as f64 / s.links.rays.max(1) as f64,
            s.near_rays,
            s.near_ms,
            s.near_emitter_rays,
            s.near_emitter_ms,
            s.near_sky_rays,
            s.near_sky_ms,
            mb(solver.near().sky.cost.bytes),
            s.near_gather_rays,
            s.near_gather_ms,
            mb(solver.near().gather.cost.bytes)
        );
    }
    for d in solver.term_decisions() {
        println!("term decided     {}", d.describe());
    }
    println!(
        "bounces ms       {:.1} ({} bounces, tail {:.2e}{})",
        s.gather_ms,
        s.bounces,
        s.tail_relative,
        if solution.gather.tail_added { " added" } else { "" }
    );
    println!("smoothing ms     {:.1}", s.smooth_ms);
    println!("total ms         {:.1}", t0.elapsed().as_secs_f64() * 1e3);
    if let Some(b) = crate::bench::memory::peak_bytes() {
        println!("peak memory MB   {:.0}", b as f64 / 1e6);
    }
    if let Some(dir) = export {
        crate::export::export(&dir, &solver.scene(), &solution, &stats)?;
        println!("wrote            {} and {}", dir.join("mesh.ply").display(), dir.join("scene.json").display());
    }
    Ok(())
}
