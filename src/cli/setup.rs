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
//! 4. prepare the scene ([`prep::prepare`]: weld, split, normals), warn
//!    about what preparation dropped, and light a scene that has no lights,
//!    emitters or sky by [`default_sky`] (with a note saying so).
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
    /// auto (a hardware GPU on machines with fewer than 12 CPU threads, else the CPU),
    /// gpu (any adapter, software ones too) or cpu:
    /// where GI runs, and where `render`, `animate` and `view` rasterize (auto and gpu draw
    /// on the first adapter, software ones too, else on the CPU); overrides the scene's setting.
    #[arg(long, value_name = "auto|gpu|cpu", value_parser = parse_backend)]
    pub backend: Option<Backend>,
    /// Optional terms of the solve to switch off, comma-separated (emitter_links, emitter_cv,
    /// near, near_emitters, near_sky, near_gather, reconstruct, hidden, sky_refine, sky_portals,
    /// noise_check, smoothing, sky_smoothing); added to the scene's `off` list.
    #[arg(long, value_name = "TERM[,TERM]", value_parser = parse_off)]
    pub off: Option<Terms>,
    /// Split mesh edges longer than this many metres before solving (a-priori
    /// refinement of coarse meshes: `scene::refine`); off when not given.
    #[arg(long, value_name = "METRES")]
    pub max_edge: Option<f32>,
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

/// The light of a scene that has none (a bare OBJ or glTF of an object):
/// a studio-like gradient sky, W/(m^2 sr): 1 at the zenith, 0.5 at the
/// horizon, 0.1 below ([`linkgi::sky::SkyModel::Gradient`]).
pub fn default_sky() -> linkgi::sky::Sky {
    linkgi::sky::Sky::gradient(glam::Vec3::ONE, glam::Vec3::splat(0.5), glam::Vec3::splat(0.1))
}

/// Steps 1-4: [`load`], then prepares the scene and warns about dropped
/// triangles and a scene without any light (lights, emitters or sky).
pub fn setup(scene: &str, overrides: &Overrides) -> Result<Setup> {
    let mut desc = load(scene, overrides)?;
    if let Some(max_edge) = overrides.max_edge {
        if !(max_edge.is_finite() && max_edge > 0.0) {
            anyhow::bail!("--max-edge {max_edge}: must be positive and finite");
        }
        let params = linkgi::scene::refine::RefineParams { max_edge, max_vertices: 4_000_000 };
        let (refined, stats) = linkgi::scene::refine::refine_scene(&desc, &params);
        let (before, after) = stats.iter().fold((0, 0), |(b, a), s| (b + s.triangles_before, a + s.triangles_after));
        eprintln!("note: edges split to at most {max_edge} m: {before} triangles became {after}");
        desc = refined;
    }
    let prepared = prep::prepare(&desc).with_context(|| format!("preparing scene {scene}"))?;
    if prepared.dropped_triangles > 0 {
        eprintln!("warning: dropped {} zero-area triangles", prepared.dropped_triangles);
    }
    let mut prepared = prepared;
    let emits = prepared.emission.iter().any(|e| *e != glam::Vec3::ZERO);
    if prepared.lights.is_empty() && prepared.sky.is_none() && !emits {
        let sky = default_sky();
        eprintln!(
            "note: the scene has no lights, emitters or sky: lit by a default {} (add a [[light]], emission or [sky] to replace it)",
            sky.describe()
        );
        prepared.sky = Some(sky);
    }
    let settings = desc.settings;
    Ok(Setup { desc, prepared, settings })
}
