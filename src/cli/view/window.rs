//! The window loop of `linkgi view`: winit's [`ApplicationHandler`] opens
//! the window and its [`Display`], routes events to the panel and to
//! [`super::input`], and draws a frame whenever the window asks: run due
//! script actions, advance the deformers by the elapsed time (at most 0.1 s
//! a frame), draw the scene with the engine's newest GI (never waiting for
//! it; zero indirect light until the first result), write pending
//! screenshots, apply the panel's actions and refresh the figures (fps and
//! GI updates/s over the last 0.5 s or more; in the title without a panel).

use super::display::{Capture, Display};
use super::input::Drag;
use super::panel::{self, PanelModel};
use super::Viewer;
use crate::engine::{Change, GiResult};
use crate::render::{Frame, RenderParams, View};
use crate::scene::deform::deform_scene;
use crate::scene::Light;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::window::{Window, WindowId};

/// Screenshots asked for, written after the next frame.
#[derive(Default)]
pub(super) struct PendingShots {
    pub scene: Option<PathBuf>,
    pub window: Option<PathBuf>,
}

/// The view's name in the window title.
/// Size of the automatic exposure's probe renders, pixels.
const PROBE_SIZE: (u32, u32) = (96, 72);

fn view_name(v: View) -> &'static str {
    match v {
        View::Combined => "combined",
        View::Direct => "direct",
        View::Indirect => "indirect",
    }
}

/// Writes a screenshot, creating its folder.
fn save_png(img: &image::RgbImage, path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    img.save_with_format(path, image::ImageFormat::Png).with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

impl Viewer {
    pub(super) fn screenshot_path(&mut self, name: Option<&str>) -> PathBuf {
        match name {
            Some(n) => self.shot_dir.join(n),
            None => {
                self.shots += 1;
                self.shot_dir.join(format!("screenshot_{:04}.png", self.shots))
            }
        }
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
        let intensity = self.lights.get(self.selected).map_or(0.0, Light::strength);
        window.set_title(&format!(
            "linkgi {} | {:.1} fps | GI {:.1} upd/s, age {age} | {links} links, {bounces} bounces | {} | \
             light {}/{} I={intensity:.3} | {} rays/vertex{}{}",
            self.prepared.name,
            self.fps,
            self.gi_ups,
            view_name(self.view),
            self.selected,
            self.lights.len(),
            self.settings.rays_per_vertex,
            if self.playing { " | playing" } else { "" },
            Some(self.refine_status()).filter(|r| !r.is_empty()).map_or(String::new(), |r| format!(" | {r}"))
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
        if let Some(a) = self.auto_exposure.as_mut() {
            self.exposure = a.step(dt);
        }
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
        self.poll_refinement();
        // The engine's newest result for the mesh shown, else the newest landed round's.
        let n = self.positions.len();
        let gi = (self.engine.latest().filter(|g| g.e_indirect.len() == n))
            .or_else(|| self.round_gi.clone().filter(|g| g.e_indirect.len() == n));
        let light_pixels = self.light_pixels(size);
        let counters = self.engine.counters();
        let last_error = self.engine.last_error();
        let mut actions = Vec::new();
        let capture = Capture { scene: self.pending.scene.is_some(), window: self.pending.window.is_some() };
        let drawn = {
            let current = gi.as_ref().filter(|g| g.e_indirect.len() == self.positions.len());
            let frame = Frame {
                positions: &self.positions,
                normals: &self.normals,
                albedo: &self.prepared.albedo,
                triangles: &self.prepared.triangles,
                textures: self.prepared.textures.as_deref(),
                e_indirect: current.map_or(&self.zeros, |g| &g.e_indirect),
                e_sky: current.map_or(&[][..], |g| &g.e_sky),
                emission: current.map_or(&self.prepared.emission, |g| &g.emission),
                sky: current.map_or(self.prepared.sky.as_ref(), |g| g.sky.as_ref()),
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
            if let Some(a) = self.auto_exposure.as_mut().filter(|a| a.wants_probe()) {
                // A small render of the same frame measures the key.
                let probe = RenderParams { width: PROBE_SIZE.0, height: PROBE_SIZE.1, ..params };
                a.probed(display.probe(&frame, &probe)?.pixels);
            }
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
                deform: counters.deform,
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
                auto_exposure: self.auto_exposure.is_some(),
                light_pixels: &light_pixels,
                pixels_per_point: display.pixels_per_point(),
                meshes: &self.mesh_emission,
                selected_mesh: self.selected_mesh,
                sky: self.sky.as_ref().map(|s| (s.intensity, s.rotate_deg)),
                refining: self.refine_status(),
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
