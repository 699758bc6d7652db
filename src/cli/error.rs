//! `linkgi error`: sweep rays, bounces and smoothing against the Monte
//! Carlo reference (src/accuracy, src/reference), run the reference path
//! tracer at a ladder of samples per vertex beside it, score the
//! light-move preview against the full result; write errors.csv and
//! errors.png into the output folder and print a summary.

use super::setup::{setup, Overrides, Setup};
use crate::accuracy::{self, path, preview, SweepParams};
use crate::reference::{self, ReferenceParams};
use crate::scene::TracerKind;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `linkgi error`.
#[derive(clap::Args, Debug)]
pub struct ErrorArgs {
    /// Scene file or built-in name.
    pub scene: String,
    /// Output folder for errors.csv and errors.png.
    #[arg(long, default_value = "out/error")]
    pub out: PathBuf,
    /// Reference paths per vertex.
    #[arg(long, default_value_t = 4096)]
    pub ref_samples: u32,
    /// Samples per vertex of the path tracer beside the link solver, comma-separated
    /// (default 16, 64, 256, ... up to a quarter of --ref-samples; 0: none).
    #[arg(long, value_delimiter = ',')]
    pub path_samples: Option<Vec<u32>>,
    /// Reference cache folder (default target/reference-cache).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Ray tracer: auto, bvh (wide BVH), kd (kd-tree with ropes) or rq (GPU ray queries); overrides the scene's setting.
    #[arg(long, value_name = "auto|bvh|kd|rq", value_parser = super::parse_tracer)]
    pub tracer: Option<TracerKind>,
    /// Optional terms of the solve to switch off, comma-separated (as `solve --off`), to measure what they buy.
    #[arg(long, value_name = "TERM[,TERM]", value_parser = super::setup::parse_off)]
    pub off: Option<crate::scene::terms::Terms>,
    /// Also score the picture: render the link solution (scene's settings, CPU
    /// renderer) and the reference image at the scene's camera, this size
    /// (WIDTHxHEIGHT), and print the mean luminance ratio and the mean 8x8-block
    /// relative error; writes image.png and image_reference.png (same exposure).
    #[arg(long, value_name = "WxH")]
    pub image: Option<String>,
    /// Paths per pixel of the reference image (`--image`).
    #[arg(long, default_value_t = 256)]
    pub image_spp: u32,
    /// Longest edge kept by refinement, metres (as `render --max-edge`).
    #[arg(long, value_name = "METRES")]
    pub max_edge: Option<f32>,
    /// Refinement of coarse meshes: auto (the default) or off.
    #[arg(long, value_name = "auto|off", value_parser = super::setup::parse_refine)]
    pub refine: Option<crate::scene::refine::RefineMode>,
    /// Error-driven refinement's tolerance (as `render --refine-tolerance`).
    #[arg(long, value_name = "SHARE")]
    pub refine_tolerance: Option<f32>,
    /// Most positions refinement may add to the input (as `render --refine-max-added`).
    #[arg(long, value_name = "N")]
    pub refine_max_added: Option<u32>,
    /// Only the picture's score (`--image`): no sweep, no path-tracer ladder.
    #[arg(long)]
    pub image_only: bool,
}

fn bar(len: usize, msg: &'static str) -> ProgressBar {
    let bar = ProgressBar::new(len as u64).with_message(msg);
    bar.set_style(
        ProgressStyle::with_template("{msg:12} [{bar:40}] {pos}/{len} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar
}

pub fn run(args: ErrorArgs) -> Result<()> {
    // The sweep sets rays and bounces itself and runs on the CPU.
    let Setup { desc, prepared, plan, .. } = setup(
        &args.scene,
        &Overrides {
            tracer: args.tracer,
            off: args.off,
            max_edge: args.max_edge,
            refine: args.refine,
            refine_tolerance: args.refine_tolerance,
            refine_max_added: args.refine_max_added,
            ..Default::default()
        },
    )?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    if let Some(size) = &args.image {
        image_score(&args, size, &desc, &prepared, &plan)?;
        if args.image_only {
            return Ok(());
        }
    }
    let cache = args.cache.clone().unwrap_or_else(reference::cache::default_dir);
    let rp = ReferenceParams { samples_per_vertex: args.ref_samples, ..Default::default() };
    eprintln!(
        "reference: {} vertices x {} paths (cached under {})...",
        prepared.vertex_count(),
        rp.samples_per_vertex,
        cache.display()
    );
    let t = Instant::now();
    let r = reference::compute_cached(&prepared, &rp, &cache);
    eprintln!(
        "reference {} in {:.1} s",
        if r.from_cache { "read from the cache" } else { "computed" },
        t.elapsed().as_secs_f64()
    );
    let params = SweepParams::default();
    let b = bar(params.rays.len(), "ray counts");
    let rows = accuracy::sweep(&prepared, &r, &params, &|done, _| b.set_position(done as u64))?;
    b.finish_and_clear();
    let ladder_samples: Vec<u32> = match &args.path_samples {
        Some(s) => s.iter().copied().filter(|&s| s > 0).collect(),
        None => path::default_ladder(args.ref_samples),
    };
    let b = bar(ladder_samples.len(), "path tracer");
    let ladder = path::ladder(&prepared, &r, &ladder_samples, &|done, _| b.set_position(done as u64));
    b.finish_and_clear();
    let angle = rows.iter().map(|r| r.smoothing_deg).fold(0.0, f32::max);
    let preview = preview::score(&prepared, angle)?;
    let csv_path = args.out.join("errors.csv");
    std::fs::write(&csv_path, accuracy::csv::to_csv(&prepared.name, &rows, &ladder, preview.as_ref()))
        .with_context(|| format!("writing {}", csv_path.display()))?;
    let png_path = args.out.join("errors.png");
    accuracy::plot::plot(&prepared.name, &rows, &ladder, &png_path)?;
    println!(
        "rays  bounces  smoothing  total ms   E_i rmse (noise-corr.)  E_i bias  E_i p95   E_d rmse  total rmse (corr.)  path tracer at equal time"
    );
    for r in rows.iter().filter(|r| r.bounces == "3" || r.bounces == "auto") {
        let equal = accuracy::csv::equal_time(&ladder, r.total_ms, r.e_total.rel_rmse_corrected)
            .map_or(String::new(), |(p, ratio)| format!("{p:6.4} ({ratio:.1}x)"));
        println!(
            "{:5} {:>7}  {:>9}  {:8.1}   {:6.4} ({:6.4})        {:+7.4}   {:6.4}    {:6.4}    {:6.4} ({:6.4})     {equal}",
            r.rays,
            r.bounces,
            if r.smoothing_deg > 0.0 { format!("{:.0} deg", r.smoothing_deg) } else { "off".into() },
            r.total_ms,
            r.e_indirect.rel_rmse,
            r.e_indirect.rel_rmse_corrected,
            r.e_indirect.bias,
            r.e_indirect.p95,
            r.e_direct.rel_rmse,
            r.e_total.rel_rmse,
            r.e_total.rel_rmse_corrected,
        );
    }
    if !ladder.is_empty() {
        println!("path tracer: samples  ms        E_i rmse (corr.)  total rmse (corr.)");
        for p in &ladder {
            println!(
                "             {:7}  {:8.1}  {:6.4} ({:6.4})   {:6.4} ({:6.4})",
                p.samples,
                p.ms,
                p.e_indirect.rel_rmse,
                p.e_indirect.rel_rmse_corrected,
                p.e_total.rel_rmse,
                p.e_total.rel_rmse_corrected
            );
        }
    }
    if let Some(p) = &preview {
        // Without one-ring oversampling the preview traces the full column
        // and the refinement traces nothing.
        let rays = if p.full_shadow_rays == 0 {
            format!("{} shadow rays, already the full column", p.preview_shadow_rays)
        } else {
            format!("{} shadow rays, then {} for the full column", p.preview_shadow_rays, p.full_shadow_rays)
        };
        println!(
            "light-move preview ({} rays, {rays}, {:.1} ms against {:.1} ms): against the full result E_d rmse {:.4}, E_i rmse {:.4}, total rmse {:.4}",
            p.rays,
            p.preview_ms,
            p.full_ms,
            p.e_direct.rel_rmse,
            p.e_indirect.rel_rmse,
            p.e_total.rel_rmse
        );
    }
    println!("wrote {} and {}", csv_path.display(), png_path.display());
    Ok(())
}

/// `error --image`: the link solution's picture against the reference image.
fn image_score(
    args: &ErrorArgs,
    size: &str,
    desc: &crate::scene::SceneDesc,
    prepared: &crate::scene::prep::PreparedScene,
    plan: &crate::solver::adaptive::Plan,
) -> Result<()> {
    use crate::render::{cpu::render_cpu, exposure::auto_exposure, write_png, Frame, RenderParams};
    let (w, h) = super::render::parse_size(size)?;
    if args.image_spp == 0 {
        anyhow::bail!("--image-spp must be at least 1");
    }
    // The link solution as `render` makes it (refined where the light needs it), on the CPU.
    let mut settings = prepared.settings;
    settings.backend = crate::scene::Backend::Cpu;
    let setup = Setup { desc: desc.clone(), prepared: prepared.clone(), settings, plan: plan.clone() };
    let refined = super::setup::solve(setup, &crate::solver::Compute::Cpu, &|_, _| {})?;
    let (solver, sol) = (&refined.solver, &refined.solution);
    eprintln!(
        "link solution: {} vertices ({} before refinement)",
        solver.scene().vertex_count(),
        prepared.vertex_count()
    );
    let bvh = crate::bvh::Bvh::build(&prepared.positions, &prepared.triangles, &Default::default());
    let camera = super::setup::camera(desc, prepared, Some(&bvh));
    let params = RenderParams { width: w, height: h, ..Default::default() };
    let frame = Frame::of(solver.scene(), &sol.e_indirect, camera).with_sky(&sol.e_sky);
    let s = solver.scene();
    let refined_bvh = crate::bvh::Bvh::build(&s.positions, &s.triangles, &Default::default());
    let (ours, _) = render_cpu(&frame, &params, Some(&refined_bvh))?;
    let rp = ReferenceParams { seed: prepared.settings.seed, ..Default::default() };
    let t = Instant::now();
    let cache = args.cache.clone().unwrap_or_else(reference::cache::default_dir);
    let key = reference::cache::image_key(prepared, &rp, &camera, (w, h), args.image_spp);
    let reference = match reference::cache::load_image(&cache, key).filter(|r| (r.width, r.height) == (w, h)) {
        Some(r) => {
            eprintln!("reference image read from the cache ({})", cache.display());
            r
        }
        None => {
            let b = bar(h as usize, "image ref");
            let r = reference::image::render(prepared, &bvh, &camera, w, h, args.image_spp, &rp, &|| b.inc(1));
            b.finish_and_clear();
            if let Err(e) = reference::cache::store_image(&cache, key, &r) {
                eprintln!("warning: could not cache the reference image in {}: {e}", cache.display());
            }
            r
        }
    };
    let exposure = auto_exposure(&reference);
    let (a, r) = (args.out.join("image.png"), args.out.join("image_reference.png"));
    write_png(&ours, exposure, &a)?;
    write_png(&reference, exposure, &r)?;
    match reference::image::score(&ours, &reference) {
        Some(s) => println!(
            "picture {w}x{h} against the reference image ({} paths a pixel, {:.1} s): mean luminance ratio {:.4}, \
             mean 8x8-block error {:.4} over {} lit blocks; wrote {} and {}",
            args.image_spp,
            t.elapsed().as_secs_f64(),
            s.mean_ratio,
            s.block_error,
            s.blocks,
            a.display(),
            r.display()
        ),
        None => println!("the reference image is black: no score; wrote {} and {}", a.display(), r.display()),
    }
    Ok(())
}
