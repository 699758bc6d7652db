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
    /// Write the built-in scenes as .toml + .obj + .mtl files into DIR.
    Scenes {
        #[arg(default_value = "scenes")]
        dir: PathBuf,
    },
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        None => cli::solve::run(cli::solve::SolveArgs {
            scene: "cornell".into(),
            export: Some(PathBuf::from("out/cornell")),
            devices: 1,
            ..Default::default()
        }),
        Some(Command::Solve(args)) => cli::solve::run(args),
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
