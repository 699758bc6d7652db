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
    /// Build links and solve a scene (a .toml, .obj, .gltf or .glb file, or a built-in name), print figures.
    Solve(cli::solve::SolveArgs),
    /// Benchmark scenes (default: all built-ins) as the paper's two tables.
    Bench(cli::bench::BenchArgs),
    /// Error against the Monte Carlo reference over rays (16..1024), bounces (1..6, auto) and smoothing.
    Error(cli::error::ErrorArgs),
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
    // Before any thread or GPU instance: libwayland's headless noise (src/cli/runtime_dir.rs).
    cli::runtime_dir::ensure();
    cli::logger::install();
    let cli = Cli::parse();
    match cli.command {
        None => cli::render::run(cli::render::RenderArgs {
            scene: "cornell".into(),
            out: PathBuf::from("out/cornell.png"),
            exr: None,
            size: "640x480".into(),
            view: linkgi::render::View::Combined,
            overrides: cli::setup::Overrides::default(),
            exposure: None,
            reference: false,
            spp: 64,
        }),
        Some(Command::Solve(args)) => cli::solve::run(args),
        Some(Command::Render(args)) => cli::render::run(args),
        Some(Command::Animate(args)) => cli::animate::run(args),
        Some(Command::View(args)) => cli::view::run(args),
        Some(Command::Bench(args)) => cli::bench::run(args),
        Some(Command::Error(args)) => cli::error::run(args),
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
