//! `linkgi bench`: the paper's two tables for each scene (src/bench),
//! printed as markdown, optionally written as JSON and markdown files.

use super::setup::{self, Overrides};
use crate::bench::{self, Backend, BenchParams};
use crate::scene::{self, TracerKind};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// Arguments of `linkgi bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Scene files, built-in names, or a benchmark scene (`glowsphere`:
    /// the Cornell box with a sphere whose every vertex emits).
    pub scenes: Vec<String>,
    /// Ray-shooting backend: cpu, gpu or both.
    #[arg(long, default_value = "cpu")]
    pub backend: String,
    /// Rays per vertex (a square number).
    #[arg(long, default_value_t = 256)]
    pub rays: u32,
    /// Ray tracer: auto, bvh (wide BVH), kd (kd-tree with ropes) or rq (GPU ray queries); overrides the scenes' setting.
    #[arg(long, value_name = "auto|bvh|kd|rq", value_parser = super::parse_tracer)]
    pub tracer: Option<TracerKind>,
    /// Measured runs per scene (after one warm-up run); the median is reported.
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the tables as markdown.
    #[arg(long, value_name = "FILE")]
    pub markdown: Option<PathBuf>,
    /// The scaling table instead: the one scene given, subdivided at these
    /// levels (4^k times its triangles each; e.g. `0,1,2,3`), each solved
    /// as `solve` does (the lighting mesh simplified past the budget), with
    /// its time, peak memory and picture against the first level's.
    #[arg(long, value_name = "LEVELS", value_delimiter = ',')]
    pub scale: Vec<u32>,
    /// Where `--scale` writes each level's picture (`level<k>.png`).
    #[arg(long, value_name = "DIR", default_value = "bench-scale")]
    pub out: PathBuf,
}

pub fn run(args: BenchArgs) -> Result<()> {
    let backend: Backend = args.backend.parse()?;
    let computes = backend.computes()?;
    let names: Vec<String> = if args.scenes.is_empty() {
        scene::builtin::NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        args.scenes.clone()
    };
    let params = BenchParams { rays_per_vertex: args.rays, runs: args.runs.max(1), ..Default::default() };
    let mut descs = Vec::new();
    for n in &names {
        // Each run prepares the scene itself (src/bench); rays and backend come from the flags above.
        let overrides = Overrides { rays: Some(args.rays), tracer: args.tracer, ..Default::default() };
        descs.push(match bench::scenes::scene(n) {
            Some(mut d) => {
                d.settings = overrides.apply(d.settings);
                d.settings.validate().with_context(|| format!("settings of scene {n}"))?;
                d
            }
            None => setup::load(n, &overrides)?,
        });
    }
    if !args.scale.is_empty() {
        return scale(&args, &descs, &computes);
    }
    let per_scene = (params.warmup + params.runs) as u64;
    let bar = ProgressBar::new(per_scene * (descs.len() * computes.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{msg:12} [{bar:40}] {pos}/{len} runs ({elapsed}, eta {eta})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    // The machine's read bandwidth, the yardstick of the CPU gather.
    let read_gbps = if computes.iter().any(|c| c.0 == "CPU") {
        bench::bandwidth::read_bandwidth_gbps(512 << 20, 5)
    } else {
        f64::NAN
    };
    let mut rows = Vec::new();
    for d in &descs {
        for c in &computes {
            bar.set_message(format!("{} {}", d.name, c.0));
            let mut row = bench::run_scene(d, &params, c, &|| bar.inc(1))?;
            row.read_gbps = read_gbps;
            rows.push(row);
        }
    }
    bar.finish_and_clear();
    let md = bench::markdown(&rows);
    println!("{md}");
    for (label, c) in &computes {
        println!("{label}: {}", c.describe());
    }
    if computes.iter().any(|c| c.0 == "CPU") {
        match bench::peer::find() {
            Some(p) => println!("Embree peer: {}", p.display()),
            None => println!(
                "Embree peer: not found (build it with `make -C {}` or set {}); no Embree figures",
                bench::peer::DEFAULT_PATH.trim_end_matches("/peer"),
                bench::peer::ENV
            ),
        }
    }
    if let Some(p) = &args.json {
        let text =
            serde_json::to_string_pretty(&serde_json::json!({ "backend": backend, "params": params, "rows": rows }))?;
        std::fs::write(p, text).with_context(|| format!("writing {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &args.markdown {
        std::fs::write(p, &md).with_context(|| format!("writing {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// `bench --scale`: the scaling table of one scene on the first backend.
fn scale(args: &BenchArgs, descs: &[scene::SceneDesc], computes: &[(String, crate::solver::Compute)]) -> Result<()> {
    let [desc] = descs else { anyhow::bail!("--scale takes one scene ({} given)", descs.len()) };
    let (label, compute) = computes.first().context("no backend to run on")?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut written = Vec::new();
    let rows = bench::scale::run(
        desc,
        &args.scale,
        compute,
        (320, 240),
        &|level| eprintln!("{}: level {level} ({label})", desc.name),
        &mut |level, img| {
            let path = args.out.join(format!("level{level}.png"));
            match crate::render::write_png(img, crate::auto_exposure(img), &path) {
                Ok(()) => written.push(path),
                Err(e) => log::warn!("{e}"),
            }
        },
    )?;
    let md = bench::scale::markdown(&desc.name, &rows, desc.settings.refine.max_triangles);
    println!("{md}");
    println!("{label}: {}", compute.describe());
    for p in &written {
        println!("wrote {}", p.display());
    }
    if let Some(p) = &args.json {
        std::fs::write(p, serde_json::to_string_pretty(&serde_json::json!({ "scene": desc.name, "rows": rows }))?)
            .with_context(|| format!("writing {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &args.markdown {
        std::fs::write(p, &md).with_context(|| format!("writing {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
