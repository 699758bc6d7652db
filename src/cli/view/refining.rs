//! The viewer's refinement: a scene with coarse meshes is shown at once on
//! its a-priori mesh (the engine's first solve), while a background thread
//! runs the error-driven rounds ([`adaptive::solve_planned_with`]). Each
//! round's mesh and solution are drawn as they land (a marking round:
//! fewer rays, no near field); the final round's solver is handed to the
//! engine ([`Change::Adopt`]), which carries over the lights, sky and
//! settings edited meanwhile, and the emission edits are sent again. Until
//! then edits reach the indirect light of the mesh the engine holds, and the
//! drawn rounds keep the light they were solved with (direct light is
//! drawn per pixel from the edited lights, so it follows at once).
//!
//! Scenes that deform are not refined in the viewer (their engine updates
//! are bound to one mesh); `render` and `solve` refine them as before.

use super::Viewer;
use crate::engine::{Adopted, Change, GiResult};
use crate::scene::prep::PreparedScene;
use crate::scene::SceneDesc;
use crate::solver::adaptive::{self, Plan};
use crate::solver::{Compute, Solution, Solver};
use crossbeam_channel::{Receiver, Sender};
use glam::Vec3;
use std::sync::Arc;
use std::time::Instant;

/// What the refinement thread sends the viewer.
pub enum Landed {
    /// A marking round's mesh and solution (more rounds follow).
    Round(Box<PreparedScene>, Arc<GiResult>),
    /// The final mesh's solver and solution.
    Final(Box<Solver>, Arc<GiResult>),
    /// The refinement failed (the a-priori mesh stays).
    Failed(String),
}

/// The drawable result of `solution` on `solver`'s mesh (version 0: not
/// the engine's).
fn result(solver: &Solver, solution: Solution) -> Arc<GiResult> {
    let s = solver.scene();
    Arc::new(GiResult {
        version: 0,
        e_indirect: solution.e_indirect,
        e_direct: solution.e_direct,
        e_sky: solution.e_sky,
        emission: s.emission.clone(),
        sky: s.sky.clone(),
        lights: s.lights.clone(),
        published: Instant::now(),
        update_ms: 0.0,
        links: solver.links().stats.merged_links,
        bounces: solution.gather.bounces,
        preview: false,
    })
}

/// Starts the rounds on `desc` (the a-priori scene) and `prepared` (its
/// preparation, with the viewer's light) by `plan`; the thread stops
/// early when the viewer has gone (its receiver dropped).
pub fn start(desc: SceneDesc, prepared: PreparedScene, plan: Plan, compute: Compute) -> Receiver<Landed> {
    let (tx, rx) = crossbeam_channel::unbounded();
    let spawned =
        std::thread::Builder::new().name("linkgi-refine".into()).spawn(move || run(desc, prepared, plan, compute, tx));
    if let Err(e) = spawned {
        // The receiver then reports the failure on the first poll.
        let (tx, rx2) = crossbeam_channel::unbounded();
        let _ = tx.send(Landed::Failed(format!("starting the refinement thread: {e}")));
        return rx2;
    }
    rx
}

fn run(desc: SceneDesc, prepared: PreparedScene, plan: Plan, compute: Compute, tx: Sender<Landed>) {
    let mut on_round = |s: &Solver, sol: &Solution| {
        let _ = tx.send(Landed::Round(Box::new(s.scene().clone()), result(s, sol.clone())));
    };
    let landed = match adaptive::solve_planned_with(desc, prepared, &plan, &compute, &|_, _| {}, &mut on_round) {
        Ok(r) => {
            let gi = result(&r.solver, r.solution);
            Landed::Final(Box::new(r.solver), gi)
        }
        Err(e) => Landed::Failed(e.to_string()),
    };
    let _ = tx.send(landed);
}

impl Viewer {
    /// Takes what the refinement has landed since the last frame: the
    /// newest mesh is shown with its round's light; the final one goes to
    /// the engine.
    pub(super) fn poll_refinement(&mut self) {
        let Some(rx) = &self.refining else { return };
        let landed: Vec<Landed> = rx.try_iter().collect();
        for l in landed {
            match l {
                Landed::Round(scene, gi) => {
                    self.rounds_landed += 1;
                    self.show_mesh(*scene, gi);
                }
                Landed::Final(solver, gi) => {
                    self.rounds_landed += 1;
                    self.show_mesh(solver.scene().clone(), gi);
                    let mut batch = vec![Change::Adopt(Adopted::new(*solver))];
                    for (mesh, ((_, edited), (_, loaded))) in
                        self.mesh_emission.iter().zip(&self.loaded_emission).enumerate()
                    {
                        if edited != loaded {
                            batch.push(Change::SetEmission { mesh, emission: *edited });
                        }
                    }
                    self.engine.send_batch(batch);
                    self.refining = None;
                    log::info!("refined: {} vertices after {} rounds", self.positions.len(), self.rounds_landed);
                }
                Landed::Failed(e) => {
                    eprintln!("warning: refinement failed, the a-priori mesh stays: {e}");
                    self.refining = None;
                }
            }
        }
    }

    /// Shows `scene`'s mesh with `gi` until the engine has a result for it.
    fn show_mesh(&mut self, scene: PreparedScene, gi: Arc<GiResult>) {
        self.rest = scene.positions.clone();
        self.rest_normals = scene.normals.clone();
        self.positions = scene.positions.clone();
        self.normals = scene.normals.clone();
        self.zeros = vec![Vec3::ZERO; scene.positions.len()];
        self.prepared = scene;
        self.round_gi = Some(gi);
    }

    /// What the panel and title say about the refinement (empty when done
    /// or off).
    pub(super) fn refine_status(&self) -> String {
        if self.refining.is_some() {
            format!("refining: {} round(s) shown, {} vertices", self.rounds_landed, self.positions.len())
        } else {
            String::new()
        }
    }
}
