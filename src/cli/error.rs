//! `linkgi error`: sweep rays, bounces and smoothing against the Monte
//! Carlo reference (src/accuracy, src/reference); write errors.csv and
//! errors.png into the output folder and print a summary.

use super::setup::{setup, Overrides, Setup};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use linkgi::accuracy::{self, SweepParams};
use linkgi::reference::{self, ReferenceParams};
use linkgi::scene::TracerKind;
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
    /// Reference cache folder (default target/reference-cache).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scene's setting.
    #[arg(long, value_name = "bvh|kd", value_parser = super::parse_tracer)]
    pub tracer: Option<TracerKind>,
}

pub fn run(args: ErrorArgs) -> Result<()> {
    // The sweep sets rays and bounces itself and runs on the CPU.
    let Setup { prepared, .. } = setup(&args.scene, &Overrides { tracer: args.tracer, ..Default::default() })?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
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
    let bar = ProgressBar::new(params.rays.len() as u64).with_message("ray counts");
    bar.set_style(
        ProgressStyle::with_template("{msg:12} [{bar:40}] {pos}/{len} ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let rows = accuracy::sweep(&prepared, &r, &params, &|done, _| bar.set_position(done as u64));
    bar.finish_and_clear();
    let csv_path = args.out.join("errors.csv");
    std::fs::write(&csv_path, accuracy::csv::to_csv(&prepared.name, &rows))
        .with_context(|| format!("writing {}", csv_path.display()))?;
    let png_path = args.out.join("errors.png");
    accuracy::plot::plot(&prepared.name, &rows, &png_path)?;
    println!("rays  bounces  smoothing  total ms   E_i rmse (noise-corr.)  E_i bias  E_i p95   E_d rmse  total rmse");
    for r in rows.iter().filter(|r| r.bounces == "3" || r.bounces == "auto") {
        println!(
            "{:5} {:>7}  {:>9}  {:8.1}   {:6.4} ({:6.4})        {:+7.4}   {:6.4}    {:6.4}    {:6.4}",
            r.rays,
            r.bounces,
            if r.smoothing_deg > 0.0 { format!("{:.0} deg", r.smoothing_deg) } else { "off".into() },
            r.total_ms,
            r.e_indirect.rel_rmse,
            r.e_indirect.rel_rmse_corrected,
            r.e_indirect.bias,
            r.e_indirect.p95,
            r.e_direct.rel_rmse,
            r.e_total.rel_rmse
        );
    }
    println!("wrote {} and {}", csv_path.display(), png_path.display());
    Ok(())
}
