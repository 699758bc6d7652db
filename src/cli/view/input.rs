//! Input of `linkgi view`: keys, mouse drags and the wheel, and the
//! panel's actions, turned into camera moves and edits ([`super::edit`]).
//!
//! Keys: arrows move the selected light in x/z, PageUp/PageDown in y, by 2 %
//! of the scene's extent; `L` selects the next light; `Space` plays or
//! pauses the deformers; `1`/`2`/`3` pick the view; `+`/`-` scale the
//! selected light's strength by 1.25/0.8; `[`/`]` rays per vertex x0.25/x4;
//! `P` screenshot; `Esc` quits. Mouse: left-drag orbits, or moves a light
//! whose ring is under the pointer (in the horizontal plane at its height);
//! right- or middle-drag pans; the wheel zooms.

use super::orbit::cursor_on_plane;
use super::panel::UiAction;
use super::Viewer;
use crate::render::View;
use crate::scene::Light;
use anyhow::Result;
use glam::{Vec2, Vec3};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::keyboard::{Key, NamedKey};

/// What a mouse drag does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Drag {
    Orbit,
    Pan,
    /// Moves this light in the horizontal plane at its height.
    Light(usize),
    /// Started over the panel: egui's.
    Panel,
}

impl Viewer {
    /// Does what the panel asked for.
    pub(super) fn apply(&mut self, action: UiAction) -> Result<()> {
        match action {
            UiAction::View(v) => self.view = v,
            UiAction::Play(on) => self.playing = on && self.deforms,
            UiAction::Select(i) => self.selected = i.min(self.lights.len().saturating_sub(1)),
            UiAction::Intensity(v) => self.set_intensity(self.selected, v)?,
            UiAction::RaysSlider(k) => self.rays_k = k,
            UiAction::Rays(n) => self.set_rays(n),
            UiAction::Exposure(e) => {
                self.exposure = e.clamp(1e-4, 1e4);
                self.auto_exposure = None;
            }
            UiAction::AutoExposure(on) => {
                self.auto_exposure = on.then(|| crate::render::exposure::AutoExposure::new(self.exposure));
            }
            UiAction::Screenshot => self.pending.scene = Some(self.screenshot_path(None)),
            UiAction::AddLight => self.add_light()?,
            UiAction::RemoveLight => self.remove_light(self.selected)?,
            UiAction::SelectMesh(i) => self.selected_mesh = i.min(self.mesh_emission.len().saturating_sub(1)),
            UiAction::Emission(v) => self.set_emission(self.selected_mesh, v)?,
            UiAction::Sky { intensity, rotate_deg } => self.set_sky(intensity, rotate_deg)?,
        }
        Ok(())
    }

    /// A pressed key the panel did not take.
    pub(super) fn key(&mut self, key: &Key) -> Result<()> {
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
                    let v = self.lights.get(sel).map_or(0.0, Light::strength) * 1.25;
                    self.set_intensity(sel, v)?
                }
                "-" | "_" => {
                    let v = self.lights.get(sel).map_or(0.0, Light::strength) * 0.8;
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

    /// A mouse event; `over_panel`: the panel owns it (a drag started over it).
    pub(super) fn mouse(&mut self, event: &WindowEvent, over_panel: bool) -> Result<()> {
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
}
