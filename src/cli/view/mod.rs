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

mod display;
mod orbit;
mod panel;
mod script;

use super::setup::{compute, setup, Overrides, Setup};
use anyhow::{bail, Context, Result};
use display::{Capture, Display};
use glam::{Vec2, Vec3};
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::engine::{Change, Engine, EngineParams, GiResult};
use linkgi::gpu::Backend;
use linkgi::kdtree::Ray;
use linkgi::render::{Frame, RenderParams, View};
use linkgi::scene::deform::{deform_scene, has_deformers};
use linkgi::scene::prep::PreparedScene;
use linkgi::scene::{Light, Settings};
use linkgi::solver::SolveParams;
use orbit::{cursor_on_plane, project, Orbit};
use panel::{strength, PanelModel, UiAction};
use script::{parse_script, Action, ScriptLine};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

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
    /// Radiance scale before tone mapping.
    #[arg(long, default_value_t = 0.6)]
    pub exposure: f32,
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

fn view_name(v: View) -> &'static str {
    match v {
        View::Combined => "combined",
        View::Direct => "direct",
        View::Indirect => "indirect",
    }
}

/// Moves a point light by `delta`; offsets and renormalises a directional light's direction.
fn moved(light: Light, delta: Vec3) -> Light {
    match light {
        Light::Point { position, intensity } => Light::Point { position: position + delta, intensity },
        Light::Directional { direction, irradiance } => {
            let d = (direction + delta).normalize_or_zero();
            Light::Directional { direction: if d == Vec3::ZERO { direction } else { d }, irradiance }
        }
    }
}

/// The light with its strongest channel set to `value`, colour kept (a black light becomes grey).
fn with_strength(light: Light, value: f32) -> Light {
    let rescale = |c: Vec3| {
        let m = c.max_element();
        if m > 0.0 {
            c * (value / m)
        } else {
            Vec3::splat(value)
        }
    };
    match light {
        Light::Point { position, intensity } => Light::Point { position, intensity: rescale(intensity) },
        Light::Directional { direction, irradiance } => {
            Light::Directional { direction, irradiance: rescale(irradiance) }
        }
    }
}

/// What a mouse drag does.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Drag {
    Orbit,
    Pan,
    /// Moves this light in the horizontal plane at its height.
    Light(usize),
    /// Started over the panel: egui's.
    Panel,
}

/// A running `wait_gi`.
struct GiWait {
    since: Instant,
    /// Changes sent when the wait began: all must be handled.
    target: u64,
    /// The result version that then had to be drawn.
    need: Option<u64>,
}

/// Screenshots asked for, written after the next frame.
#[derive(Default)]
struct PendingShots {
    scene: Option<PathBuf>,
    window: Option<PathBuf>,
}

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
    settings: Settings,
    rays_k: u32,
    orbit: Orbit,
    extent: f32,
    view: View,
    exposure: f32,
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
}

impl Viewer {
    fn set_light(&mut self, index: usize, light: Light) {
        self.lights[index] = light;
        self.engine.send(Change::MoveLight { index, light });
    }

    fn light(&self, index: usize) -> Result<Light> {
        match self.lights.get(index) {
            Some(l) => Ok(*l),
            None => bail!("light {index} does not exist (the scene has {})", self.lights.len()),
        }
    }

    fn move_light(&mut self, index: usize, delta: Vec3) -> Result<()> {
        let l = self.light(index)?;
        self.set_light(index, moved(l, delta));
        Ok(())
    }

    fn set_intensity(&mut self, index: usize, value: f32) -> Result<()> {
        let l = self.light(index)?;
        if !(value.is_finite() && value >= 0.0) {
            bail!("light intensity {value} must be finite and >= 0");
        }
        self.set_light(index, with_strength(l, value));
        Ok(())
    }

    /// A point light halfway between the camera and the surface at the
    /// centre of the view (so in free space and in sight), as strong as the
    /// selected light (or 1 W/sr).
    fn add_light(&mut self) -> Result<()> {
        if self.lights.len() >= linkgi::render::MAX_LIGHTS {
            bail!("the renderer draws at most {} lights", linkgi::render::MAX_LIGHTS);
        }
        let cam = self.orbit.camera();
        let dir = (cam.target - cam.position).normalize_or_zero();
        let bvh = Bvh::build(&self.positions, &self.prepared.triangles, &BvhBuildParams::default());
        let t = bvh.intersect(&Ray::new(cam.position, dir)).map_or(self.orbit.distance, |h| h.t);
        let i = self.lights.get(self.selected).map_or(1.0, strength).max(1e-6);
        let light = Light::Point { position: cam.position + dir * (0.5 * t), intensity: Vec3::splat(i) };
        self.lights.push(light);
        self.intensity_range.push((i * 1e-2, i * 1e2));
        self.selected = self.lights.len() - 1;
        self.engine.send(Change::AddLight(light));
        Ok(())
    }

    fn remove_light(&mut self, index: usize) -> Result<()> {
        self.light(index)?;
        self.lights.remove(index);
        self.intensity_range.remove(index);
        self.selected = self.selected.min(self.lights.len().saturating_sub(1));
        self.engine.send(Change::RemoveLight(index));
        Ok(())
    }

    fn set_rays(&mut self, rays: u32) {
        self.rays_k = (rays as f64).sqrt().round() as u32;
        if rays != self.settings.rays_per_vertex {
            self.settings.rays_per_vertex = rays;
            self.engine.send(Change::Settings(self.settings));
        }
    }

    fn scale_rays(&mut self, up: bool) {
        let k = (self.settings.rays_per_vertex as f64).sqrt().round().max(1.0) as u32;
        let k = if up { (k * 2).min(32) } else { (k / 2).max(1) };
        self.set_rays(k * k);
    }

    fn screenshot_path(&mut self, name: Option<&str>) -> PathBuf {
        match name {
            Some(n) => self.shot_dir.join(n),
            None => {
                self.shots += 1;
                self.shot_dir.join(format!("screenshot_{:04}.png", self.shots))
            }
        }
    }

    fn apply(&mut self, action: UiAction) -> Result<()> {
        match action {
            UiAction::View(v) => self.view = v,
            UiAction::Play(on) => self.playing = on && self.deforms,
            UiAction::Select(i) => self.selected = i.min(self.lights.len().saturating_sub(1)),
            UiAction::Intensity(v) => self.set_intensity(self.selected, v)?,
            UiAction::RaysSlider(k) => self.rays_k = k,
            UiAction::Rays(n) => self.set_rays(n),
            UiAction::Exposure(e) => self.exposure = e.clamp(1e-4, 1e4),
            UiAction::Screenshot => self.pending.scene = Some(self.screenshot_path(None)),
            UiAction::AddLight => self.add_light()?,
            UiAction::RemoveLight => self.remove_light(self.selected)?,
        }
        Ok(())
    }

    /// Runs due script actions; stops at one that must wait or at a screenshot.
    fn run_script(&mut self) -> Result<()> {
        let Some(opened) = self.opened else { return Ok(()) };
        while self.pending.scene.is_none() && self.pending.window.is_none() && !self.quit {
            let Some(step) = self.script.get(self.script_pos).cloned() else { return Ok(()) };
            if opened.elapsed().as_secs_f64() < step.at {
                return Ok(());
            }
            let here = format!("{}:{}", self.script_file.display(), step.line);
            match step.action {
                Action::MoveLight { index, delta } => self.move_light(index, delta).with_context(|| here.clone())?,
                Action::SetIntensity { index, value } => {
                    self.set_intensity(index, value).with_context(|| here.clone())?
                }
                Action::SetRays(n) => self.set_rays(n),
                Action::AddLight => self.add_light().with_context(|| here.clone())?,
                Action::RemoveLight(i) => self.remove_light(i).with_context(|| here.clone())?,
                Action::Deform(on) => {
                    if on && !self.deforms {
                        eprintln!("note: {here}: the scene has no deformers");
                    }
                    self.playing = on && self.deforms;
                }
                Action::View(v) => self.view = v,
                Action::WaitGi => {
                    if !self.wait_gi(&here)? {
                        return Ok(());
                    }
                }
                Action::Screenshot(name) => self.pending.scene = Some(self.screenshot_path(Some(&name))),
                Action::WindowShot(name) => self.pending.window = Some(self.screenshot_path(Some(&name))),
                Action::WaitFile(name) => {
                    let since = *self.wait_file_since.get_or_insert_with(Instant::now);
                    if !self.shot_dir.join(&name).exists() {
                        if since.elapsed() > Duration::from_secs(300) {
                            bail!(
                                "{here}: wait_file: {} did not appear within 300 s",
                                self.shot_dir.join(&name).display()
                            );
                        }
                        return Ok(());
                    }
                    self.wait_file_since = None;
                }
                Action::Quit => self.quit = true,
            }
            self.script_pos += 1;
        }
        Ok(())
    }

    /// One step of `wait_gi`: true once every change sent before the wait
    /// is in a published result and that result has been drawn.
    fn wait_gi(&mut self, here: &str) -> Result<bool> {
        let sent = self.engine.sent();
        let w = self.wait.get_or_insert_with(|| GiWait { since: Instant::now(), target: sent, need: None });
        let c = self.engine.counters();
        if w.need.is_none() && c.changes >= w.target && (c.published > 0 || c.errors > 0) {
            if c.published == 0 {
                bail!(
                    "{here}: wait_gi: the GI engine published no result: {}",
                    self.engine.last_error().unwrap_or_default()
                );
            }
            w.need = Some(c.published);
        }
        if w.need.is_some_and(|v| self.shown_version >= v) {
            self.wait = None;
            if let Some(g) = self.engine.latest() {
                let light0 = match g.lights.first() {
                    Some(Light::Point { position: p, intensity: i }) => {
                        format!(", light0 point {} {} {} intensity {}", p.x, p.y, p.z, i.max_element())
                    }
                    Some(Light::Directional { direction: d, irradiance: e }) => {
                        format!(", light0 directional {} {} {} irradiance {}", d.x, d.y, d.z, e.max_element())
                    }
                    None => String::new(),
                };
                println!(
                    "gi: version {}, links {}, bounces {}, rays {}{light0}",
                    g.version, g.links, g.bounces, self.settings.rays_per_vertex
                );
            }
            return Ok(true);
        }
        if w.since.elapsed() > Duration::from_secs(300) {
            bail!(
                "{here}: wait_gi: the GI did not catch up within 300 s{}",
                self.engine.last_error().map(|e| format!(" (last error: {e})")).unwrap_or_default()
            );
        }
        Ok(false)
    }

    /// Window pixels of each light (point lights on screen; `None` otherwise).
    fn light_pixels(&self, size: PhysicalSize<u32>) -> Vec<Option<Vec2>> {
        let cam = self.orbit.camera();
        self.lights
            .iter()
            .map(|l| match l {
                Light::Point { position, .. } => project(&cam, size.width, size.height, self.extent, *position)
                    .filter(|p| p.x >= 0.0 && p.y >= 0.0 && p.x < size.width as f32 && p.y < size.height as f32),
                Light::Directional { .. } => None,
            })
            .collect()
    }

    /// The point light whose marker is within 12 pixels of `at`, nearest first.
    fn pick_light(&self, at: Vec2) -> Option<usize> {
        let size = self.window.as_ref()?.inner_size();
        self.light_pixels(size)
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.map(|p| (i, p.distance(at))))
            .filter(|(_, d)| *d <= 12.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    fn update_hud(&mut self, window: &Window, gi: Option<&GiResult>) {
        let secs = self.hud_at.elapsed().as_secs_f64();
        if secs < 0.5 {
            return;
        }
        let c = self.engine.counters();
        self.fps = (self.frames - self.hud_frames) as f64 / secs;
        self.gi_ups = (c.published - self.hud_published) as f64 / secs;
        let (age, links, bounces) = match gi {
            Some(g) => (format!("{:.0} ms", g.published.elapsed().as_secs_f64() * 1e3), g.links, g.bounces),
            None => ("-".into(), 0, 0),
        };
        let intensity = self.lights.get(self.selected).map_or(0.0, strength);
        window.set_title(&format!(
            "linkgi {} | {:.1} fps | GI {:.1} upd/s, age {age} | {links} links, {bounces} bounces | {} | \
             light {}/{} I={intensity:.3} | {} rays/vertex{}",
            self.prepared.name,
            self.fps,
            self.gi_ups,
            view_name(self.view),
            self.selected,
            self.lights.len(),
            self.settings.rays_per_vertex,
            if self.playing { " | playing" } else { "" }
        ));
        self.hud_at = Instant::now();
        self.hud_frames = self.frames;
        self.hud_published = c.published;
    }

    fn frame(&mut self) -> Result<()> {
        self.run_script()?;
        if self.quit {
            return Ok(());
        }
        let now = Instant::now();
        let dt = now.duration_since(self.last_tick).as_secs_f32().min(0.1);
        self.last_tick = now;
        if self.playing && self.deforms {
            self.anim_time += dt;
            let (p, n) = deform_scene(&self.prepared, &self.rest, &self.rest_normals, self.anim_time);
            self.engine.send(Change::Deform { positions: p.clone() });
            self.positions = p;
            self.normals = n;
        }
        let Some(window) = self.window.clone() else { return Ok(()) };
        let size = window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(());
        }
        let Some(mut display) = self.display.take() else { return Ok(()) };
        let gi = self.engine.latest();
        let light_pixels = self.light_pixels(size);
        let counters = self.engine.counters();
        let last_error = self.engine.last_error();
        let mut actions = Vec::new();
        let capture = Capture { scene: self.pending.scene.is_some(), window: self.pending.window.is_some() };
        let drawn = {
            let e_indirect = match &gi {
                Some(g) if g.e_indirect.len() == self.positions.len() => &g.e_indirect,
                _ => &self.zeros,
            };
            let frame = Frame {
                positions: &self.positions,
                normals: &self.normals,
                albedo: &self.prepared.albedo,
                triangles: &self.prepared.triangles,
                e_indirect,
                lights: &self.lights,
                camera: self.orbit.camera(),
            };
            let params = RenderParams {
                width: size.width,
                height: size.height,
                view: self.view,
                exposure: self.exposure,
                ..Default::default()
            };
            let model = PanelModel {
                scene: &self.prepared.name,
                renderer: &self.display_name,
                gi_device: &self.gi_device,
                fps: self.fps,
                gi_updates_per_s: self.gi_ups,
                gi_age_ms: gi.as_ref().map(|g| g.published.elapsed().as_secs_f64() * 1e3),
                gi_version: gi.as_ref().map_or(0, |g| g.version),
                gi_preview: gi.as_ref().is_some_and(|g| g.preview),
                links: gi.as_ref().map_or(0, |g| g.links),
                bounces: gi.as_ref().map_or(0, |g| g.bounces),
                stage_ms: [counters.rebuild_ms, counters.light_links_ms, counters.gather_ms],
                busy: counters.changes < self.engine.sent(),
                last_error,
                view: self.view,
                playing: self.playing,
                deforms: self.deforms,
                lights: &self.lights,
                selected: self.selected,
                intensity_range: &self.intensity_range,
                rays_per_vertex: self.settings.rays_per_vertex,
                rays_k: self.rays_k,
                exposure: self.exposure,
                light_pixels: &light_pixels,
                pixels_per_point: display.pixels_per_point(),
            };
            display.draw(&window, &frame, &params, &mut |ctx| actions = panel::panel(ctx, &model), capture)
        };
        self.display = Some(display);
        let got = drawn?;
        if !got.drawn {
            return Ok(());
        }
        self.shown_version = gi.as_ref().map_or(0, |g| g.version);
        self.frames += 1;
        for (img, path) in [(got.scene, self.pending.scene.take()), (got.window, self.pending.window.take())] {
            if let (Some(img), Some(path)) = (img, path) {
                save_png(&img, &path)?;
            }
        }
        for a in actions {
            self.apply(a)?;
        }
        self.update_hud(&window, gi.as_deref());
        Ok(())
    }

    fn key(&mut self, key: &Key) -> Result<()> {
        let step = 0.02 * self.extent;
        let sel = self.selected;
        match key {
            Key::Named(NamedKey::Escape) => self.quit = true,
            Key::Named(NamedKey::ArrowLeft) => self.move_light(sel, Vec3::new(-step, 0.0, 0.0))?,
            Key::Named(NamedKey::ArrowRight) => self.move_light(sel, Vec3::new(step, 0.0, 0.0))?,
            Key::Named(NamedKey::ArrowUp) => self.move_light(sel, Vec3::new(0.0, 0.0, -step))?,
            Key::Named(NamedKey::ArrowDown) => self.move_light(sel, Vec3::new(0.0, 0.0, step))?,
            Key::Named(NamedKey::PageUp) => self.move_light(sel, Vec3::new(0.0, step, 0.0))?,
            Key::Named(NamedKey::PageDown) => self.move_light(sel, Vec3::new(0.0, -step, 0.0))?,
            Key::Named(NamedKey::Space) => self.playing = !self.playing && self.deforms,
            Key::Character(s) => match s.as_str() {
                "l" | "L" => self.selected = (self.selected + 1) % self.lights.len().max(1),
                "1" => self.view = View::Combined,
                "2" => self.view = View::Direct,
                "3" => self.view = View::Indirect,
                "+" | "=" => {
                    let v = self.lights.get(sel).map_or(0.0, strength) * 1.25;
                    self.set_intensity(sel, v)?
                }
                "-" | "_" => {
                    let v = self.lights.get(sel).map_or(0.0, strength) * 0.8;
                    self.set_intensity(sel, v)?
                }
                "]" => self.scale_rays(true),
                "[" => self.scale_rays(false),
                "p" | "P" => self.pending.scene = Some(self.screenshot_path(None)),
                _ => {}
            },
            _ => {}
        }
        Ok(())
    }

    fn mouse(&mut self, event: &WindowEvent, over_panel: bool) -> Result<()> {
        match *event {
            WindowEvent::MouseInput { state: ElementState::Pressed, button, .. } => {
                self.drag = Some(if over_panel {
                    Drag::Panel
                } else {
                    match button {
                        MouseButton::Left => {
                            let at = self.cursor.map(|c| Vec2::new(c.x as f32, c.y as f32));
                            match at.and_then(|p| self.pick_light(p)) {
                                Some(i) => {
                                    self.selected = i;
                                    Drag::Light(i)
                                }
                                None => Drag::Orbit,
                            }
                        }
                        MouseButton::Right | MouseButton::Middle => Drag::Pan,
                        _ => return Ok(()),
                    }
                });
            }
            WindowEvent::MouseInput { state: ElementState::Released, .. } => self.drag = None,
            WindowEvent::CursorMoved { position, .. } => {
                if let (Some(prev), Some(drag)) = (self.cursor, self.drag) {
                    let (dx, dy) = ((position.x - prev.x) as f32, (position.y - prev.y) as f32);
                    match drag {
                        Drag::Orbit => self.orbit.rotate(dx, dy),
                        Drag::Pan => self.orbit.pan(dx, dy),
                        Drag::Light(i) => {
                            if let (Some(Light::Point { position: p, .. }), Some(w)) =
                                (self.lights.get(i), &self.window)
                            {
                                let size = w.inner_size();
                                let cam = self.orbit.camera();
                                let (x, y) = (position.x as f32, position.y as f32);
                                if let Some(to) = cursor_on_plane(&cam, size.width, size.height, self.extent, x, y, p.y)
                                {
                                    let delta = to - *p;
                                    self.move_light(i, delta)?;
                                }
                            }
                        }
                        Drag::Panel => {}
                    }
                }
                self.cursor = Some(position);
            }
            WindowEvent::MouseWheel { delta, .. } if !over_panel => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.orbit.zoom(lines, self.extent);
            }
            _ => {}
        }
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        self.error = Some(e);
        el.exit();
    }
}

fn save_png(img: &image::RgbImage, path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    img.save_with_format(path, image::ImageFormat::Png).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title(format!("linkgi {}", self.prepared.name))
            .with_inner_size(self.size);
        let made = (|| -> Result<()> {
            let window = Arc::new(el.create_window(attrs).context("creating the window")?);
            let display = Display::open(&window, self.backend, self.vsync, self.blit)?;
            self.display_name = display.describe();
            eprintln!("GI on {}; drawing on {}", self.gi_device, self.display_name);
            self.window = Some(window);
            self.display = Some(display);
            Ok(())
        })();
        match made {
            Ok(()) => {
                self.opened = Some(Instant::now());
                self.last_tick = Instant::now();
            }
            Err(e) => self.fail(el, e),
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let (consumed, over_panel) = match (&mut self.display, &self.window) {
            (Some(d), Some(w)) => {
                let consumed = d.on_event(w, &event);
                (consumed, d.wants_pointer())
            }
            _ => (false, false),
        };
        let result = match &event {
            WindowEvent::CloseRequested => {
                self.quit = true;
                Ok(())
            }
            WindowEvent::RedrawRequested => self.frame(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed && !consumed => {
                self.key(&event.logical_key)
            }
            WindowEvent::MouseInput { .. } | WindowEvent::CursorMoved { .. } | WindowEvent::MouseWheel { .. } => {
                // A drag that began outside the panel stays ours over it.
                let panel = over_panel && !matches!(self.drag, Some(d) if d != Drag::Panel);
                self.mouse(&event, panel)
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            if self.script.is_empty() {
                // Interactive: a bad key press (e.g. no light to move) is a note, not the end.
                eprintln!("note: {e:#}");
            } else {
                self.fail(el, e);
            }
        }
        if self.quit {
            el.exit();
        }
    }

    fn about_to_wait(&mut self, _el: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

pub fn run(args: ViewArgs) -> Result<()> {
    let (width, height) = super::render::parse_size(&args.size)?;
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure must be positive");
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
    let Setup { desc, prepared, settings } = setup(&args.scene, &args.overrides)?;
    let backend = settings.backend;
    for step in &script {
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
    let extent = Frame::of(&prepared, &prepared.positions, desc.camera).extent();
    let engine = Engine::start(
        prepared.clone(),
        SolveParams::from_settings(&settings),
        compute,
        // Moving a light shows a quick preview first (see EngineParams).
        EngineParams { light_preview: true, ..Default::default() },
    );
    let n = prepared.positions.len();
    let intensity_range = prepared
        .lights
        .iter()
        .map(|l| {
            let base = strength(l).max(1e-6);
            (base * 1e-2, base * 1e2)
        })
        .collect();
    let mut viewer = Viewer {
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
        orbit: Orbit::from_camera(desc.camera),
        extent,
        view: View::Combined,
        exposure: args.exposure,
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
