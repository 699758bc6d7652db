//! `linkgi solve`: build links for a scene, solve, print the figures table,
//! optionally export PLY + JSON.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use linkgi::scene::{self, prep, Bounces, TracerKind};
use linkgi::solver::{Compute, SolveParams, Solver};
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
    /// Scene file or built-in name (cornell, furnace, colorlamp, torso, tearoom, sculpture, conference).
    pub scene: String,
    /// Rays per vertex (a square number); overrides the scene's setting.
    #[arg(long)]
    pub rays: Option<u32>,
    /// Number of bounces or "auto"; overrides the scene's setting.
    #[arg(long)]
    pub bounces: Option<String>,
    /// Seed of the ray directions; overrides the scene's setting.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Write DIR/mesh.ply and DIR/scene.json.
    #[arg(long, value_name = "DIR")]
    pub export: Option<PathBuf>,
    /// auto (a hardware GPU, else the CPU), gpu (any adapter, software ones too) or cpu; overrides the scene.
    #[arg(long)]
    pub backend: Option<String>,
    /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scene's setting.
    #[arg(long, value_name = "bvh|kd", value_parser = super::parse_tracer)]
    pub tracer: Option<TracerKind>,
    /// Logical devices per adapter (exercises the multi-device scheduler on one GPU).
    #[arg(long, default_value_t = 1)]
    pub devices: usize,
}

pub fn run(args: SolveArgs) -> Result<()> {
    let SolveArgs { scene: scene_name, rays, bounces, seed, export, backend, tracer, devices } = args;
    let t0 = Instant::now();
    let mut desc = scene::load(&scene_name)?;
    for w in &desc.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(r) = rays {
        desc.settings.rays_per_vertex = r;
    }
    if let Some(b) = bounces {
        desc.settings.bounces = parse_bounces(&b)?;
    }
    if let Some(s) = seed {
        desc.settings.seed = s;
    }
    if let Some(b) = backend {
        desc.settings.backend = b.parse()?;
    }
    if let Some(t) = tracer {
        desc.settings.tracer = t;
    }
    let (compute, note) = Compute::from_backend(desc.settings.backend, devices)?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    let prepared = prep::prepare(&desc)?;
    if prepared.dropped_triangles > 0 {
        eprintln!("warning: dropped {} zero-area triangles", prepared.dropped_triangles);
    }
    if prepared.lights.is_empty() {
        eprintln!("warning: the scene has no lights: all irradiance is zero");
    }
    let prep_ms = t0.elapsed().as_secs_f64() * 1e3;
    let n = prepared.vertex_count() as u64;
    let bar = ProgressBar::new(n).with_message("shooting rays");
    bar.set_style(
        ProgressStyle::with_template("{msg:16} [{bar:40}] {pos}/{len} vertices ({eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let params = SolveParams::from_settings(&prepared.settings);
    let solver = Solver::new_on(prepared, params, &compute, &|done, _| bar.set_position(done as u64))?;
    bar.finish_and_clear();
    let t1 = Instant::now();
    let solution = solver.solve();
    let solve_ms = t1.elapsed().as_secs_f64() * 1e3;
    let stats = solver.stats(&solution, solve_ms - solution.gather.ms);
    let s = &stats;
    let mb = |b: u64| b as f64 / 1e6;
    println!("scene            {}", solver.scene.name);
    println!("backend          {}", s.backend);
    println!("vertices         {}", s.vertices);
    println!("triangles        {}", s.triangles);
    println!("tracer           {}", s.tracer);
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
        "links merged     {} ({:.2} MB, {:.1}x fewer)",
        s.links.merged_links,
        mb(s.links.merged_bytes),
        s.links.raw_links as f64 / s.links.merged_links.max(1) as f64
    );
    println!("rays             {} ({} missed, {} back faces)", s.links.rays, s.links.misses, s.links.back_hits);
    println!("prep ms          {prep_ms:.1}");
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
    println!(
        "bounces ms       {:.1} ({} bounces, tail {:.2e}{})",
        s.gather_ms,
        s.bounces,
        s.tail_relative,
        if solution.gather.tail_added { " added" } else { "" }
    );
    println!("smoothing ms     {:.1}", s.smooth_ms);
    println!("total ms         {:.1}", t0.elapsed().as_secs_f64() * 1e3);
    if let Some(b) = linkgi::bench::memory::peak_bytes() {
        println!("peak memory MB   {:.0}", b as f64 / 1e6);
    }
    if let Some(dir) = export {
        linkgi::export::export(&dir, &solver.scene, &solution, &stats)?;
        println!("wrote            {} and {}", dir.join("mesh.ply").display(), dir.join("scene.json").display());
    }
    Ok(())
}
