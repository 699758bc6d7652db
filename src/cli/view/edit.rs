//! Light editing in `linkgi view`: what the keys, the panel and the script
//! do to the lights (move, set the strength, add, remove), to emitters
//! (a mesh's emission) and the sky (intensity, rotation), the rays per
//! vertex, and where the point lights are on screen (the rings the mouse
//! drags). Every edit updates the viewer's copy and sends the engine the
//! [`Change`]; the edits themselves are [`Light`] methods.
//!
//! Units: positions and offsets in metres; strength in W/sr (point lights)
//! or W/m^2 (directional lights); screen positions in window pixels.

use super::orbit::project;
use super::Viewer;
use crate::bvh::{Bvh, BvhBuildParams};
use crate::engine::Change;
use crate::scene::Light;
use crate::trace::ray::Ray;
use anyhow::{bail, Result};
use glam::{Vec2, Vec3};
use winit::dpi::PhysicalSize;

impl Viewer {
    pub(super) fn set_light(&mut self, index: usize, light: Light) {
        self.lights[index] = light;
        self.engine.send(Change::MoveLight { index, light });
        if let Some(a) = self.auto_exposure.as_mut() {
            a.hold();
        }
    }

    pub(super) fn light(&self, index: usize) -> Result<Light> {
        match self.lights.get(index) {
            Some(l) => Ok(*l),
            None => bail!("light {index} does not exist (the scene has {})", self.lights.len()),
        }
    }

    pub(super) fn move_light(&mut self, index: usize, delta: Vec3) -> Result<()> {
        let l = self.light(index)?;
        self.set_light(index, l.moved(delta));
        Ok(())
    }

    pub(super) fn set_intensity(&mut self, index: usize, value: f32) -> Result<()> {
        let l = self.light(index)?;
        if !(value.is_finite() && value >= 0.0) {
            bail!("light intensity {value} must be finite and >= 0");
        }
        self.set_light(index, l.with_strength(value));
        Ok(())
    }

    /// A point light halfway between the camera and the surface at the
    /// centre of the view (so in free space and in sight), as strong as the
    /// selected light (or 1 W/sr).
    pub(super) fn add_light(&mut self) -> Result<()> {
        if self.lights.len() >= crate::render::MAX_LIGHTS {
            bail!("the renderer draws at most {} lights", crate::render::MAX_LIGHTS);
        }
        let cam = self.orbit.camera();
        let dir = (cam.target - cam.position).normalize_or_zero();
        let bvh = Bvh::build(&self.positions, &self.prepared.triangles, &BvhBuildParams::default());
        let t = bvh.intersect(&Ray::new(cam.position, dir)).map_or(self.orbit.distance, |h| h.t);
        let i = self.lights.get(self.selected).map_or(1.0, Light::strength).max(1e-6);
        let light = Light::Point { position: cam.position + dir * (0.5 * t), intensity: Vec3::splat(i) };
        self.lights.push(light);
        self.intensity_range.push((i * 1e-2, i * 1e2));
        self.selected = self.lights.len() - 1;
        self.engine.send(Change::AddLight(light));
        Ok(())
    }

    pub(super) fn remove_light(&mut self, index: usize) -> Result<()> {
        self.light(index)?;
        self.lights.remove(index);
        self.intensity_range.remove(index);
        self.selected = self.selected.min(self.lights.len().saturating_sub(1));
        self.engine.send(Change::RemoveLight(index));
        Ok(())
    }

    /// Sets mesh `mesh`'s emission to `value` W/m^2 in its strongest
    /// channel, colour kept (a mesh that did not glow glows white).
    pub(super) fn set_emission(&mut self, mesh: usize, value: f32) -> Result<()> {
        let Some(current) = self.mesh_emission.get(mesh).map(|m| m.1) else {
            bail!("mesh {mesh} does not exist (the scene has {})", self.mesh_emission.len())
        };
        if !(value.is_finite() && value >= 0.0) {
            bail!("emission {value} must be finite and >= 0");
        }
        let m = current.max_element();
        let emission = if m > 0.0 { current * (value / m) } else { Vec3::splat(value) };
        self.mesh_emission[mesh].1 = emission;
        self.engine.send(Change::SetEmission { mesh, emission });
        Ok(())
    }

    /// Sets the sky's intensity (multiplier) and rotation about +y (degrees).
    pub(super) fn set_sky(&mut self, intensity: f32, rotate_deg: f32) -> Result<()> {
        let Some(sky) = &mut self.sky else { bail!("the scene has no sky") };
        if !(intensity.is_finite() && intensity >= 0.0 && rotate_deg.is_finite()) {
            bail!("sky intensity {intensity} must be finite and >= 0, rotation {rotate_deg} finite");
        }
        sky.intensity = intensity;
        sky.rotate_deg = rotate_deg;
        self.engine.send(Change::SetSky(Some(sky.clone())));
        Ok(())
    }

    pub(super) fn set_rays(&mut self, rays: u32) {
        self.rays_k = (rays as f64).sqrt().round() as u32;
        if rays != self.settings.rays_per_vertex {
            self.settings.rays_per_vertex = rays;
            self.engine.send(Change::Settings(self.settings));
        }
    }

    pub(super) fn scale_rays(&mut self, up: bool) {
        let k = (self.settings.rays_per_vertex as f64).sqrt().round().max(1.0) as u32;
        let k = if up { (k * 2).min(32) } else { (k / 2).max(1) };
        self.set_rays(k * k);
    }

    /// Window pixels of each light (point lights on screen; `None` otherwise).
    pub(super) fn light_pixels(&self, size: PhysicalSize<u32>) -> Vec<Option<Vec2>> {
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
    pub(super) fn pick_light(&self, at: Vec2) -> Option<usize> {
        let size = self.window.as_ref()?.inner_size();
        self.light_pixels(size)
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.map(|p| (i, p.distance(at))))
            .filter(|(_, d)| *d <= 12.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }
}
