//! The `linkgi` command-line tool: the argument parser and its
//! subcommands, one file each (the binary `src/main.rs` calls [`run`]).

pub mod animate;
pub mod bench;
pub mod error;
pub mod logger;
pub mod render;
pub mod runtime_dir;
pub mod setup;
pub mod solve;
#[cfg(feature = "viewer")]
pub mod view;

use crate::scene::TracerKind;

/// Parses `--tracer` (clap value parser): "auto", "bvh", "kd" or "rq".
pub fn parse_tracer(s: &str) -> Result<TracerKind, String> {
    s.parse::<TracerKind>().map_err(|_| format!("unknown tracer \"{s}\": expected auto, bvh, kd or rq"))
}

use crate::scene;
use anyhow::Result;
use clap::{Parser, Subcommand};
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
    Solve(solve::SolveArgs),
    /// Benchmark scenes (default: all built-ins) as the paper's two tables.
    Bench(bench::BenchArgs),
    /// Error against the Monte Carlo reference over rays (16..1024), bounces (1..6, auto) and smoothing.
    Error(error::ErrorArgs),
    /// Render a scene (GI solved first) to a PNG.
    Render(render::RenderArgs),
    /// Animate: move the first light, run deformers, render every frame with the async engine's GI.
    Animate(animate::AnimateArgs),
    /// Interactive window: orbit, move lights, deform, switch views while GI updates (see README).
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
    /// Write the built-in scenes as .toml + .obj + .mtl files into DIR.
    Scenes {
        #[arg(default_value = "scenes")]
        dir: PathBuf,
    },
}

/// The `linkgi` command line: parses the process arguments and runs the
/// subcommand (the binary's whole `main`).
pub fn run() -> Result<()> {
    // Before any thread or GPU instance: libwayland's headless noise (src/cli/runtime_dir.rs).
    runtime_dir::ensure();
    logger::install();
    let cli = Cli::parse();
    match cli.command {
        None => render::run(render::RenderArgs {
            scene: "cornell".into(),
            out: PathBuf::from("out/cornell.png"),
            exr: None,
            size: "640x480".into(),
            view: crate::render::View::Combined,
            overrides: setup::Overrides::default(),
            exposure: None,
            reference: false,
            spp: 64,
        }),
        Some(Command::Solve(args)) => solve::run(args),
        Some(Command::Render(args)) => render::run(args),
        Some(Command::Animate(args)) => animate::run(args),
        #[cfg(feature = "viewer")]
        Some(Command::View(args)) => view::run(args),
        Some(Command::Bench(args)) => bench::run(args),
        Some(Command::Error(args)) => error::run(args),
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
