//! `linkgi view`: an interactive window that shows the scene with the
//! asynchronous engine's newest GI while lights move and meshes deform.
//!
//! Presentation: every frame is rendered by the existing offscreen
//! [`Renderer`] (wgpu into `Rgba16Float` and read back, or the CPU
//! fallback) at the window's size, tone-mapped on the CPU and copied into
//! the window with `softbuffer`. That path needs no swap chain and no second
//! wgpu device, works the same with lavapipe under Xvfb as on a desktop, and
//! creates no GPU resources beyond the renderer's own (all labelled there).
//! It costs a read-back and a CPU blit per frame, which is fine for a
//! debugging viewer. The HUD (fps, GI updates/s, age of the shown GI, links,
//! bounces, view mode, light intensity, rays per vertex) is the window title,
//! refreshed twice a second.
//!
//! The render loop never waits for the engine: it draws with
//! [`Engine::latest`] (direct light only until the first GI is out).
//!
//! Controls: left-drag orbit, right-drag pan, wheel zoom; `L` selects the
//! next light, arrow keys move it in x/z, PageUp/PageDown in y; `Space`
//! plays/pauses the scene's deformers; `1`/`2`/`3` combined/direct/indirect;
//! `+`/`-` scale the selected light's intensity; `[`/`]` rays per vertex
//! x0.25/x4; `P` writes a screenshot PNG; `Esc` quits.
//!
//! `--script FILE` runs timed actions, one per line, `<seconds> <action>
//! [args]` (`#` starts a comment). Actions run in file order; each waits
//! until `<seconds>` after the window opened and until the one before it is
//! done: `move_light <i> <dx> <dy> <dz>` (metres; a directional light's
//! direction is offset and renormalised), `deform on|off`,
//! `view combined|direct|indirect`, `wait_gi` (until the engine is idle and
//! its newest result has been drawn; fails after 300 s), `screenshot
//! <name.png>` (into `--screenshot-dir`, the next drawn frame), `quit`.

use anyhow::{bail, Context, Result};
use glam::Vec3;
use linkgi::engine::{Change, Engine, EngineParams};
use linkgi::gpu::Backend;
use linkgi::render::{tone_map, Frame, RenderParams, Renderer, View};
use linkgi::scene::deform::{deform_scene, has_deformers};
use linkgi::scene::prep::PreparedScene;
use linkgi::scene::{self, prep, Light, Settings};
use linkgi::solver::{Compute, SolveParams};
use std::num::NonZeroU32;
use std::path::{Path, PathBuf};
use std::rc::Rc;
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
    /// auto/gpu: rasterize on the first adapter, else the CPU; cpu: CPU fallback. GI as in `render`.
    #[arg(long, default_value = "auto")]
    pub backend: String,
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
    /// Rays per vertex of the GI (a square number); overrides the scene's setting.
    #[arg(long)]
    pub rays: Option<u32>,
}

/// One scripted action.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    MoveLight { index: usize, delta: Vec3 },
    Deform(bool),
    View(View),
    WaitGi,
    Screenshot(String),
    Quit,
}

/// An action with its earliest time (seconds after the window opened) and source line.
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptLine {
    pub at: f64,
    pub action: Action,
    pub line: usize,
}

/// Parses a script; errors name `file` and the line.
pub fn parse_script(text: &str, file: &Path) -> Result<Vec<ScriptLine>> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let here = || format!("{}:{line}", file.display());
        let body = raw.split('#').next().unwrap_or("").trim();
        if body.is_empty() {
            continue;
        }
        let words: Vec<&str> = body.split_whitespace().collect();
        let at: f64 = words[0]
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite() && *t >= 0.0)
            .with_context(|| format!("{}: '{}' is not a time in seconds (>= 0)", here(), words[0]))?;
        let Some(&name) = words.get(1) else {
            bail!("{}: missing action after the time", here());
        };
        let args = &words[2..];
        let want = |n: usize| -> Result<()> {
            if args.len() != n {
                bail!("{}: {name} takes {n} argument(s), got {}", here(), args.len());
            }
            Ok(())
        };
        let action = match name {
            "move_light" => {
                want(4)?;
                let index = args[0]
                    .parse()
                    .with_context(|| format!("{}: move_light: '{}' is not a light index", here(), args[0]))?;
                let mut d = [0.0f32; 3];
                for (k, a) in args[1..].iter().enumerate() {
                    d[k] = a
                        .parse()
                        .ok()
                        .filter(|v: &f32| v.is_finite())
                        .with_context(|| format!("{}: move_light: '{a}' is not a number", here()))?;
                }
                Action::MoveLight { index, delta: Vec3::from(d) }
            }
            "deform" => {
                want(1)?;
                match args[0] {
                    "on" => Action::Deform(true),
                    "off" => Action::Deform(false),
                    a => bail!("{}: deform takes on or off, got '{a}'", here()),
                }
            }
            "view" => {
                want(1)?;
                match args[0] {
                    "combined" => Action::View(View::Combined),
                    "direct" => Action::View(View::Direct),
                    "indirect" => Action::View(View::Indirect),
                    a => bail!("{}: view takes combined, direct or indirect, got '{a}'", here()),
                }
            }
            "wait_gi" => {
                want(0)?;
                Action::WaitGi
            }
            "screenshot" => {
                want(1)?;
                Action::Screenshot(args[0].to_string())
            }
            "quit" => {
                want(0)?;
                Action::Quit
            }
            other => {
                bail!("{}: unknown action '{other}' (move_light, deform, view, wait_gi, screenshot, quit)", here())
            }
        };
        out.push(ScriptLine { at, action, line });
    }
    Ok(out)
}

/// Orbit camera around a target.
#[derive(Clone, Copy, Debug)]
struct Orbit {
    target: Vec3,
    yaw: f32,
    pitch: f32,
    distance: f32,
    fov_deg: f32,
}

impl Orbit {
    fn from_camera(c: scene::Camera) -> Orbit {
        let off = c.position - c.target;
        let distance = off.length().max(1e-3);
        Orbit {
            target: c.target,
            yaw: off.x.atan2(off.z),
            pitch: (off.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
            fov_deg: c.fov_deg,
        }
    }

    fn camera(&self) -> scene::Camera {
        let dir = Vec3::new(self.pitch.cos() * self.yaw.sin(), self.pitch.sin(), self.pitch.cos() * self.yaw.cos());
        scene::Camera { position: self.target + dir * self.distance, target: self.target, fov_deg: self.fov_deg }
    }

    /// Camera right and up vectors.
    fn basis(&self) -> (Vec3, Vec3) {
        let c = self.camera();
        let fwd = (c.target - c.position).normalize_or_zero();
        let right = fwd.cross(Vec3::Y).normalize_or_zero();
        (right, right.cross(fwd))
    }
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

fn scaled(light: Light, s: f32) -> Light {
    match light {
        Light::Point { position, intensity } => Light::Point { position, intensity: intensity * s },
        Light::Directional { direction, irradiance } => Light::Directional { direction, irradiance: irradiance * s },
    }
}

fn strength(light: &Light) -> f32 {
    match light {
        Light::Point { intensity, .. } => intensity.max_element(),
        Light::Directional { irradiance, .. } => irradiance.max_element(),
    }
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
    renderer: Renderer,
    lights: Vec<Light>,
    selected: usize,
    settings: Settings,
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
    pending_shot: Option<PathBuf>,
    script: Vec<ScriptLine>,
    script_file: PathBuf,
    script_pos: usize,
    wait_since: Option<Instant>,
    opened: Option<Instant>,
    shown_version: u64,
    drag: Option<MouseButton>,
    cursor: Option<PhysicalPosition<f64>>,
    frames: u64,
    hud_at: Instant,
    hud_frames: u64,
    hud_published: u64,
    window: Option<Rc<Window>>,
    surface: Option<softbuffer::Surface<Rc<Window>, Rc<Window>>>,
    error: Option<anyhow::Error>,
    quit: bool,
}

impl Viewer {
    fn move_light(&mut self, index: usize, delta: Vec3) -> Result<()> {
        let Some(l) = self.lights.get(index).copied() else {
            bail!("light {index} does not exist (the scene has {})", self.lights.len());
        };
        self.lights[index] = moved(l, delta);
        self.engine.send(Change::MoveLight { index, light: self.lights[index] });
        Ok(())
    }

    fn scale_light(&mut self, s: f32) {
        if let Some(l) = self.lights.get(self.selected).copied() {
            self.lights[self.selected] = scaled(l, s);
            self.engine.send(Change::MoveLight { index: self.selected, light: self.lights[self.selected] });
        }
    }

    fn scale_rays(&mut self, up: bool) {
        let k = (self.settings.rays_per_vertex as f64).sqrt().round().max(1.0) as u32;
        let k = if up { (k * 2).min(256) } else { (k / 2).max(1) };
        if k * k != self.settings.rays_per_vertex {
            self.settings.rays_per_vertex = k * k;
            self.engine.send(Change::Settings(self.settings));
        }
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

    /// Runs due script actions; stops at one that must wait or at a screenshot.
    fn run_script(&mut self) -> Result<()> {
        let Some(opened) = self.opened else { return Ok(()) };
        while self.pending_shot.is_none() && !self.quit {
            let Some(step) = self.script.get(self.script_pos).cloned() else { return Ok(()) };
            if opened.elapsed().as_secs_f64() < step.at {
                return Ok(());
            }
            let here = format!("{}:{}", self.script_file.display(), step.line);
            match step.action {
                Action::MoveLight { index, delta } => self.move_light(index, delta).with_context(|| here.clone())?,
                Action::Deform(on) => {
                    if on && !self.deforms {
                        eprintln!("note: {here}: the scene has no deformers");
                    }
                    self.playing = on;
                }
                Action::View(v) => self.view = v,
                Action::WaitGi => {
                    let since = *self.wait_since.get_or_insert_with(Instant::now);
                    let idle = self.engine.wait_idle(Duration::ZERO);
                    let latest = self.engine.latest().map(|g| g.version);
                    if idle && latest.is_none() {
                        bail!(
                            "{here}: wait_gi: the GI engine published no result: {}",
                            self.engine.last_error().unwrap_or_default()
                        );
                    }
                    if !(idle && latest == Some(self.shown_version)) {
                        if since.elapsed() > Duration::from_secs(300) {
                            bail!(
                                "{here}: wait_gi: no idle engine after 300 s{}",
                                self.engine.last_error().map(|e| format!(" (last error: {e})")).unwrap_or_default()
                            );
                        }
                        return Ok(());
                    }
                    self.wait_since = None;
                }
                Action::Screenshot(name) => self.pending_shot = Some(self.screenshot_path(Some(&name))),
                Action::Quit => self.quit = true,
            }
            self.script_pos += 1;
        }
        Ok(())
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
        let gi = self.engine.latest();
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
        let (hdr, _) = self.renderer.render(&frame, &params)?;
        let img = tone_map(&hdr, self.exposure);
        let surface = self.surface.as_mut().context("no window surface")?;
        let (w, h) = (NonZeroU32::new(img.width()), NonZeroU32::new(img.height()));
        let (Some(w), Some(h)) = (w, h) else { return Ok(()) };
        surface.resize(w, h).map_err(|e| anyhow::anyhow!("resizing the window buffer: {e}"))?;
        let mut buf = surface.buffer_mut().map_err(|e| anyhow::anyhow!("window buffer: {e}"))?;
        for (dst, p) in buf.iter_mut().zip(img.pixels()) {
            *dst = (p[0] as u32) << 16 | (p[1] as u32) << 8 | p[2] as u32;
        }
        buf.present().map_err(|e| anyhow::anyhow!("presenting: {e}"))?;
        self.shown_version = gi.as_ref().map_or(0, |g| g.version);
        self.frames += 1;
        if let Some(path) = self.pending_shot.take() {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            }
            img.save_with_format(&path, image::ImageFormat::Png)
                .with_context(|| format!("writing {}", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        self.hud(&window, gi.as_deref());
        Ok(())
    }

    fn hud(&mut self, window: &Window, gi: Option<&linkgi::engine::GiResult>) {
        let secs = self.hud_at.elapsed().as_secs_f64();
        if secs < 0.5 {
            return;
        }
        let c = self.engine.counters();
        let fps = (self.frames - self.hud_frames) as f64 / secs;
        let ups = (c.published - self.hud_published) as f64 / secs;
        let (age, links, bounces) = match gi {
            Some(g) => (format!("{:.0} ms", g.published.elapsed().as_secs_f64() * 1e3), g.links, g.bounces),
            None => ("-".into(), 0, 0),
        };
        let intensity = self.lights.get(self.selected).map_or(0.0, strength);
        window.set_title(&format!(
            "linkgi {} | {fps:.1} fps | GI {ups:.1} upd/s, age {age} | {links} links, {bounces} bounces | {} | \
             light {}/{} I={intensity:.3} | {} rays/vertex{}",
            self.prepared.name,
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
            Key::Named(NamedKey::Space) => self.playing = !self.playing,
            Key::Character(s) => match s.as_str() {
                "l" | "L" => self.selected = (self.selected + 1) % self.lights.len().max(1),
                "1" => self.view = View::Combined,
                "2" => self.view = View::Direct,
                "3" => self.view = View::Indirect,
                "+" | "=" => self.scale_light(1.25),
                "-" | "_" => self.scale_light(0.8),
                "]" => self.scale_rays(true),
                "[" => self.scale_rays(false),
                "p" | "P" => self.pending_shot = Some(self.screenshot_path(None)),
                " " => self.playing = !self.playing,
                _ => {}
            },
            _ => {}
        }
        Ok(())
    }

    fn fail(&mut self, el: &ActiveEventLoop, e: anyhow::Error) {
        self.error = Some(e);
        el.exit();
    }
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
            let window = Rc::new(el.create_window(attrs).context("creating the window")?);
            let context = softbuffer::Context::new(window.clone())
                .map_err(|e| anyhow::anyhow!("window presentation (softbuffer): {e}"))?;
            let surface = softbuffer::Surface::new(&context, window.clone())
                .map_err(|e| anyhow::anyhow!("window surface (softbuffer): {e}"))?;
            self.window = Some(window);
            self.surface = Some(surface);
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
        let result = match event {
            WindowEvent::CloseRequested => {
                self.quit = true;
                Ok(())
            }
            WindowEvent::RedrawRequested => self.frame(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(&event.logical_key)
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = (state == ElementState::Pressed).then_some(button);
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (Some(prev), Some(button)) = (self.cursor, self.drag) {
                    let (dx, dy) = ((position.x - prev.x) as f32, (position.y - prev.y) as f32);
                    match button {
                        MouseButton::Left => {
                            self.orbit.yaw -= dx * 0.005;
                            self.orbit.pitch = (self.orbit.pitch + dy * 0.005).clamp(-1.5, 1.5);
                        }
                        MouseButton::Right => {
                            let (right, up) = self.orbit.basis();
                            let s = self.orbit.distance * 0.002;
                            self.orbit.target += (-right * dx + up * dy) * s;
                        }
                        _ => {}
                    }
                }
                self.cursor = Some(position);
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.orbit.distance =
                    (self.orbit.distance * 0.9f32.powf(lines)).clamp(1e-3 * self.extent, 20.0 * self.extent);
                Ok(())
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
    let backend: Backend = args.backend.parse()?;
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
    let mut desc = scene::load(&args.scene)?;
    for w in &desc.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(r) = args.rays {
        desc.settings.rays_per_vertex = r;
    }
    desc.settings.validate()?;
    let prepared = prep::prepare(&desc)?;
    for step in &script {
        if let Action::MoveLight { index, .. } = step.action {
            if index >= prepared.lights.len() {
                bail!(
                    "{}:{}: move_light {index}: the scene has {} light(s)",
                    script_file.display(),
                    step.line,
                    prepared.lights.len()
                );
            }
        }
    }
    let (compute, note) = Compute::from_backend(backend, 1)?;
    if let Some(n) = note {
        eprintln!("{n}");
    }
    let renderer = Renderer::open(backend);
    eprintln!("GI on {}; rendering on {}", compute.describe(), renderer.describe());
    let extent = Frame::of(&prepared, &prepared.positions, desc.camera).extent();
    let engine = Engine::start(
        prepared.clone(),
        SolveParams::from_settings(&prepared.settings),
        compute,
        EngineParams::default(),
    );
    let n = prepared.positions.len();
    let mut viewer = Viewer {
        rest: prepared.positions.clone(),
        rest_normals: prepared.normals.clone(),
        positions: prepared.positions.clone(),
        normals: prepared.normals.clone(),
        zeros: vec![Vec3::ZERO; n],
        deforms: has_deformers(&prepared),
        lights: prepared.lights.clone(),
        settings: prepared.settings,
        prepared,
        engine,
        renderer,
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
        pending_shot: None,
        script,
        script_file,
        script_pos: 0,
        wait_since: None,
        opened: None,
        shown_version: 0,
        drag: None,
        cursor: None,
        frames: 0,
        hud_at: Instant::now(),
        hud_frames: 0,
        hud_published: 0,
        window: None,
        surface: None,
        error: None,
        quit: false,
    };
    event_loop.run_app(&mut viewer).context("running the window's event loop")?;
    if let Some(e) = viewer.error.take() {
        return Err(e);
    }
    if let Some(opened) = viewer.opened {
        let secs = opened.elapsed().as_secs_f64();
        println!("{} frames in {secs:.2} s ({:.1} fps)", viewer.frames, viewer.frames as f64 / secs.max(1e-9));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_actions_and_names_bad_lines() {
        let f = Path::new("s.txt");
        let s = parse_script("# c\n0 wait_gi\n0.5 move_light 0 0.1 0 -0.2\n1 view indirect # x\n2 quit\n", f).unwrap();
        assert_eq!(s.len(), 4);
        assert_eq!(s[1].action, Action::MoveLight { index: 0, delta: Vec3::new(0.1, 0.0, -0.2) });
        assert_eq!(s[1].line, 3);
        assert_eq!(s[2].action, Action::View(View::Indirect));
        for (bad, line) in [("0 wait_gi\nx quit", 2), ("1 fly", 1), ("0 view sideways", 1), ("0 move_light 0 1", 1)] {
            let e = format!("{:#}", parse_script(bad, f).unwrap_err());
            assert!(e.contains(&format!("s.txt:{line}")), "{e}");
        }
    }
}
