//! `linkgi` command-line tool.

mod cli;

use anyhow::Result;
use clap::{Parser, Subcommand};
use linkgi::scene;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "linkgi",
    version,
    about = "Vertex link radiosity: diffuse global illumination for moving lights and deforming meshes"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Build links and solve a scene (a .toml or .obj file, or a built-in name), print figures.
    Solve(cli::solve::SolveArgs),
    /// Benchmark scenes (default: all built-ins) as the paper's two tables.
    Bench {
        /// Scene files or built-in names.
        scenes: Vec<String>,
        /// Ray-shooting backend: cpu, gpu or both.
        #[arg(long, default_value = "cpu")]
        backend: String,
        /// Rays per vertex (a square number).
        #[arg(long, default_value_t = 256)]
        rays: u32,
        /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scenes' setting.
        #[arg(long, value_name = "bvh|kd", value_parser = cli::parse_tracer)]
        tracer: Option<scene::TracerKind>,
        /// Measured runs per scene (after one warm-up run); the median is reported.
        #[arg(long, default_value_t = 5)]
        runs: u32,
        /// Write the figures as JSON.
        #[arg(long, value_name = "FILE")]
        json: Option<PathBuf>,
        /// Write the tables as markdown.
        #[arg(long, value_name = "FILE")]
        markdown: Option<PathBuf>,
    },
    /// Error against the Monte Carlo reference over rays (16..1024), bounces (1..6, auto) and smoothing.
    Error {
        /// Scene file or built-in name.
        scene: String,
        /// Output folder for errors.csv and errors.png.
        #[arg(long, default_value = "out/error")]
        out: PathBuf,
        /// Reference paths per vertex.
        #[arg(long, default_value_t = 4096)]
        ref_samples: u32,
        /// Reference cache folder (default target/reference-cache).
        #[arg(long)]
        cache: Option<PathBuf>,
        /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scene's setting.
        #[arg(long, value_name = "bvh|kd", value_parser = cli::parse_tracer)]
        tracer: Option<scene::TracerKind>,
    },
    /// Render a scene (GI solved first) to a PNG.
    Render(cli::render::RenderArgs),
    /// Animate: move the first light, run deformers, render every frame with the async engine's GI.
    Animate(cli::animate::AnimateArgs),
    /// Interactive window: orbit, move lights, deform, switch views while GI updates (see README).
    View(cli::view::ViewArgs),
    /// Write the built-in scenes as .toml + .obj + .mtl files into DIR.
    Scenes {
        #[arg(default_value = "scenes")]
        dir: PathBuf,
    },
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        None => cli::render::run(cli::render::RenderArgs {
            scene: "cornell".into(),
            out: PathBuf::from("out/cornell.png"),
            exr: None,
            size: "640x480".into(),
            view: linkgi::render::View::Combined,
            backend: "auto".into(),
            exposure: 0.6,
            rays: None,
            tracer: None,
        }),
        Some(Command::Solve(args)) => cli::solve::run(args),
        Some(Command::Render(args)) => cli::render::run(args),
        Some(Command::Animate(args)) => cli::animate::run(args),
        Some(Command::View(args)) => cli::view::run(args),
        Some(Command::Bench { scenes, backend, rays, tracer, runs, json, markdown }) => {
            cli::bench::run(cli::bench::Args { scenes, backend, rays, tracer, runs, json, markdown })
        }
        Some(Command::Error { scene, out, ref_samples, cache, tracer }) => {
            cli::error::run(cli::error::Args { scene, out, ref_samples, cache, tracer })
        }
        Some(Command::Scenes { dir }) => {
            for name in scene::builtin::NAMES {
                let s = scene::builtin::builtin(name).expect("built-in exists");
                let path = scene::file::write_scene(&s, &dir)?;
                println!("wrote {}", path.display());
            }
            Ok(())
        }
    }
}
