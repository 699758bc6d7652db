//! `linkgi view`: an interactive window that shows the scene with the
//! asynchronous engine's newest GI while lights move and meshes deform.
//!
//! Presentation ([`display`]): on any adapter that can present to the
//! window, the wgpu rasterizer renders into its HDR target, a display pass
//! tone-maps it into the swap chain and an egui panel ([`panel`]) draws the
//! figures (fps, GI updates/s, age of the shown GI, links, bounces, stage
//! times) and the controls (view mode, light, intensity, rays per vertex,
//! exposure, deformation, screenshot) on top, with a ring over each point
//! light. With `--backend cpu`, no adapter or no presentable surface, frames
//! go through the offscreen renderer and `softbuffer` instead, with the
//! figures in the window title and the keys as controls.
//!
//! The render loop never waits for the engine: it draws with
//! [`Engine::latest`] (direct light only until the first GI is out).
//!
//! Controls: left-drag orbit, right-drag pan, wheel zoom; left-drag a light's
//! ring to move the light horizontally (at its height), PageUp/PageDown
//! move the selected light up/down, arrow keys in x/z; `L` selects the next
//! light; `Space` plays/pauses the scene's deformers; `1`/`2`/`3`
//! combined/direct/indirect; `+`/`-` scale the selected light's intensity;
//! `[`/`]` rays per vertex x0.25/x4; `P` writes a screenshot PNG; `Esc`
//! quits. Mouse and keys go to the panel when it is under the pointer or
//! has focus.
//!
//! `--script FILE` runs timed actions ([`script`]).
//!
//! Files: this one holds the arguments, the viewer's state and its setup;
//! [`window`] the event loop and the frame; [`input`] keys and mouse;
//! [`edit`] light (and rays) edits; [`script`] the script's parser and
//! runner; [`orbit`] the camera; [`display`] and [`panel`] the drawing.

mod display;
mod edit;
mod input;
mod orbit;
mod panel;
mod refining;
mod script;
mod window;

use super::setup::{compute, setup, Overrides, Setup};
use crate::engine::{Engine, EngineParams};
use crate::gpu::Backend;
use crate::render::{Frame, View};
use crate::scene::deform::has_deformers;
use crate::scene::prep::PreparedScene;
use crate::scene::{Light, Settings};
use crate::solver::SolveParams;
use anyhow::{bail, Context, Result};
use display::Display;
use glam::Vec3;
use input::Drag;
use orbit::Orbit;
use script::{parse_script, Action, GiWait, ScriptLine};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use window::PendingShots;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event_loop::{ControlFlow, EventLoop};
use winit::window::Window;

/// Arguments of `linkgi view`.
#[derive(clap::Args, Debug)]
pub struct ViewArgs {
    /// Scene file or built-in name.
    pub scene: String,
    /// Initial window size, WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600")]
    pub size: String,
    /// Timed actions to run (see `linkgi view --help` and the README).
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// Where `P` and the script's `screenshot` write PNGs.
    #[arg(long, value_name = "DIR", default_value = "screenshots")]
    pub screenshot_dir: PathBuf,
    /// Radiance scale before tone mapping; automatic when not given (small
    /// probe renders' log-average luminance mapped to middle grey, followed
    /// smoothly and held while a light moves).
    #[arg(long)]
    pub exposure: Option<f32>,
    #[command(flatten)]
    pub overrides: Overrides,
    /// Present without waiting for the display's refresh (measures the real frame rate).
    #[arg(long)]
    pub no_vsync: bool,
    /// Draw through the offscreen renderer and a CPU blit even where a swap chain
    /// works (no panel; figures in the title). For broken window drivers and comparisons.
    #[arg(long)]
    pub blit: bool,
}

/// The viewer's state: the scene as shown (deformed positions, edited
/// lights), the engine, the display, input and script progress, figures.
struct Viewer {
    prepared: PreparedScene,
    rest: Vec<Vec3>,
    rest_normals: Vec<Vec3>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    zeros: Vec<Vec3>,
    deforms: bool,
    engine: Engine,
    gi_device: String,
    backend: Backend,
    vsync: bool,
    blit: bool,
    display: Option<Display>,
    display_name: String,
    lights: Vec<Light>,
    intensity_range: Vec<(f32, f32)>,
    selected: usize,
    /// Each mesh's name and emitted exitance as edited (the strongest vertex's), W/m^2.
    mesh_emission: Vec<(String, Vec3)>,
    /// The mesh the panel's emission slider edits.
    selected_mesh: usize,
    /// The sky as edited.
    sky: Option<crate::sky::Sky>,
    settings: Settings,
    rays_k: u32,
    orbit: Orbit,
    extent: f32,
    view: View,
    /// The exposure shown.
    exposure: f32,
    /// Automatic exposure (`None`: fixed, from `--exposure` or the panel).
    auto_exposure: Option<crate::render::exposure::AutoExposure>,
    playing: bool,
    anim_time: f32,
    last_tick: Instant,
    size: PhysicalSize<u32>,
    shot_dir: PathBuf,
    shots: u32,
    pending: PendingShots,
    script: Vec<ScriptLine>,
    script_file: PathBuf,
    script_pos: usize,
    wait: Option<GiWait>,
    wait_file_since: Option<Instant>,
    opened: Option<Instant>,
    shown_version: u64,
    drag: Option<Drag>,
    cursor: Option<PhysicalPosition<f64>>,
    frames: u64,
    hud_at: Instant,
    hud_frames: u64,
    hud_published: u64,
    fps: f64,
    gi_ups: f64,
    window: Option<Arc<Window>>,
    error: Option<anyhow::Error>,
    quit: bool,
    /// The error-driven rounds running in the background ([`refining`]), until the final one lands.
    refining: Option<crossbeam_channel::Receiver<refining::Landed>>,
    /// The light of the newest landed round, drawn until the engine has a result for its mesh.
    round_gi: Option<Arc<crate::engine::GiResult>>,
    /// Rounds drawn so far.
    rounds_landed: usize,
    /// Each mesh's emission as loaded (edits differ from it and are sent again after a new mesh).
    loaded_emission: Vec<(String, Vec3)>,
}

pub fn run(args: ViewArgs) -> Result<()> {
    let (width, height) = super::render::parse_size(&args.size)?;
    if let Some(e) = args.exposure.filter(|e| !(e.is_finite() && *e > 0.0)) {
        bail!("--exposure {e}: must be positive and finite");
    }
    let (script, script_file) = match &args.script {
        Some(f) => {
            let text = std::fs::read_to_string(f).with_context(|| format!("reading script {}", f.display()))?;
            (parse_script(&text, f)?, f.clone())
        }
        None => (Vec::new(), PathBuf::new()),
    };
    // Before the scene and the engine: no display fails fast.
    let event_loop = EventLoop::new().context("opening the window system (is DISPLAY or WAYLAND_DISPLAY set?)")?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let Setup { desc, prepared, settings, plan } = setup(&args.scene, &args.overrides)?;
    let backend = settings.backend;
    for step in &script {
        let at = || format!("{}:{}", script_file.display(), step.line);
        match step.action {
            Action::SetEmission { mesh, .. } if mesh >= prepared.meshes.len() => {
                bail!("{}: mesh {mesh}: the scene has {} mesh(es)", at(), prepared.meshes.len())
            }
            Action::SetSky { .. } if prepared.sky.is_none() => bail!("{}: set_sky: the scene has no sky", at()),
            _ => {}
        }
        if let Action::MoveLight { index, .. } | Action::SetIntensity { index, .. } = step.action {
            if index >= prepared.lights.len() {
                bail!(
                    "{}:{}: light {index}: the scene has {} light(s)",
                    script_file.display(),
                    step.line,
                    prepared.lights.len()
                );
            }
        }
    }
    let compute = compute(backend, 1)?;
    let gi_device = compute.describe();
    // The a-priori mesh at once (the engine), the error-driven rounds behind it.
    let refining = (plan.refining && !has_deformers(&prepared))
        .then(|| refining::start(desc.clone(), prepared.clone(), plan.clone(), compute.clone()));
    let camera = super::setup::camera(&desc, &prepared, None);
    let extent = Frame::of(&prepared, &prepared.positions, camera).extent();
    let engine = Engine::start(
        prepared.clone(),
        SolveParams::from_settings(&settings),
        compute,
        // Moving a light or deforming shows a quick preview first (see EngineParams).
        EngineParams { light_preview: true, deform_preview: true, ..Default::default() },
    )?;
    let n = prepared.positions.len();
    let intensity_range = prepared
        .lights
        .iter()
        .map(|l| {
            let base = l.strength().max(1e-6);
            (base * 1e-2, base * 1e2)
        })
        .collect();
    let mesh_emission: Vec<(String, Vec3)> = prepared
        .meshes
        .iter()
        .map(|m| {
            let r = m.vertices.start as usize..m.vertices.end as usize;
            let e =
                prepared.emission[r]
                    .iter()
                    .fold(Vec3::ZERO, |a, e| if e.max_element() > a.max_element() { *e } else { a });
            (m.name.clone(), e)
        })
        .collect();
    let mut viewer = Viewer {
        refining,
        round_gi: None,
        rounds_landed: 0,
        loaded_emission: mesh_emission.clone(),
        mesh_emission,
        selected_mesh: 0,
        sky: prepared.sky.clone(),
        rest: prepared.positions.clone(),
        rest_normals: prepared.normals.clone(),
        positions: prepared.positions.clone(),
        normals: prepared.normals.clone(),
        zeros: vec![Vec3::ZERO; n],
        deforms: has_deformers(&prepared),
        lights: prepared.lights.clone(),
        intensity_range,
        settings,
        rays_k: (settings.rays_per_vertex as f64).sqrt().round() as u32,
        prepared,
        engine,
        gi_device,
        backend,
        vsync: !args.no_vsync,
        blit: args.blit,
        display: None,
        display_name: String::new(),
        selected: 0,
        orbit: Orbit::from_camera(camera),
        extent,
        view: View::Combined,
        exposure: args.exposure.unwrap_or(crate::render::DEFAULT_EXPOSURE),
        auto_exposure: args
            .exposure
            .is_none()
            .then(|| crate::render::exposure::AutoExposure::new(crate::render::DEFAULT_EXPOSURE)),
        playing: false,
        anim_time: 0.0,
        last_tick: Instant::now(),
        size: PhysicalSize::new(width, height),
        shot_dir: args.screenshot_dir,
        shots: 0,
        pending: PendingShots::default(),
        script,
        script_file,
        script_pos: 0,
        wait: None,
        wait_file_since: None,
        opened: None,
        shown_version: 0,
        drag: None,
        cursor: None,
        frames: 0,
        hud_at: Instant::now(),
        hud_frames: 0,
        hud_published: 0,
        fps: 0.0,
        gi_ups: 0.0,
        window: None,
        error: None,
        quit: false,
    };
    event_loop.run_app(&mut viewer).context("running the window's event loop")?;
    if let Some(e) = viewer.error.take() {
        return Err(e);
    }
    if let Some(opened) = viewer.opened {
        let secs = opened.elapsed().as_secs_f64();
        let published = viewer.engine.counters().published;
        println!(
            "{} frames in {secs:.2} s ({:.1} fps); {published} GI results ({:.2} per s) on {}",
            viewer.frames,
            viewer.frames as f64 / secs.max(1e-9),
            published as f64 / secs.max(1e-9),
            viewer.display_name
        );
    }
    Ok(())
}
