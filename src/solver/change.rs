//! One method per change to a built [`Solver`]'s scene, each retracing
//! exactly what the change can have changed ([`super::traced::Part`]) and
//! dropping what was derived from it, so a solve afterwards equals a fresh
//! one:
//!
//! | change | method | traced again |
//! |---|---|---|
//! | lights moved, added, removed or rescaled | [`Solver::set_lights`] ([`Solver::preview_lights`]) | the columns of lights at a new position or direction (light links and near field) |
//! | emission edited | [`Solver::set_emission`] | the emitter links, when a surface starts emitting that they do not cover |
//! | sky set, changed or removed | [`Solver::set_sky`] | the sky's rays, when its portals change or a sky appears |
//! | stage parameters | [`Solver::set_params`] | everything, when a traced part's parameters change |
//! | meshes deformed | [`Solver::deform`] ([`super::deform`]) | what the motion can have changed |

use super::compute::Tracers;
use super::traced::Part;
use super::{SolveParams, Solver};
use crate::scene::{Light, Settings};
use crate::sky::rays::portals_of;
use crate::sky::Sky;
use glam::Vec3;

impl Solver {
    /// Sets the lights and brings their light links and near-field columns
    /// up to date: only lights at a new position or direction are traced
    /// (`crate::exchange::LightLinks::update_with`); a new intensity
    /// traces nothing, and preview columns are replaced by full ones.
    pub fn set_lights(&mut self, lights: Vec<Light>) {
        self.scene.lights = lights;
        self.refresh_lights(false);
    }

    /// As [`Solver::set_lights`], but lights that need tracing get quick
    /// preview columns (`crate::exchange::LightLinks::preview_with`) and
    /// the near field's columns are left stale (its correction waits for
    /// the full update). Returns true if it traced any; then
    /// [`Solver::set_lights`] with the same lights refines them.
    pub fn preview_lights(&mut self, lights: Vec<Light>) -> bool {
        self.scene.lights = lights;
        self.refresh_lights(true);
        let l = &self.traced.light_links;
        l.shadow_rays > 0 && l.coarse.contains(&true)
    }

    /// True while some light's columns are a preview's.
    pub fn lights_preview(&self) -> bool {
        self.traced.light_links.coarse.contains(&true)
    }

    fn refresh_lights(&mut self, preview: bool) {
        let t = Tracers::of(&self.gpu, &self.accel);
        let (scene, params, near) = (&self.scene, &self.params, &self.links.near);
        let traced = &mut self.traced;
        t.any("computing light links", |tr| {
            if preview {
                traced.light_links.preview_with(scene, tr, &params.light)
            } else {
                traced.light_links.update_with(scene, tr, &params.light)
            }
        });
        // A preview leaves the near hits' columns as they are: a moved
        // light's is stale, so the preview goes without the lights' near
        // field ([`crate::exchange::NearLight::covers`]) and the full
        // update traces it.
        traced.on_cpu[Part::LightLinks.index()] |= t.take_cpu_used();
        if !preview {
            t.any("tracing near-hit light", |tr| traced.near.light.update(scene, near, tr, &params.light));
            traced.on_cpu[Part::NearLight.index()] |= t.take_cpu_used();
        }
    }

    /// Sets every vertex's emitted exitance (W/m^2). The emitter links are
    /// traced again only if some vertex now emits that they do not cover
    /// (a surface started emitting after they were built); other emission
    /// edits need no rays. Returns whether it traced.
    pub fn set_emission(&mut self, emission: Vec<Vec3>) -> bool {
        self.scene.emission = emission;
        let e = &self.traced.emitter_links;
        let uncovered = self.scene.emission.iter().zip(&e.covered).any(|(m, &c)| *m != Vec3::ZERO && !c);
        if !uncovered || e.fallback.is_some() || !self.params.terms.emitter_links {
            return false;
        }
        self.retrace(&[Part::Emitters, Part::NearEmitters]);
        true
    }

    /// Sets the sky (`None`: none). Its rays (portal samples, refined cells,
    /// the near hits' sky samples) are traced again when its portals differ
    /// from those traced or a sky appears where none was traced; a changed,
    /// turned or rescaled sky needs no rays. Returns whether it traced.
    pub fn set_sky(&mut self, sky: Option<Sky>) -> bool {
        self.scene.sky = sky;
        let same_portals = portals_of(&self.scene, &self.params.terms) == self.traced.sky.portals.portals.as_slice();
        // A sky where there was none at the last trace: its rays were never traced.
        let untraced = self.scene.sky.is_some() && !self.traced.near.sky.traced;
        if same_portals && !untraced {
            return false;
        }
        self.retrace(&[Part::Sky, Part::NearSky]);
        true
    }

    /// Sets the scene's settings as its file gave them (rays, bounces,
    /// smoothing, ...; the stages read [`Solver::params`], which
    /// [`Solver::set_params`] sets).
    pub fn set_settings(&mut self, settings: Settings) {
        self.scene.settings = settings;
    }

    /// Sets the stages' parameters. Parameters of the solve alone (bounces,
    /// smoothing, hidden vertices, corrections) take effect at the next
    /// solve; a change to what was traced (links, tracer, structures,
    /// lights, emitters, sky, near field, noise check) rebuilds the solver
    /// on its compute. Returns whether it rebuilt; parameters that do not
    /// pass [`SolveParams::validate`] are an error and change nothing.
    pub fn set_params(&mut self, params: SolveParams) -> crate::Result<bool> {
        params.validate()?;
        let params = self.with_decisions(params);
        if self.params.same_traced(&params) {
            if params.hidden != self.params.hidden || params.terms != self.params.terms {
                self.links_changed();
            }
            self.params = params;
            return Ok(false);
        }
        let scene = self.scene.clone();
        *self = Solver::new_on(scene, params, &self.compute.clone(), &|_, _| {})?;
        Ok(true)
    }
}
