//! `linkgi bench`: the paper's two tables for each scene (src/bench),
//! printed as markdown, optionally written as JSON and markdown files.

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use linkgi::bench::{self, Backend, BenchParams};
use linkgi::scene::{self, TracerKind};
use std::path::PathBuf;

pub struct Args {
    pub scenes: Vec<String>,
    pub backend: String,
    pub rays: u32,
    /// Overrides each scene's `tracer` setting.
    pub tracer: Option<TracerKind>,
    pub runs: u32,
    pub json: Option<PathBuf>,
    pub markdown: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
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
        let mut d = scene::load(n).with_context(|| format!("loading scene {n}"))?;
        if let Some(t) = args.tracer {
            d.settings.tracer = t;
        }
        descs.push(d);
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
