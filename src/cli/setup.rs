//! The setup every scene-running subcommand (`solve`, `render`, `animate`,
//! `view`, `bench`, `error`) shares, so they cannot drift apart:
//!
//! 1. load the scene (a `.toml`, a bare `.obj` or a built-in name);
//! 2. print the loader's warnings (clamped albedo, missing MTL, ...) to
//!    stderr as `warning: ...`, and its notes (what it assumed: how an
//!    emission was read) as `note: ...`;
//! 3. apply the command line's [`Overrides`] of the scene's `[settings]`
//!    (`--rays`, `--tracer`, `--backend`, `--off`; `solve` also `--bounces`, `--seed`)
//!    and check the result;
//! 4. prepare the scene ([`prep::prepare`]: weld, split, normals) and warn
//!    about what preparation dropped and about a scene without lights.
//!
//! [`load`] is steps 1-3 (for `bench`, which prepares per run itself);
//! [`setup`] is all four.

use anyhow::{Context, Result};
use linkgi::scene::prep::{self, PreparedScene};
use linkgi::scene::terms::Terms;
use linkgi::scene::{self, Backend, Bounces, SceneDesc, Settings, TracerKind};
use linkgi::solver::Compute;

/// Command-line overrides of the scene's settings; `None` keeps the scene's value.
/// The flags are flattened into `solve`, `render`, `animate` and `view`.
#[derive(clap::Args, Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// Rays per vertex of the GI solve (a square number); overrides the scene's setting.
    #[arg(long)]
    pub rays: Option<u32>,
    /// CPU ray tracer: bvh (wide BVH) or kd (kd-tree with ropes); overrides the scene's setting.
    #[arg(long, value_name = "bvh|kd", value_parser = super::parse_tracer)]
    pub tracer: Option<TracerKind>,
    /// auto (a hardware GPU, else the CPU), gpu (any adapter, software ones too) or cpu:
    /// where GI runs, and where `render`, `animate` and `view` rasterize (auto and gpu draw
    /// on the first adapter, software ones too, else on the CPU); overrides the scene's setting.
    #[arg(long, value_name = "auto|gpu|cpu", value_parser = parse_backend)]
    pub backend: Option<Backend>,
    /// Optional terms of the solve to switch off, comma-separated (emitter_links, emitter_cv,
    /// near, near_emitters, near_sky, near_gather, reconstruct, hidden, sky_refine, sky_portals,
    /// noise_check, smoothing, sky_smoothing); added to the scene's `off` list.
    #[arg(long, value_name = "TERM[,TERM]", value_parser = parse_off)]
    pub off: Option<Terms>,
    /// Number of bounces (`solve --bounces`).
    #[arg(skip)]
    pub bounces: Option<Bounces>,
    /// Seed of the ray directions (`solve --seed`).
    #[arg(skip)]
    pub seed: Option<u64>,
}

impl Overrides {
    /// `settings` with every given override applied.
    pub fn apply(&self, mut settings: Settings) -> Settings {
        if let Some(r) = self.rays {
            settings.rays_per_vertex = r;
        }
        if let Some(t) = self.tracer {
            settings.tracer = t;
        }
        if let Some(b) = self.backend {
            settings.backend = b;
        }
        if let Some(b) = self.bounces {
            settings.bounces = b;
        }
        if let Some(s) = self.seed {
            settings.seed = s;
        }
        if let Some(t) = self.off {
            for name in t.off() {
                settings.terms.set(name, false).expect("a name of Terms::NAMES");
            }
        }
        settings
    }
}

/// Parses `--off` (clap value parser): term names separated by commas.
pub fn parse_off(s: &str) -> Result<Terms, String> {
    Terms::with_off(s.split(',').filter(|n| !n.trim().is_empty()))
}

/// Parses `--backend` (clap value parser): "auto", "gpu" or "cpu".
pub fn parse_backend(s: &str) -> Result<Backend, String> {
    s.parse::<Backend>().map_err(|e| e.to_string())
}

/// A loaded, overridden and prepared scene.
pub struct Setup {
    /// The scene as loaded, with the overrides in `desc.settings`.
    pub desc: SceneDesc,
    /// The prepared scene (its `settings` are the effective ones too).
    pub prepared: PreparedScene,
    /// The effective settings: the scene's with the overrides applied.
    pub settings: Settings,
}

/// Where GI runs for `backend` (the effective setting), with `devices`
/// logical devices per adapter; prints the note when `auto` falls back to the CPU.
pub fn compute(backend: Backend, devices: usize) -> Result<Compute> {
    let (compute, note) = Compute::from_backend(backend, devices)?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    Ok(compute)
}

/// Steps 1-3: loads `scene`, prints its warnings and notes, applies and checks `overrides`.
pub fn load(scene: &str, overrides: &Overrides) -> Result<SceneDesc> {
    let mut desc = scene::load(scene).with_context(|| format!("loading scene {scene}"))?;
    for w in &desc.warnings {
        eprintln!("warning: {w}");
    }
    for n in &desc.notes {
        eprintln!("note: {n}");
    }
    desc.settings = overrides.apply(desc.settings);
    desc.settings.validate().with_context(|| format!("settings of scene {scene}"))?;
    Ok(desc)
}

/// The scene's camera, or one framed automatically (with a note saying
/// where it stands), traced through `tracer` or a BVH built for it.
pub fn camera(
    desc: &SceneDesc,
    prepared: &PreparedScene,
    tracer: Option<&dyn linkgi::trace::CpuTracer>,
) -> linkgi::scene::Camera {
    let (camera, framing) = linkgi::render::framing::camera_or_framed(desc.camera, prepared, tracer);
    if let Some(f) = framing {
        eprintln!("note: the scene has no camera; framed it as {}", f.describe());
    }
    camera
}

/// Steps 1-4: [`load`], then prepares the scene and warns about dropped
/// triangles and a scene without any light (lights, emitters or sky).
pub fn setup(scene: &str, overrides: &Overrides) -> Result<Setup> {
    let desc = load(scene, overrides)?;
    let prepared = prep::prepare(&desc).with_context(|| format!("preparing scene {scene}"))?;
    if prepared.dropped_triangles > 0 {
        eprintln!("warning: dropped {} zero-area triangles", prepared.dropped_triangles);
    }
    let emits = prepared.emission.iter().any(|e| *e != glam::Vec3::ZERO);
    if prepared.lights.is_empty() && prepared.sky.is_none() && !emits {
        eprintln!("warning: the scene has no lights, emitters or sky: all irradiance is zero");
    }
    let settings = desc.settings;
    Ok(Setup { desc, prepared, settings })
}
