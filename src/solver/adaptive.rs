//! Error-driven (a-posteriori) refinement of coarse meshes: the lighting
//! mesh refines itself where one value per vertex cannot carry the light.
//!
//! Vertex links compute irradiance at vertices and everything downstream
//! (the picture, the bounces' radiosity at link hits) interpolates it
//! linearly across triangles. After the a-priori step
//! ([`crate::scene::refine::apriori`], in preparation) has cut a coarse
//! mesh's edges to the target length `L`, each round here solves, then
//! marks every edge of a coarse mesh ([`refine::coarse_meshes`]) longer
//! than `L / 4` whose ends' irradiance differ by more than the tolerance:
//!
//! `|Y_a - Y_b| > tol * max((Y_a + Y_b) / 2, 0.05 * mean Y)`,
//!
//! `Y` the luminance of the whole irradiance at the vertex (direct, sky and
//! indirect, W/m^2). Such an edge crosses a shadow border or a pool of
//! light that linear interpolation smears; it is split at its midpoint
//! (conforming: the same split pass as the a-priori step), and the next
//! round solves the refined scene. Where the marks would pass the budget
//! of positions, the edges whose ends differ most are split up to it.
//! Rounds stop when nothing is marked, at the budget, or after
//! [`MAX_ROUNDS`]. A scene without coarse meshes is solved once, as before.
//!
//! Deviations from the design: each round solves the refined scene
//! afresh (new vertices shoot their rays, and so do all others) instead of
//! re-assigning the hits of split triangles to their pieces; the indicator
//! is the corners' difference, so a feature wholly inside one triangle of
//! length `L` is found only by the a-priori step. Dynamic meshes are left
//! as they are (refit keeps their topology). A light that moves later keeps
//! the mesh refined for where it was.

use super::{Compute, SolveParams, Solver};
use crate::render::exposure::luminance;
use crate::scene::refine::{self, RefineMode, WorldEdge};
use crate::scene::{prep, SceneDesc};
use crate::solver::Solution;
use std::collections::HashSet;
use std::time::Instant;

/// Most error-driven rounds after the first solve.
pub const MAX_ROUNDS: usize = 4;

/// One solve of the refinement loop.
#[derive(Clone, Debug, Default)]
pub struct Round {
    /// Solver vertices and triangles of the scene solved in this round.
    pub vertices: usize,
    pub triangles: usize,
    /// Edges this round's solution marked for splitting (0 in the last).
    pub marked: usize,
    /// Preparation, links and solve, milliseconds.
    pub ms: f64,
    /// The solve alone ([`Solver::solve`]: bounces, corrections, smoothing), milliseconds.
    pub solve_ms: f64,
}

/// The solved, refined scene.
pub struct Refined {
    /// The scene as finally solved (refined meshes).
    pub desc: SceneDesc,
    pub solver: Solver,
    pub solution: Solution,
    pub rounds: Vec<Round>,
}

/// What refinement will do to a scene, decided on the scene as loaded
/// (before the a-priori step, which leaves no edge over the target).
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Per mesh: coarse ([`refine::coarse_meshes`]), so error-driven rounds may split it.
    pub coarse: Vec<bool>,
    /// The a-priori target length, metres.
    pub target: f32,
    /// Whether any refinement runs (`refine = "auto"` and a coarse mesh).
    pub refining: bool,
}

impl Plan {
    pub fn of(desc: &SceneDesc) -> Plan {
        let settings = &desc.settings.refine;
        let target = settings.target_edge(desc);
        let coarse = refine::coarse_meshes(desc, target);
        let refining = settings.mode == RefineMode::Auto && coarse.contains(&true);
        Plan { coarse, target, refining }
    }
}

/// Prepares and solves `desc` (as loaded), refining its coarse meshes
/// where the light needs it (by `desc.settings.refine`; once, unrefined,
/// when it is off or nothing is coarse).
pub fn solve(desc: &SceneDesc, compute: &Compute, progress: &(dyn Fn(usize, usize) + Sync)) -> crate::Result<Refined> {
    let plan = Plan::of(desc);
    let current = if plan.refining { refine::apriori(desc, &desc.settings.refine).0 } else { desc.clone() };
    let prepared = prep::prepare(&current)?;
    solve_planned(current, prepared, &plan, compute, progress)
}

/// [`solve`] from the a-priori refined scene `desc` and its preparation
/// `prepared` (which may differ from `prep::prepare(&desc)` in its light:
/// the CLI adds a default sky to scenes without any), by `plan` (made on
/// the scene as loaded).
pub fn solve_planned(
    mut current: SceneDesc,
    mut prepared: prep::PreparedScene,
    plan: &Plan,
    compute: &Compute,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> crate::Result<Refined> {
    let settings = current.settings.refine;
    let mut rounds = Vec::new();
    loop {
        let t = Instant::now();
        let solver = Solver::new_on(prepared, SolveParams::from_settings(&current.settings), compute, progress)?;
        let ts = Instant::now();
        let solution = solver.solve();
        let solve_ms = ts.elapsed().as_secs_f64() * 1e3;
        let s = solver.scene();
        let mut round =
            Round { vertices: s.vertex_count(), triangles: s.triangles.len(), solve_ms, ..Default::default() };
        let marks = if plan.refining && rounds.len() < MAX_ROUNDS {
            mark(s, &solution, &plan.coarse, plan.target / 4.0, settings.tolerance)
        } else {
            Vec::new()
        };
        // Within the budget: the edges whose ends differ most first (an
        // edge indexed twice, as in two OBJ groups, adds two positions).
        let budget = settings.max_vertices as usize;
        let mut take = budget.saturating_sub(positions(&current)).min(marks.len());
        let mut next = None;
        while take > 0 {
            let chosen: HashSet<WorldEdge> = marks[..take].iter().map(|(_, e)| *e).collect();
            let split = refine::split_world_edges(&current, &chosen);
            let over = positions(&split).saturating_sub(budget);
            if over == 0 {
                next = Some(split);
                break;
            }
            take = take.saturating_sub(over);
        }
        round.marked = take;
        round.ms = t.elapsed().as_secs_f64() * 1e3;
        rounds.push(round);
        let Some(next) = next else {
            return Ok(Refined { desc: current, solver, solution, rounds });
        };
        let sky = s.sky.clone();
        current = next;
        prepared = prep::prepare(&current)?;
        prepared.sky = sky;
    }
}

fn positions(desc: &SceneDesc) -> usize {
    desc.meshes.iter().map(|m| m.positions.len()).sum()
}

/// The edges of coarse meshes longer than `min_edge` whose ends'
/// irradiance differ by more than `tolerance` (module doc), each once, the
/// largest relative difference first (ties in a fixed order).
fn mark(
    scene: &prep::PreparedScene,
    sol: &Solution,
    coarse: &[bool],
    min_edge: f32,
    tolerance: f32,
) -> Vec<(f32, WorldEdge)> {
    let y: Vec<f32> =
        (0..scene.vertex_count()).map(|v| luminance(sol.e_direct[v] + sol.e_sky[v] + sol.e_indirect[v])).collect();
    let mean = y.iter().map(|&x| x as f64).sum::<f64>() as f32 / y.len().max(1) as f32;
    let floor = 0.05 * mean;
    let mut marks = Vec::new();
    let mut seen = HashSet::new();
    for (m, _) in scene.meshes.iter().zip(coarse).filter(|(_, c)| **c) {
        for t in &scene.triangles[m.triangles.start as usize..m.triangles.end as usize] {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let (pa, pb) = (scene.positions[a], scene.positions[b]);
                let score = (y[a] - y[b]).abs() / (0.5 * (y[a] + y[b])).max(floor);
                let edge = refine::world_edge(pa, pb);
                if pa.distance(pb) > min_edge && score > tolerance && seen.insert(edge) {
                    marks.push((score, edge));
                }
            }
        }
    }
    marks.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    marks
}
