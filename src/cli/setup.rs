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

use crate::scene::prep::{self, PreparedScene};
use crate::scene::terms::Terms;
use crate::scene::{self, Backend, Bounces, SceneDesc, Settings, TracerKind};
use crate::solver::{adaptive, Compute};
use anyhow::{Context, Result};

/// Command-line overrides of the scene's settings; `None` keeps the scene's value.
/// The flags are flattened into `solve`, `render`, `animate` and `view`.
#[derive(clap::Args, Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    /// Rays per vertex of the GI solve (a square number); overrides the scene's setting.
    #[arg(long)]
    pub rays: Option<u32>,
    /// Ray tracer: auto (the BVH on the CPU; on a GPU, ray queries where the adapter has them, else
    /// the BVH), bvh (wide BVH), kd (kd-tree with ropes) or rq (GPU ray queries); overrides the scene.
    #[arg(long, value_name = "auto|bvh|kd|rq", value_parser = super::parse_tracer)]
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
    /// Terms to keep on whatever a sample of their work says (near_emitters, near_sky,
    /// near_gather are decided per scene otherwise), comma-separated; added to the scene's `on`.
    #[arg(long, value_name = "TERM[,TERM]", value_parser = parse_on)]
    pub on: Option<Terms>,
    /// Refinement of coarse meshes: auto (the default: edges split to the target length, then
    /// where the light needs it) or off; overrides the scene's `refine` setting.
    #[arg(long, value_name = "auto|off", value_parser = parse_refine)]
    pub refine: Option<crate::scene::refine::RefineMode>,
    /// Longest edge kept by refinement, metres (default: 8% of the scene's diagonal).
    #[arg(long, value_name = "METRES")]
    pub max_edge: Option<f32>,
    /// Error-driven refinement splits an edge where its ends' irradiance differ by more than
    /// this share of their mean (default 0.25).
    #[arg(long, value_name = "SHARE")]
    pub refine_tolerance: Option<f32>,
    /// Most positions refinement may add to the input (default 250000).
    #[arg(long, value_name = "N")]
    pub refine_max_added: Option<u32>,
    /// The lighting mesh's triangle budget: a denser input has its dense
    /// static meshes simplified to fit it (default 300000, at least 1000).
    #[arg(long, value_name = "N")]
    pub refine_max_triangles: Option<u32>,
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
        if let Some(t) = self.on {
            for name in t.on() {
                settings.forced.set(name, true).expect("a name of Terms::NAMES");
            }
        }
        if let Some(m) = self.refine {
            settings.refine.mode = m;
        }
        if let Some(e) = self.max_edge {
            settings.refine.max_edge = e;
        }
        if let Some(t) = self.refine_tolerance {
            settings.refine.tolerance = t;
        }
        if let Some(n) = self.refine_max_added {
            settings.refine.max_added = n;
        }
        if let Some(n) = self.refine_max_triangles {
            settings.refine.max_triangles = n;
        }
        settings
    }
}

/// Parses `--refine` (clap value parser): "auto" or "off".
pub fn parse_refine(s: &str) -> Result<crate::scene::refine::RefineMode, String> {
    use crate::scene::refine::RefineMode;
    match s {
        "auto" => Ok(RefineMode::Auto),
        "off" => Ok(RefineMode::Off),
        _ => Err(format!("{s}: expected auto or off")),
    }
}

/// Parses `--on` (clap value parser): term names separated by commas.
pub fn parse_on(s: &str) -> Result<Terms, String> {
    Terms::with_on(s.split(',').filter(|n| !n.trim().is_empty()))
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
    /// What refinement does (made before the a-priori step that `desc` has had).
    pub plan: adaptive::Plan,
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
    tracer: Option<&dyn crate::trace::CpuTracer>,
) -> crate::scene::Camera {
    let (camera, framing) = crate::render::framing::camera_or_framed(desc.camera, prepared, tracer);
    if let Some(f) = framing {
        eprintln!("note: the scene has no camera; framed it as {}", f.describe());
    }
    camera
}

/// Whether `desc` has any light: a light, a sky, or an emissive material
/// or vertex.
fn has_light(desc: &SceneDesc) -> bool {
    !desc.lights.is_empty()
        || desc.sky.is_some()
        || desc.meshes.iter().any(|m| {
            m.materials.iter().any(|mat| mat.emission != glam::Vec3::ZERO)
                || m.vertex_emission.as_ref().is_some_and(|e| e.iter().any(|x| *x != glam::Vec3::ZERO))
        })
}

/// Solves `setup`'s scene on `compute`, refining its coarse meshes where
/// the light needs it (`crate::solver::adaptive`; one solve of the
/// prepared scene when there are none or refinement is off) and saying
/// what the rounds did.
pub fn solve(
    setup: Setup,
    compute: &Compute,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<crate::solver::adaptive::Refined> {
    let refined = adaptive::solve_planned(setup.desc, setup.prepared, &setup.plan, compute, progress)?;
    if refined.rounds.len() > 1 {
        let list: Vec<String> =
            refined.rounds.iter().map(|r| format!("{} ({:.1} s)", r.vertices, r.ms / 1e3)).collect();
        eprintln!("note: refined where the light needs it: vertices per round {}", list.join(", "));
    }
    Ok(refined)
}

/// [`solve`] with a progress bar across the refinement rounds: each
/// round's link rays, by vertices (a round's count falls back when the
/// next one starts), and the elapsed time while the other parts trace.
pub fn solve_shown(setup: Setup, compute: &Compute) -> Result<crate::solver::adaptive::Refined> {
    use indicatif::{ProgressBar, ProgressStyle};
    use std::sync::atomic::{AtomicUsize, Ordering};
    let rounds = if setup.plan.refining { crate::solver::adaptive::MAX_ROUNDS + 1 } else { 1 };
    let bar = ProgressBar::new(setup.prepared.vertex_count() as u64);
    bar.set_style(
        ProgressStyle::with_template("{msg:24} [{bar:40}] {pos}/{len} vertices ({elapsed})")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    let (round, last) = (AtomicUsize::new(1), AtomicUsize::new(0));
    let say = |r: usize| {
        if rounds > 1 {
            format!("round {r} (of up to {rounds})")
        } else {
            "shooting rays".to_string()
        }
    };
    bar.set_message(say(1));
    let refined = solve(setup, compute, &|done, total| {
        if done < last.swap(done, Ordering::Relaxed) {
            bar.set_message(say(round.fetch_add(1, Ordering::Relaxed) + 1));
        }
        bar.set_length(total as u64);
        bar.set_position(done as u64)
    });
    bar.finish_and_clear();
    refined
}

/// The light of a scene that has none (a bare OBJ or glTF of an object):
/// a studio-like gradient sky, W/(m^2 sr): 1 at the zenith, 0.5 at the
/// horizon, 0.1 below ([`crate::sky::SkyModel::Gradient`]).
pub fn default_sky() -> crate::sky::Sky {
    crate::sky::Sky::gradient(glam::Vec3::ONE, glam::Vec3::splat(0.5), glam::Vec3::splat(0.1))
}

/// Steps 1-4: [`load`], then prepares the scene and warns about dropped
/// triangles and a scene without any light (lights, emitters or sky).
pub fn setup(scene: &str, overrides: &Overrides) -> Result<Setup> {
    let mut desc = load(scene, overrides)?;
    if !has_light(&desc) {
        let sky = default_sky();
        eprintln!(
            "note: the scene has no lights, emitters or sky: lit by a default {} (add a [[light]], emission or [sky] to replace it)",
            sky.describe()
        );
        desc.sky = Some(sky);
    }
    let before: usize = desc.meshes.iter().map(|m| m.triangles.len()).sum();
    let plan = adaptive::Plan::of(&desc);
    if plan.apriori {
        desc = crate::scene::refine::apriori(&desc, &desc.settings.refine).0;
    }
    let prepared = prep::prepare(&desc).with_context(|| format!("preparing scene {scene}"))?;
    if prepared.dropped_triangles > 0 {
        eprintln!("warning: dropped {} zero-area triangles", prepared.dropped_triangles);
    }
    let after: usize = desc.meshes.iter().map(|m| m.triangles.len()).sum();
    if after > before {
        eprintln!(
            "note: coarse meshes refined to edges of at most {:.3} m: {before} triangles became {after} \
             (--max-edge sets the length, --refine off keeps the meshes)",
            desc.settings.refine.target_edge(&desc)
        );
    }
    let settings = desc.settings;
    Ok(Setup { desc, prepared, settings, plan })
}
