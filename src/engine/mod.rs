//! The asynchronous GI engine (docs/DESIGN.md §6): a background worker thread
//! owns the [`Solver`]; the application sends [`Change`]s over a crossbeam
//! channel and reads the newest published [`GiResult`] without blocking.
//!
//! The worker blocks until a change arrives, then drains everything queued
//! and coalesces it (light edits are applied in order to one light list,
//! the newest deformation and the newest settings win) and redoes only what
//! the batch invalidates:
//!
//! | change | redone |
//! |---|---|
//! | light moved / added / removed | light links of the lights at a new position or direction + gather |
//! | light intensity changed | gather (its light links are kept) |
//! | emission of a mesh, the sky (set, changed, turned, removed) | gather (sky light from the kept miss masks and portal samples, no rays) |
//! | the sky's portals (moved, added, removed) | the portals' rays and the sky's refined cells + gather |
//! | mesh deformed (new positions; static meshes must not move) | CPU: BVH refit + selective re-shooting of links and light links ([`Solver::deform`]) + gather; GPU: everything |
//! | settings: rays or seed | kd-tree + links + light links + gather |
//! | settings: bounces or smoothing | gather |
//! | a solver built elsewhere ([`Change::Adopt`]: a refined mesh) | light links where the lights were edited meanwhile + gather |
//! | deform to the current positions, or nothing | nothing (the worker sleeps on the channel) |
//!
//! With [`EngineParams::light_preview`] (the viewer's choice), a light edit
//! that needs tracing publishes a preview first (new light links from the
//! vertices alone, [`GiResult::preview`]), then the full result unless more
//! changes are already queued; the next batch then refines the preview.
//! With [`EngineParams::deform_preview`], a selective deformation update
//! publishes a preview first (the remade vertices' links at
//! [`PREVIEW_RAYS`](crate::solver::PREVIEW_RAYS) rays), then the full result at once; `wait_idle` (and
//! the viewer's `wait_gi`) wait for the full one. Previews are gathered
//! with [`Solver::solve_quick`] (no hidden-vertex correction, fixed
//! one-ring smoothing).
//!
//! Each finished update is published as a new `Arc<GiResult>` with a version
//! one higher than the last. A change that fails (bad light index, wrong
//! position count, a GPU error) or a panic inside the solver is reported
//! (`Engine::last_error`, the `errors` counter) and the last good result
//! stays published; after a panic the solver is rebuilt from the last good
//! scene on the next change. Irradiance in W/m^2, positions in metres,
//! times in ms.

mod worker;

use crate::scene::prep::PreparedScene;
use crate::scene::{Light, Settings};
use crate::sky::Sky;
use crate::solver::{Compute, DeformStats, SolveParams, Solver};
use crossbeam_channel::Sender;
use glam::Vec3;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use worker::Worker;

/// A change sent to the worker.
#[derive(Clone, Debug)]
pub enum Change {
    /// Replace light `index`.
    MoveLight {
        /// The light's index in the scene's lights.
        index: usize,
        /// The new light.
        light: Light,
    },
    /// Append a light.
    AddLight(Light),
    /// Remove light `index` (later lights move down by one).
    RemoveLight(usize),
    /// New world positions of every solver vertex (same count and order as
    /// the prepared scene; normals are recomputed from the triangles).
    Deform {
        /// World positions, metres, one per solver vertex.
        positions: Vec<Vec3>,
    },
    /// New solver settings (`backend` is ignored: the engine keeps its compute).
    Settings(Settings),
    /// Emitted exitance of every vertex of mesh `mesh` (index into the
    /// prepared scene's meshes), W/m^2.
    SetEmission {
        /// Index of the mesh in the prepared scene's meshes.
        mesh: usize,
        /// Emitted exitance per channel, W/m^2.
        emission: Vec3,
    },
    /// Replace the sky (None: no sky).
    SetSky(Option<Sky>),
    /// Replace the solver, and with it the mesh, by one built elsewhere
    /// (the viewer's refinement: each new lighting mesh as it lands). The
    /// current lights, sky and settings carry over (light links are redone
    /// where the lights differ from the adopted solver's; everything is
    /// rebuilt where rays, seed or tracer do); per-vertex emission comes
    /// with the new mesh, so emission edits are sent again after it.
    Adopt(Adopted),
    /// Test hook (feature `internals`, the tests' only): the worker
    /// panics while handling this change.
    #[cfg(feature = "internals")]
    #[doc(hidden)]
    Panic,
}

/// A solver handed to the worker once ([`Change::Adopt`]); cloning shares
/// it, and the first batch that takes it leaves the others empty.
#[derive(Clone)]
pub struct Adopted(Arc<Mutex<Option<Solver>>>);

impl Adopted {
    /// Wraps `solver` for [`Change::Adopt`].
    pub fn new(solver: Solver) -> Adopted {
        Adopted(Arc::new(Mutex::new(Some(solver))))
    }

    fn take(&self) -> Option<Solver> {
        lock(&self.0).take()
    }
}

impl std::fmt::Debug for Adopted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = lock(&self.0).as_ref().map(|s| s.scene().vertex_count());
        write!(f, "Adopted({n:?} vertices)")
    }
}

/// One published GI state.
#[derive(Clone, Debug)]
pub struct GiResult {
    /// 1 for the first solve, +1 for every update.
    pub version: u64,
    /// Smoothed indirect irradiance per solver vertex, W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Direct irradiance per solver vertex, W/m^2.
    pub e_direct: Vec<Vec3>,
    /// Irradiance from the sky per solver vertex, W/m^2.
    pub e_sky: Vec<Vec3>,
    /// Emitted exitance per solver vertex the result was computed with, W/m^2.
    pub emission: Vec<Vec3>,
    /// The sky the result was computed with.
    pub sky: Option<Sky>,
    /// The lights the result was computed for.
    pub lights: Vec<Light>,
    /// When the result was published.
    pub published: Instant,
    /// Time from taking the batch of changes to publishing, ms.
    pub update_ms: f64,
    /// Merged vertex links of the solver that produced the result.
    pub links: u64,
    /// Bounces the gather ran.
    pub bounces: u32,
    /// True for a preview ([`EngineParams::light_preview`]): some light
    /// links lack their one-ring oversampling; a full result follows.
    pub preview: bool,
}

/// What the worker has done so far and the stage times of its last update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counters {
    /// Acceleration structures built from scratch (kd-tree or BVH).
    pub kd_builds: u64,
    /// BVH refits after a deformation (instead of a build).
    pub refits: u64,
    /// Link generations (a new solver or a deformation update).
    pub link_builds: u64,
    /// Light-link computations (full or preview).
    pub light_link_updates: u64,
    /// Emitter links traced again because a surface started emitting
    /// (`Solver::update_emitters`); other emission edits are gather-only.
    pub emitter_link_updates: u64,
    /// Sky portal samples traced because the sky's portals changed (`Solver::update_portals`).
    pub portal_updates: u64,
    /// Gathers run (one per published result).
    pub gathers: u64,
    /// Results published (the version of the newest result).
    pub published: u64,
    /// Of those, previews ([`GiResult::preview`]).
    pub previews: u64,
    /// Changes received.
    pub changes: u64,
    /// Batches of changes handled (fewer than `changes` when they coalesce).
    pub batches: u64,
    /// Failed updates (errors and panics).
    pub errors: u64,
    /// Last kd-tree + links rebuild, ms.
    pub rebuild_ms: f64,
    /// Last light-link update, ms.
    pub light_links_ms: f64,
    /// Last gather + smoothing, ms.
    pub gather_ms: f64,
    /// Last whole update, ms.
    pub update_ms: f64,
    /// Figures of the last deformation update (rays re-shot, link groups
    /// patched, light links recomputed, bytes of per-ray state), if any.
    pub deform: Option<DeformStats>,
    /// Time from taking the last deformation to publishing its preview, ms
    /// (0 when it had none).
    pub preview_ms: f64,
}

/// Engine options.
#[derive(Clone, Copy, Debug, Default)]
pub struct EngineParams {
    /// Extra sleep before each update (tests and demos of a slow solve). Default 0.
    pub delay: Duration,
    /// Light edits first publish a preview: lights that need tracing get
    /// light links from their vertices alone (no one-ring oversampling,
    /// about 1/13 of the shadow rays), then, unless more changes are
    /// already queued, the full result follows. The changes count as
    /// handled ([`Counters::changes`]) only with the full result. Default
    /// off; the viewer turns it on.
    pub light_preview: bool,
    /// A deformation handled selectively first publishes a preview: the
    /// remade vertices' links shot at `PREVIEW_RAYS` rays and their light
    /// links from the vertices alone, everything else as before; the full
    /// result follows at once. Default off; the viewer and `animate` turn
    /// it on.
    pub deform_preview: bool,
}

struct Shared {
    latest: Mutex<Option<Arc<GiResult>>>,
    counters: Mutex<Counters>,
    last_error: Mutex<Option<String>>,
}

enum Msg {
    Change(Vec<Change>),
    Stop,
}

/// Handle of the running engine; dropping it stops the worker.
pub struct Engine {
    tx: Sender<Msg>,
    shared: Arc<Shared>,
    sent: u64,
    handle: Option<JoinHandle<()>>,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Gathers on `s`, publishes the result as the next version and adds this
/// run's counts `c` to the totals (then clears them, so a second publish of
/// the same batch does not count them twice). `changes` are the changes
/// the result completes; `batch_done` counts the batch as handled.
fn publish(shared: &Shared, s: &Solver, c: &mut Counters, t0: Instant, preview: bool, changes: u64, batch_done: bool) {
    let t = Instant::now();
    let sol = if preview { s.solve_quick() } else { s.solve() };
    c.gather_ms = t.elapsed().as_secs_f64() * 1e3;
    let update_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut total = lock(&shared.counters);
    let version = total.published + 1;
    let result = Arc::new(GiResult {
        version,
        links: s.links().stats.merged_links,
        bounces: sol.gather.bounces,
        e_indirect: sol.e_indirect,
        e_direct: sol.e_direct,
        e_sky: sol.e_sky,
        emission: s.scene().emission.clone(),
        sky: s.scene().sky.clone(),
        lights: s.scene().lights.clone(),
        published: Instant::now(),
        update_ms,
        preview,
    });
    *lock(&shared.latest) = Some(result);
    total.kd_builds += c.kd_builds;
    total.refits += c.refits;
    total.link_builds += c.link_builds;
    total.light_link_updates += c.light_link_updates;
    total.emitter_link_updates += c.emitter_link_updates;
    total.portal_updates += c.portal_updates;
    total.gathers += 1;
    total.published = version;
    total.previews += preview as u64;
    total.changes += changes;
    total.batches += batch_done as u64;
    if c.kd_builds + c.refits > 0 {
        total.rebuild_ms = c.rebuild_ms;
    }
    if c.deform.is_some() {
        total.deform = c.deform;
    }
    if preview && c.preview_ms > 0.0 {
        total.preview_ms = c.preview_ms;
    }
    if c.light_link_updates > 0 {
        total.light_links_ms = c.light_links_ms;
    }
    total.gather_ms = c.gather_ms;
    total.update_ms = update_ms;
    *c = Counters::default();
}

impl Engine {
    /// Starts the worker; it builds the solver and publishes version 1.
    /// Fails only where the system cannot start a thread.
    pub fn start(
        scene: PreparedScene,
        params: SolveParams,
        compute: Compute,
        options: EngineParams,
    ) -> crate::Result<Engine> {
        let (tx, rx) = crossbeam_channel::unbounded();
        let shared = Arc::new(Shared {
            latest: Mutex::new(None),
            counters: Mutex::new(Counters::default()),
            last_error: Mutex::new(None),
        });
        let sh = shared.clone();
        let handle = std::thread::Builder::new()
            .name("linkgi-gi".into())
            .spawn(move || {
                Worker { shared: sh, compute, options, params, solver: None, good: scene, pending: 0 }.run(rx)
            })
            .map_err(crate::Error::Thread)?;
        Ok(Engine { tx, shared, sent: 0, handle: Some(handle) })
    }

    /// Queues a change (never blocks).
    pub fn send(&mut self, change: Change) {
        self.send_batch(vec![change]);
    }

    /// Queues changes that are handled together (one update for all of them).
    pub fn send_batch(&mut self, changes: Vec<Change>) {
        if changes.is_empty() {
            return;
        }
        self.sent += changes.len() as u64;
        let _ = self.tx.send(Msg::Change(changes));
    }

    /// Changes sent so far (compare with [`Counters::changes`], those handled).
    pub fn sent(&self) -> u64 {
        self.sent
    }

    /// The newest published result, if any (never waits for the worker).
    pub fn latest(&self) -> Option<Arc<GiResult>> {
        lock(&self.shared.latest).clone()
    }

    /// A copy of the worker's counters: its totals so far and the stage times of its last update.
    pub fn counters(&self) -> Counters {
        *lock(&self.shared.counters)
    }

    /// The message of the newest failed update, if any.
    pub fn last_error(&self) -> Option<String> {
        lock(&self.shared.last_error).clone()
    }

    /// Waits until the first result is out and every change sent so far has
    /// been handled (published or failed), or `timeout` passes. True when idle.
    pub fn wait_idle(&self, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        loop {
            let c = self.counters();
            if c.changes >= self.sent && (c.published > 0 || c.errors > 0) {
                return true;
            }
            if Instant::now() > end || self.handle.as_ref().is_some_and(|h| h.is_finished()) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

impl Drop for Engine {
    fn drop(&mut self) {
        let _ = self.tx.send(Msg::Stop);
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}
