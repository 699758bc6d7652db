//! The engine's worker thread: it takes batches of [`Change`]s, coalesces
//! them into a new scene and what it invalidates, updates the [`Solver`]
//! (catching panics) and publishes the result, or reports the failure.

use super::{lock, publish, Change, Counters, EngineParams, Msg, Shared};
use crate::scene::deform::moved_normals;
use crate::scene::prep::PreparedScene;
use crate::scene::Settings;
use crate::solver::{Compute, Preview, SolveParams, Solver, PREVIEW_RAYS};
use crossbeam_channel::Receiver;
use std::panic::AssertUnwindSafe;
use std::sync::Arc;
use std::time::Instant;

/// What one batch of changes invalidates.
#[derive(Default)]
struct Dirty {
    geometry: bool,
    lights: bool,
    gather: bool,
    panic: bool,
}

pub(super) struct Worker {
    pub(super) shared: Arc<Shared>,
    pub(super) compute: Compute,
    pub(super) options: EngineParams,
    pub(super) params: SolveParams,
    pub(super) solver: Option<Solver>,
    /// The scene of the last good solve (rebuild source after a panic).
    pub(super) good: PreparedScene,
    /// Changes shown so far only in a preview (counted with the next full result).
    pub(super) pending: u64,
}

impl Worker {
    pub(super) fn run(mut self, rx: Receiver<Msg>) {
        // First solve: everything.
        let scene = self.good.clone();
        self.update(scene, Dirty { geometry: true, lights: true, gather: true, panic: false }, 0, &|| false);
        while let Ok(first) = rx.recv() {
            let mut msgs = vec![first];
            msgs.extend(rx.try_iter());
            let stop = msgs.iter().any(|m| matches!(m, Msg::Stop));
            let changes: Vec<Change> = msgs
                .into_iter()
                .flat_map(|m| match m {
                    Msg::Change(c) => c,
                    Msg::Stop => Vec::new(),
                })
                .collect();
            if !changes.is_empty() {
                let n = changes.len() as u64;
                match self.coalesce(changes) {
                    Ok((scene, dirty)) => self.update(scene, dirty, n, &|| !rx.is_empty()),
                    Err(e) => self.fail(e, n),
                }
            }
            if stop {
                break;
            }
            if rx.is_empty() {
                self.settle();
            }
        }
    }

    /// With nothing queued, a preview left standing (its batch was
    /// followed by one that failed, or a panic dropped the solver) is
    /// replaced by a full result: the kept solver refines its preview
    /// columns, or a solver is rebuilt from the last good scene.
    fn settle(&mut self) {
        let shows_preview = lock(&self.shared.latest).as_ref().is_some_and(|r| r.preview);
        let coarse = self.solver.as_ref().is_some_and(|s| s.lights_preview());
        if coarse {
            let scene = self.current().clone();
            self.update(scene, Dirty { lights: true, ..Dirty::default() }, 0, &|| false);
        } else if shows_preview && self.solver.is_none() {
            let scene = self.good.clone();
            self.update(scene, Dirty { geometry: true, lights: true, gather: true, panic: false }, 0, &|| false);
        }
    }

    fn current(&self) -> &PreparedScene {
        self.solver.as_ref().map(|s| s.scene()).unwrap_or(&self.good)
    }

    /// Applies a batch of changes to a copy of the current scene.
    fn coalesce(&mut self, changes: Vec<Change>) -> Result<(PreparedScene, Dirty), String> {
        let mut scene = self.current().clone();
        let mut dirty = Dirty::default();
        let mut positions = None;
        for c in changes {
            match c {
                Change::MoveLight { index, light } => {
                    let n = scene.lights.len();
                    *scene.lights.get_mut(index).ok_or(format!("move light {index}: the scene has {n} lights"))? =
                        light;
                    dirty.lights = true;
                }
                Change::AddLight(l) => {
                    scene.lights.push(l);
                    dirty.lights = true;
                }
                Change::RemoveLight(index) => {
                    if index >= scene.lights.len() {
                        return Err(format!("remove light {index}: the scene has {} lights", scene.lights.len()));
                    }
                    scene.lights.remove(index);
                    dirty.lights = true;
                }
                Change::Deform { positions: p } => {
                    if p.len() != scene.positions.len() {
                        return Err(format!("deform: {} positions for {} vertices", p.len(), scene.positions.len()));
                    }
                    if p.iter().any(|v| !v.is_finite()) {
                        return Err("deform: non-finite position".into());
                    }
                    for m in scene.meshes.iter().filter(|m| !m.dynamic) {
                        let r = m.vertices.start as usize..m.vertices.end as usize;
                        if p[r.clone()] != scene.positions[r] {
                            return Err(format!("deform: moves vertices of the static mesh '{}'", m.name));
                        }
                    }
                    positions = Some(p);
                }
                Change::Settings(s) => {
                    s.validate().map_err(|e| e.to_string())?;
                    let old = scene.settings;
                    scene.settings = Settings { backend: old.backend, ..s };
                    if s.rays_per_vertex != old.rays_per_vertex || s.seed != old.seed || s.tracer != old.tracer {
                        dirty.geometry = true;
                    }
                    dirty.gather = true;
                    self.params = SolveParams {
                        kd: self.params.kd,
                        kd_gpu: self.params.kd_gpu,
                        bvh: self.params.bvh,
                        light: self.params.light,
                        ..SolveParams::from_settings(&scene.settings)
                    };
                }
                Change::SetEmission { mesh, emission } => {
                    let m = scene
                        .meshes
                        .get(mesh)
                        .ok_or(format!("set emission of mesh {mesh}: the scene has {} meshes", scene.meshes.len()))?;
                    if !(emission.is_finite() && emission.min_element() >= 0.0) {
                        return Err(format!("set emission of mesh {mesh}: {emission} is not finite and non-negative"));
                    }
                    let r = m.vertices.start as usize..m.vertices.end as usize;
                    scene.emission[r].fill(emission);
                    dirty.gather = true;
                }
                Change::SetSky(sky) => {
                    if let Some(s) = &sky {
                        s.validate().map_err(|e| format!("set sky: {e}"))?;
                    }
                    scene.sky = sky;
                    dirty.gather = true;
                }
                Change::Adopt(adopted) => {
                    let s = adopted.take().ok_or("adopt: that solver was adopted already")?;
                    let mut next = s.scene().clone();
                    let (old, new) = (next.settings, scene.settings);
                    dirty.lights |= scene.lights != next.lights;
                    next.lights = std::mem::take(&mut scene.lights);
                    next.sky = scene.sky.take();
                    next.settings = new;
                    // A deformation queued for the old mesh is void.
                    positions = None;
                    scene = next;
                    dirty.gather = true;
                    if (old.rays_per_vertex, old.seed, old.tracer) == (new.rays_per_vertex, new.seed, new.tracer) {
                        self.solver = Some(s);
                    } else {
                        // Other rays than the solver's: a fresh one of its mesh.
                        self.solver = None;
                        dirty.geometry = true;
                    }
                }
                #[cfg(feature = "internals")]
                Change::Panic => dirty.panic = true,
            }
        }
        // Positions identical to the current ones are no geometry change.
        if let Some(p) = positions.filter(|p| *p != scene.positions) {
            scene.normals = moved_normals(&scene, &scene.positions, &p, &scene.normals);
            scene.positions = p;
            dirty.geometry = true;
        }
        Ok((scene, dirty))
    }

    /// Handles one coalesced batch of `changes`; `more_waiting` tells
    /// whether further changes are already queued (then a light preview is
    /// not refined now: the next batch refines it).
    fn update(&mut self, scene: PreparedScene, mut dirty: Dirty, changes: u64, more_waiting: &dyn Fn() -> bool) {
        // Preview columns left by the last batch are refined by this one.
        if self.solver.as_ref().is_some_and(|s| s.lights_preview()) {
            dirty.lights = true;
        }
        if !(dirty.geometry || dirty.lights || dirty.gather || dirty.panic) {
            let mut c = lock(&self.shared.counters);
            c.changes += changes;
            c.batches += 1;
            return;
        }
        if !self.options.delay.is_zero() {
            std::thread::sleep(self.options.delay);
        }
        let t0 = Instant::now();
        let mut solver = self.solver.take();
        let params = self.params;
        let compute = self.compute.clone();
        let shared = self.shared.clone();
        let light_preview = self.options.light_preview;
        let deform_preview = self.options.deform_preview;
        let pending = self.pending;
        let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| -> Result<(Solver, bool), String> {
            if dirty.panic {
                panic!("injected panic (Change::Panic)");
            }
            let mut c = Counters::default();
            let mut s = match solver.take() {
                Some(s) if !dirty.geometry => s,
                // A deformation on the path the solver runs on: refit the
                // structure, re-shoot what moved (on the GPU there).
                Some(s) if matches!(compute, crate::solver::Compute::Gpu(_)) == s.gpu().is_some() => {
                    let t = Instant::now();
                    let mut show = |p: &Solver| {
                        c.preview_ms = t0.elapsed().as_secs_f64() * 1e3;
                        publish(&shared, p, &mut c, t0, true, 0, false);
                    };
                    let preview: Preview<'_> = if deform_preview { Some((PREVIEW_RAYS, &mut show)) } else { None };
                    let (s, d) = s.deform(scene.clone(), params, preview, &|_, _| {});
                    c.rebuild_ms = t.elapsed().as_secs_f64() * 1e3;
                    if d.refitted {
                        c.refits += 1;
                    } else {
                        c.kd_builds += 1;
                    }
                    c.link_builds += 1;
                    c.light_link_updates += 1;
                    c.light_links_ms = d.light_links_ms;
                    c.deform = Some(d);
                    s
                }
                _ => {
                    let t = Instant::now();
                    let s = Solver::new_on(scene.clone(), params, &compute, &|_, _| {}).map_err(|e| e.to_string())?;
                    c.rebuild_ms = t.elapsed().as_secs_f64() * 1e3;
                    c.kd_builds += 1;
                    c.link_builds += 1;
                    c.light_link_updates += 1;
                    c.light_links_ms = s.light_links().ms;
                    s
                }
            };
            s.set_params(params).map_err(|e| e.to_string())?;
            s.set_settings(scene.settings);
            if s.set_emission(scene.emission.clone()) {
                c.emitter_link_updates += 1;
            }
            if s.set_sky(scene.sky.clone()) {
                c.portal_updates += 1;
            }
            if dirty.lights && c.light_link_updates == 0 {
                if light_preview {
                    let t = Instant::now();
                    if s.preview_lights(scene.lights.clone()) {
                        c.light_links_ms = t.elapsed().as_secs_f64() * 1e3;
                        c.light_link_updates += 1;
                        let waiting = more_waiting();
                        publish(&shared, &s, &mut c, t0, true, 0, waiting);
                        if waiting {
                            return Ok((s, false));
                        }
                    }
                }
                let t = Instant::now();
                s.set_lights(scene.lights.clone());
                c.light_links_ms = t.elapsed().as_secs_f64() * 1e3;
                c.light_link_updates += 1;
            }
            publish(&shared, &s, &mut c, t0, false, changes + pending, true);
            Ok((s, true))
        }));
        match outcome {
            Ok(Ok((s, full))) => {
                self.pending = if full { 0 } else { pending + changes };
                self.good = s.scene().clone();
                self.solver = Some(s);
            }
            Ok(Err(e)) => {
                self.solver = solver;
                self.fail(e, changes);
            }
            Err(p) => {
                let msg = p
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into());
                // The solver may be half-updated: rebuild from the last good scene next time.
                self.solver = None;
                self.fail(format!("GI worker panicked: {msg}"), changes);
            }
        }
    }

    fn fail(&mut self, message: String, changes: u64) {
        log::warn!("GI update failed, keeping the last result: {message}");
        *lock(&self.shared.last_error) = Some(message);
        let mut c = lock(&self.shared.counters);
        c.errors += 1;
        // The changes of a standing preview count as handled here too;
        // `settle` replaces the preview with a full result.
        c.changes += changes + std::mem::take(&mut self.pending);
        c.batches += 1;
    }
}
