//! `linkgi render`: solve a scene's GI, rasterize it (or ray trace it on the
//! CPU when there is no adapter) and write a tone-mapped PNG.

use super::setup::{compute, setup, Overrides};
use crate::render::exposure::auto_exposure;
use crate::render::{write_exr, write_png, Frame, RenderParams, Renderer, View};
use crate::solver::adaptive::Refined;
use anyhow::{bail, Context, Result};
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
    #[command(flatten)]
    pub overrides: Overrides,
    /// Radiance scale before tone mapping; automatic when not given (the
    /// image's log-average luminance mapped to middle grey 0.18).
    #[arg(long)]
    pub exposure: Option<f32>,
    /// Render the reference path tracer's image instead of the link
    /// solution (same camera and size): ground truth to compare with.
    #[arg(long)]
    pub reference: bool,
    /// Paths per pixel of `--reference`.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
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
    if let Some(e) = args.exposure.filter(|e| !(e.is_finite() && *e > 0.0)) {
        bail!("--exposure {e}: must be positive and finite");
    }
    let setup = setup(&args.scene, &args.overrides)?;
    if args.reference {
        return reference(&args, &setup.desc, &setup.prepared, width, height);
    }
    let settings = setup.settings;
    let compute = compute(settings.backend, 1)?;
    let t0 = Instant::now();
    let Refined { desc, solver, solution: sol, .. } = super::setup::solve_shown(setup, &compute)?;
    let gi_ms = t0.elapsed().as_secs_f64() * 1e3;
    let renderer = Renderer::open(settings.backend);
    let params = RenderParams { width, height, view: args.view, ..Default::default() };
    let camera = super::setup::camera(&desc, solver.scene(), Some(solver.accel()));
    let frame = Frame::of(solver.scene(), &sol.e_indirect, camera).with_sky(&sol.e_sky);
    let (img, stats) = renderer.render(&frame, &params)?;
    let exposure = write_outputs(&img, &args)?;
    println!(
        "rendered {} ({}x{}, {:?}) on {} in {:.1} ms (GI {:.0} ms on {}); exposure {:.4}{}; wrote {}",
        solver.scene().name,
        width,
        height,
        args.view,
        renderer.describe(),
        stats.ms,
        gi_ms,
        compute.describe(),
        exposure,
        if args.exposure.is_some() { "" } else { " (auto)" },
        args.out.display()
    );
    Ok(())
}

/// Writes the PNG (at `--exposure`, else the automatic one) and the EXR
/// when asked; returns the exposure used.
fn write_outputs(img: &crate::render::HdrImage, args: &RenderArgs) -> Result<f32> {
    let exposure = args.exposure.unwrap_or_else(|| auto_exposure(img));
    write_png(img, exposure, &args.out)?;
    if let Some(exr) = &args.exr {
        write_exr(img, exr)?;
        println!("wrote {} (linear radiance, W/(m^2 sr))", exr.display());
    }
    Ok(exposure)
}

/// `render --reference`: the reference path tracer's image, with a progress bar.
fn reference(
    args: &RenderArgs,
    desc: &crate::scene::SceneDesc,
    prepared: &crate::scene::prep::PreparedScene,
    width: u32,
    height: u32,
) -> Result<()> {
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    let t0 = Instant::now();
    let bvh = crate::bvh::Bvh::build(&prepared.positions, &prepared.triangles, &Default::default());
    let camera = super::setup::camera(desc, prepared, Some(&bvh));
    let bar = indicatif::ProgressBar::new(height as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("reference rows [{bar:40}] {pos}/{len} ({eta})")
            .expect("template")
            .progress_chars("=> "),
    );
    let params = crate::reference::ReferenceParams { seed: prepared.settings.seed, ..Default::default() };
    let img =
        crate::reference::image::render(prepared, &bvh, &camera, width, height, args.spp, &params, &|| bar.inc(1));
    bar.finish_and_clear();
    let exposure = write_outputs(&img, args)?;
    println!(
        "rendered the reference of {} ({}x{}, {} paths a pixel) on the CPU in {:.1} s; exposure {:.4}{}; wrote {}",
        prepared.name,
        width,
        height,
        args.spp,
        t0.elapsed().as_secs_f64(),
        exposure,
        if args.exposure.is_some() { "" } else { " (auto)" },
        args.out.display()
    );
    Ok(())
}
