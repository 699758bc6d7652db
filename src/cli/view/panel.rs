//! The viewer's egui panel: figures (fps, GI updates per second, age of the
//! shown GI, links, bounces, stage times) and controls (view mode, light
//! selection and intensity, a mesh's emission, the sky's intensity and
//! rotation, rays per vertex, exposure, deformation, screenshot), plus
//! markers over the point lights.
//!
//! The panel only reads a [`PanelModel`] and returns [`UiAction`]s; the
//! viewer applies them through the same code as the keys and the script's
//! `set_intensity`/`set_rays`, so scripted tests exercise what the sliders do.
//! Units: intensity is the light's strongest channel (W/sr for point lights,
//! W/m^2 for directional ones); ages and times in milliseconds.

use crate::render::View;
use crate::scene::Light;
use glam::Vec2;

/// What the panel shows.
pub struct PanelModel<'a> {
    pub scene: &'a str,
    pub renderer: &'a str,
    pub gi_device: &'a str,
    pub fps: f64,
    pub gi_updates_per_s: f64,
    /// Age of the drawn GI, ms (`None` before the first result).
    pub gi_age_ms: Option<f64>,
    pub gi_version: u64,
    /// The drawn GI is a light preview (a full result follows).
    pub gi_preview: bool,
    pub links: u64,
    pub bounces: u32,
    /// Last update's stage times, ms: rebuild (kd-tree + links), light links, gather.
    pub stage_ms: [f64; 3],
    /// The engine has changes it has not published yet.
    pub busy: bool,
    /// The last deformation update's figures, if any.
    pub deform: Option<crate::solver::DeformStats>,
    pub last_error: Option<String>,
    pub view: View,
    pub playing: bool,
    pub deforms: bool,
    pub lights: &'a [Light],
    pub selected: usize,
    /// Intensity slider range per light (strongest channel).
    pub intensity_range: &'a [(f32, f32)],
    pub rays_per_vertex: u32,
    /// The rays slider's position, k for k x k rays (may lead `rays_per_vertex` while dragged).
    pub rays_k: u32,
    pub exposure: f32,
    pub auto_exposure: bool,
    /// Window pixels of each point light (markers), `None` when off screen.
    pub light_pixels: &'a [Option<Vec2>],
    pub pixels_per_point: f32,
    /// Mesh names and their emission (W/m^2).
    pub meshes: &'a [(String, glam::Vec3)],
    pub selected_mesh: usize,
    /// The sky's intensity and rotation (degrees), if the scene has one.
    pub sky: Option<(f32, f32)>,
    /// The background refinement's state (empty when done or off).
    pub refining: String,
}

/// A control the user changed.
#[derive(Clone, Debug, PartialEq)]
pub enum UiAction {
    View(View),
    Play(bool),
    Select(usize),
    /// New strongest channel of the selected light.
    Intensity(f32),
    /// The rays slider moved to k (k x k rays), not released yet.
    RaysSlider(u32),
    /// Rays per vertex (a square number): solve with it.
    Rays(u32),
    /// A fixed exposure (automatic exposure off).
    Exposure(f32),
    /// Automatic exposure on or off.
    AutoExposure(bool),
    Screenshot,
    /// A new point light in front of the camera.
    AddLight,
    /// Removes the selected light.
    RemoveLight,
    /// The mesh the emission slider edits.
    SelectMesh(usize),
    /// New strongest channel of the selected mesh's emission, W/m^2.
    Emission(f32),
    /// New sky intensity (multiplier) and rotation (degrees).
    Sky {
        intensity: f32,
        rotate_deg: f32,
    },
}

fn light_name(i: usize, l: &Light) -> String {
    match l {
        Light::Point { .. } => format!("{i}: point"),
        Light::Directional { .. } => format!("{i}: directional"),
    }
}

/// Builds the panel and the light markers for one frame.
pub fn panel(ctx: &egui::Context, m: &PanelModel) -> Vec<UiAction> {
    let mut out = Vec::new();
    // Light markers: a ring per point light, filled for the selected one.
    let painter = ctx.layer_painter(egui::LayerId::background());
    for (i, px) in m.light_pixels.iter().enumerate() {
        if let Some(p) = px {
            let at = egui::pos2(p.x / m.pixels_per_point, p.y / m.pixels_per_point);
            let colour = egui::Color32::from_rgb(255, 220, 80);
            if i == m.selected {
                painter.circle_filled(at, 5.0, colour);
            }
            painter.circle_stroke(at, 8.0, egui::Stroke::new(1.5, colour));
        }
    }
    egui::Window::new("linkgi")
        .anchor(egui::Align2::LEFT_TOP, egui::vec2(6.0, 6.0))
        .resizable(false)
        .default_open(true)
        .show(ctx, |ui| {
            ui.label(format!("{} · drawn on {}", m.scene, m.renderer)).on_hover_text(format!("GI on {}", m.gi_device));
            if !m.refining.is_empty() {
                ui.label(&m.refining).on_hover_text("the error-driven rounds run in the background; each lands here");
            }
            ui.label(format!(
                "{:.1} fps · GI {:.2} updates/s{}",
                m.fps,
                m.gi_updates_per_s,
                if m.busy { " · updating" } else { "" }
            ));
            ui.label(match m.gi_age_ms {
                Some(a) => format!(
                    "GI v{}{} age {a:.0} ms · {:.2} M links · {} bounces",
                    m.gi_version,
                    if m.gi_preview { " (preview)" } else { "" },
                    m.links as f64 * 1e-6,
                    m.bounces
                ),
                None => "waiting for the first GI solve".into(),
            });
            ui.label(format!(
                "last update ms: rebuild {:.0} · lights {:.0} · gather {:.0}",
                m.stage_ms[0], m.stage_ms[1], m.stage_ms[2]
            ));
            if let Some(d) = &m.deform {
                ui.label(format!(
                    "last deformation: {} rays re-shot ({:.1}% of static) · {} groups patched · {} light links · state {:.1} MB",
                    d.links.rays_reshot,
                    100.0 * d.static_rays_fraction(),
                    d.links.groups_patched,
                    d.light_links_recomputed,
                    d.ray_state_bytes as f64 / 1e6
                ));
            }
            if let Some(e) = &m.last_error {
                ui.colored_label(egui::Color32::from_rgb(255, 120, 100), format!("last GI error: {e}"));
            }
            ui.separator();
            ui.horizontal(|ui| {
                for (v, name) in [(View::Combined, "combined"), (View::Direct, "direct"), (View::Indirect, "indirect")]
                {
                    if ui.selectable_label(m.view == v, name).clicked() && m.view != v {
                        out.push(UiAction::View(v));
                    }
                }
            });
            ui.horizontal(|ui| {
                let mut exposure = m.exposure;
                if ui.add(egui::Slider::new(&mut exposure, 1e-4..=1e4).logarithmic(true).text("exposure")).changed() {
                    out.push(UiAction::Exposure(exposure));
                }
                let mut auto = m.auto_exposure;
                if ui.checkbox(&mut auto, "auto").changed() {
                    out.push(UiAction::AutoExposure(auto));
                }
            });
            ui.horizontal(|ui| {
                let can_add = m.lights.len() < crate::render::MAX_LIGHTS;
                if ui.add_enabled(can_add, egui::Button::new("add light")).clicked() {
                    out.push(UiAction::AddLight);
                }
                if ui.add_enabled(!m.lights.is_empty(), egui::Button::new("remove light")).clicked() {
                    out.push(UiAction::RemoveLight);
                }
            });
            if !m.lights.is_empty() {
                let sel = m.selected.min(m.lights.len() - 1);
                egui::ComboBox::from_label("light").selected_text(light_name(sel, &m.lights[sel])).show_ui(ui, |ui| {
                    for (i, l) in m.lights.iter().enumerate() {
                        if ui.selectable_label(i == sel, light_name(i, l)).clicked() && i != sel {
                            out.push(UiAction::Select(i));
                        }
                    }
                });
                let (lo, hi) = m.intensity_range[sel];
                let mut value = m.lights[sel].strength();
                let unit =
                    if matches!(m.lights[sel], Light::Point { .. }) { "intensity W/sr" } else { "irradiance W/m²" };
                if ui.add(egui::Slider::new(&mut value, lo..=hi).logarithmic(true).text(unit)).changed() {
                    out.push(UiAction::Intensity(value));
                }
            }
            if !m.meshes.is_empty() {
                let sel = m.selected_mesh.min(m.meshes.len() - 1);
                egui::ComboBox::from_label("emitter").selected_text(&m.meshes[sel].0).show_ui(ui, |ui| {
                    for (i, (name, _)) in m.meshes.iter().enumerate() {
                        if ui.selectable_label(i == sel, name).clicked() && i != sel {
                            out.push(UiAction::SelectMesh(i));
                        }
                    }
                });
                let mut value = m.meshes[sel].1.max_element();
                let slider = egui::Slider::new(&mut value, 0.0..=1000.0).logarithmic(true).smallest_positive(0.01);
                if ui.add(slider.text("emission W/m²")).changed() {
                    out.push(UiAction::Emission(value));
                }
            }
            if let Some((intensity, rotate)) = m.sky {
                let (mut i, mut r) = (intensity, rotate);
                let a = ui.add(egui::Slider::new(&mut i, 0.0..=20.0).logarithmic(true).smallest_positive(0.01).text("sky ×"));
                let b = ui.add(egui::Slider::new(&mut r, -180.0..=180.0).text("sky turn °"));
                if a.changed() || b.changed() {
                    out.push(UiAction::Sky { intensity: i, rotate_deg: r });
                }
            }
            // Rays per vertex: k x k; a new solve only when the drag ends.
            let mut k = m.rays_k;
            let r = ui.add(egui::Slider::new(&mut k, 1..=32).text("√ rays/vertex").custom_formatter(|v, _| {
                let k = v.round() as u32;
                format!("{k} ({} rays)", k * k)
            }));
            if r.changed() {
                out.push(UiAction::RaysSlider(k));
            }
            if (r.drag_stopped() || (r.changed() && !r.dragged())) && k * k != m.rays_per_vertex {
                out.push(UiAction::Rays(k * k));
            }
            ui.horizontal(|ui| {
                let mut playing = m.playing;
                let toggle = ui.add_enabled(m.deforms, egui::Checkbox::new(&mut playing, "deform"));
                if toggle.changed() {
                    out.push(UiAction::Play(playing));
                }
                if ui.button("screenshot").clicked() {
                    out.push(UiAction::Screenshot);
                }
            });
            ui.small(
                "drag: orbit · right-drag: pan · wheel: zoom · drag a light's ring: move it · PgUp/PgDn: light height",
            );
        });
    out
}
