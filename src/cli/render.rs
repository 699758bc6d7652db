//! `linkgi render`: solve a scene's GI, rasterize it (or ray trace it on the
//! CPU when there is no adapter) and write a tone-mapped PNG.

use anyhow::{bail, Context, Result};
use linkgi::gpu::Backend;
use linkgi::render::{write_exr, write_png, Frame, RenderParams, Renderer, View};
use linkgi::scene::{self, prep, TracerKind};
use linkgi::solver::{Compute, SolveParams, Solver};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `linkgi render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// Scene file or built-in name.
    pub scene: String,
    /// Output PNG.
    #[arg(long, default_value = "out/render.png")]
    pub out: PathBuf,
    /// Also write the linear radiance (before exposure and tone mapping) as OpenEXR.
    #[arg(long, value_name = "FILE")]
    pub exr: Option<PathBuf>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    pub size: String,
    /// Which light is shown.
    #[arg(long, value_enum, default_value_t = View::Combined)]
    pub view: View,
    /// auto or gpu: rasterize on the first adapter (software ones too), else on the CPU; cpu: the CPU fallback.
    /// GI runs on a hardware GPU (or any adapter with gpu), else on the CPU.
    #[arg(long, default_value = "auto")]
    pub backend: String,
    /// Radiance scale before tone mapping.
    #[arg(long, default_value_t = 0.6)]
    pub exposure: f32,
    /// Rays per vertex of the GI solve (a square number); overrides the scene's setting.
    #[arg(long)]
    pub rays: Option<u32>,
    /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scene's setting.
    #[arg(long, value_name = "bvh|kd", value_parser = crate::cli::parse_tracer)]
    pub tracer: Option<TracerKind>,
}

/// `WxH` -> (W, H).
pub fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) =
        s.split_once(['x', 'X']).with_context(|| format!("--size {s}: expected WIDTHxHEIGHT, e.g. 640x480"))?;
    let (w, h): (u32, u32) = (
        w.trim().parse().with_context(|| format!("--size {s}: bad width"))?,
        h.trim().parse().with_context(|| format!("--size {s}: bad height"))?,
    );
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        bail!("--size {s}: width and height must be in 1..=16384");
    }
    Ok((w, h))
}

pub fn run(args: RenderArgs) -> Result<()> {
    let (width, height) = parse_size(&args.size)?;
    let backend: Backend = args.backend.parse()?;
    let mut desc = scene::load(&args.scene)?;
    for w in &desc.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(r) = args.rays {
        desc.settings.rays_per_vertex = r;
    }
    if let Some(t) = args.tracer {
        desc.settings.tracer = t;
    }
    let gi_backend = if backend == Backend::Cpu { Backend::Cpu } else { backend };
    let (compute, note) = Compute::from_backend(gi_backend, 1)?;
    if let Some(n) = note {
        eprintln!("{n}");
    }
    let prepared = prep::prepare(&desc)?;
    let t0 = Instant::now();
    let solver = Solver::new_on(prepared, SolveParams::from_settings(&desc.settings), &compute, &|_, _| {})?;
    let sol = solver.solve();
    let gi_ms = t0.elapsed().as_secs_f64() * 1e3;
    let renderer = Renderer::open(backend);
    let params = RenderParams { width, height, view: args.view, exposure: args.exposure, ..Default::default() };
    let frame = Frame::of(&solver.scene, &sol.e_indirect, desc.camera);
    let (img, stats) = renderer.render(&frame, &params)?;
    write_png(&img, args.exposure, &args.out)?;
    if let Some(exr) = &args.exr {
        write_exr(&img, exr)?;
        println!("wrote {} (linear radiance, W/(m^2 sr))", exr.display());
    }
    println!(
        "rendered {} ({}x{}, {:?}) on {} in {:.1} ms (GI {:.0} ms on {}); wrote {}",
        solver.scene.name,
        width,
        height,
        args.view,
        renderer.describe(),
        stats.ms,
        gi_ms,
        compute.describe(),
        args.out.display()
    );
    Ok(())
}
