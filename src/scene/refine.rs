//! A-priori refinement of coarse meshes (issue 31, first part): conforming
//! edge splits until no edge is longer than a target length, so one value
//! per vertex can carry the light across large faces.
//!
//! Each pass marks every edge longer than [`RefineParams::max_edge`]
//! (world metres: object length times the mesh's scale) and splits it at
//! its midpoint `(p + q) / 2`; each triangle is then cut by how many of its
//! edges were marked: one (two triangles, the midpoint to the opposite
//! corner), two (three: the midpoints joined, the quad left split along its
//! shorter diagonal) or three (four, the midpoints joined). Marks belong to
//! edges, so the two triangles beside an edge split it alike: the result is
//! conforming (no T-junctions) wherever the input was, and edges that
//! coincide in space but are indexed twice (an OBJ's separate groups) split
//! at bit-identical midpoints, which preparation welds. A median is never
//! longer than the longer of its triangle's two other sides, so passes
//! shorten edges until none is too long, the vertex budget
//! ([`RefineParams::max_vertices`], per mesh) would be passed, or
//! [`MAX_PASSES`] have run.
//!
//! Kept: every input position keeps its index and value (new positions
//! are appended), triangles keep their materials and winding, per-position
//! attributes (albedo, emission, texture coordinates and factors) are
//! averaged at midpoints. Deviations: a textured mesh's new vertices take
//! the mean of their edge's albedo, not the texture's value there; dynamic
//! meshes (with deformers) are left as they are.

use super::{MeshDesc, SceneDesc};
use glam::Vec3;
use std::collections::HashMap;

/// Most passes of [`refine_mesh`].
pub const MAX_PASSES: u32 = 32;

/// What [`refine_scene`] refines to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineParams {
    /// Longest edge kept, world metres.
    pub max_edge: f32,
    /// Most positions a mesh may reach; a pass that would pass it is not made.
    pub max_vertices: usize,
}

/// What refinement did to one mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RefineStats {
    /// Positions of the mesh before refinement.
    pub positions_before: usize,
    /// Positions after refinement.
    pub positions_after: usize,
    /// Triangles before refinement.
    pub triangles_before: usize,
    /// Triangles after refinement.
    pub triangles_after: usize,
    /// Split passes made.
    pub passes: u32,
    /// Whether the budget stopped it with edges still over the target.
    pub stopped_by_budget: bool,
}

impl RefineStats {
    fn unchanged(m: &MeshDesc) -> Self {
        RefineStats {
            positions_before: m.positions.len(),
            positions_after: m.positions.len(),
            triangles_before: m.triangles.len(),
            triangles_after: m.triangles.len(),
            passes: 0,
            stopped_by_budget: false,
        }
    }
}

/// Whether refinement may touch `mesh`: every index in range and every
/// position finite. Others are left as they are, for preparation to
/// report (naming the mesh and the triangle).
fn refinable(mesh: &MeshDesc) -> bool {
    let n = mesh.positions.len();
    !mesh.dynamic
        && mesh.triangle_material.len() == mesh.triangles.len()
        && mesh.positions.iter().all(|p| p.is_finite())
        && mesh.triangles.iter().all(|t| t.iter().all(|&i| (i as usize) < n))
}

/// A triangle preparation drops (a repeated corner or zero area, by its
/// rule): it marks no edge and is not cut.
fn degenerate(t: &[u32; 3], p: &[Vec3]) -> bool {
    let [a, b, c] = t.map(|i| p[i as usize]);
    let cross = (b - a).cross(c - a);
    let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || super::prep::zero_area(cross, longest)
}

fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// `mesh` with its edges split to at most `params.max_edge` (world metres).
pub fn refine_mesh(mesh: &MeshDesc, params: &RefineParams) -> (MeshDesc, RefineStats) {
    let mut out = mesh.clone();
    let mut stats = RefineStats {
        positions_before: mesh.positions.len(),
        triangles_before: mesh.triangles.len(),
        ..Default::default()
    };
    let scale = mesh.transform.scale.abs();
    if !refinable(mesh) || !(params.max_edge > 0.0 && scale > 0.0 && params.max_edge.is_finite()) {
        stats.positions_after = mesh.positions.len();
        stats.triangles_after = mesh.triangles.len();
        return (out, stats);
    }
    let limit2 = (params.max_edge / scale).powi(2);
    for _ in 0..MAX_PASSES {
        let long = |a: u32, b: u32| out.positions[a as usize].distance_squared(out.positions[b as usize]) > limit2;
        let marked = mark_edges(&out, long);
        if marked.is_empty() {
            break;
        }
        if out.positions.len() + marked.len() > params.max_vertices {
            stats.stopped_by_budget = true;
            break;
        }
        split_edges(&mut out, &marked);
        stats.passes += 1;
    }
    stats.positions_after = out.positions.len();
    stats.triangles_after = out.triangles.len();
    (out, stats)
}

/// The edges of `mesh` for which `mark(a, b)` holds, each once, in the
/// order the triangles first use them.
fn mark_edges(mesh: &MeshDesc, mark: impl Fn(u32, u32) -> bool) -> Vec<(u32, u32)> {
    let mut marked = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for t in mesh.triangles.iter().filter(|t| !degenerate(t, &mesh.positions)) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if mark(a, b) && seen.insert(edge_key(a, b)) {
                marked.push(edge_key(a, b));
            }
        }
    }
    marked
}

/// One conforming pass: splits the `marked` edges (keys from [`edge_key`])
/// at their midpoints and cuts every triangle by its marked edges.
/// Returns each new triangle's parent (its index before the pass).
fn split_edges(out: &mut MeshDesc, marked: &[(u32, u32)]) -> Vec<u32> {
    let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(marked.len());
    for &(a, b) in marked {
        mid.insert((a, b), push_midpoint(out, a as usize, b as usize));
    }
    let mut triangles = Vec::with_capacity(out.triangles.len() * 2);
    let mut parents = Vec::with_capacity(out.triangles.len() * 2);
    let mut materials = Vec::with_capacity(out.triangles.len() * 2);
    let mut maps = out.textures.as_ref().map(|_| Vec::with_capacity(out.triangles.len() * 2));
    for (i, t) in out.triangles.iter().enumerate() {
        let m: [Option<u32>; 3] = if degenerate(t, &out.positions) {
            [None; 3]
        } else {
            std::array::from_fn(|k| mid.get(&edge_key(t[k], t[(k + 1) % 3])).copied())
        };
        for p in split(*t, m, &out.positions) {
            triangles.push(p);
            parents.push(i as u32);
            materials.push(out.triangle_material[i]);
            if let (Some(maps), Some(tex)) = (maps.as_mut(), out.textures.as_ref()) {
                maps.push(tex.triangle_map[i]);
            }
        }
    }
    out.triangles = triangles;
    out.triangle_material = materials;
    if let (Some(maps), Some(tex)) = (maps, out.textures.as_mut()) {
        tex.triangle_map = maps;
    }
    parents
}

/// Appends the midpoint of positions `a` and `b` with averaged attributes.
fn push_midpoint(m: &mut MeshDesc, a: usize, b: usize) -> u32 {
    let avg = |v: &[Vec3]| (v[a] + v[b]) * 0.5;
    let p = avg(&m.positions);
    m.positions.push(p);
    if let Some(v) = m.vertex_albedo.as_mut() {
        let x = avg(v);
        v.push(x);
    }
    if let Some(v) = m.vertex_emission.as_mut() {
        let x = avg(v);
        v.push(x);
    }
    if let Some(t) = m.textures.as_mut() {
        let uv = (t.uv[a] + t.uv[b]) * 0.5;
        let f = (t.factor[a] + t.factor[b]) * 0.5;
        t.uv.push(uv);
        t.factor.push(f);
    }
    (m.positions.len() - 1) as u32
}

/// The pieces of triangle `t` whose edge `k` (from corner `k` to `k + 1`)
/// has midpoint `m[k]` where marked; counter-clockwise as `t`.
fn split(t: [u32; 3], m: [Option<u32>; 3], positions: &[Vec3]) -> Vec<[u32; 3]> {
    let marked = m.iter().filter(|x| x.is_some()).count();
    // Rotate so that the pattern is canonical: one mark on edge 0, or the
    // unmarked edge of two at edge 2.
    let r = match marked {
        1 => m.iter().position(|x| x.is_some()).unwrap_or(0),
        2 => (m.iter().position(|x| x.is_none()).unwrap_or(2) + 1) % 3,
        _ => 0,
    };
    let (a, b, c) = (t[r], t[(r + 1) % 3], t[(r + 2) % 3]);
    let (m0, m1, m2) = (m[r], m[(r + 1) % 3], m[(r + 2) % 3]);
    match (m0, m1, m2) {
        (None, None, None) => vec![t],
        (Some(m0), None, None) => vec![[a, m0, c], [m0, b, c]],
        (Some(m0), Some(m1), None) => {
            let d = |x: u32, y: u32| positions[x as usize].distance_squared(positions[y as usize]);
            let mut out = vec![[m0, b, m1]];
            if d(a, m1) <= d(m0, c) {
                out.extend([[a, m0, m1], [a, m1, c]]);
            } else {
                out.extend([[a, m0, c], [m0, m1, c]]);
            }
            out
        }
        (Some(m0), Some(m1), Some(m2)) => vec![[a, m0, m2], [m0, b, m1], [m2, m1, c], [m0, m1, m2]],
        _ => vec![t], // not reached: the rotation makes the patterns above
    }
}

/// How the solver refines coarse meshes: `[settings]` keys `refine`
/// ("auto" | "off"), `refine_max_edge`, `refine_tolerance` and
/// `refine_max_added`; `--refine`, `--max-edge`, `--refine-tolerance`,
/// `--refine-max-added`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefineSettings {
    /// `Auto` refines meshes with edges longer than the target (a priori,
    /// in [`crate::scene::prep::prepare`]) and then where the light needs it
    /// (`crate::solver::adaptive`); `Off` keeps every mesh as it is.
    pub mode: RefineMode,
    /// Longest edge kept a priori, metres; 0 (the default) takes
    /// `AUTO_EDGE_SHARE` of the scene's bounding-box diagonal. Shorter:
    /// more vertices (rays and links grow with them), finer light.
    pub max_edge: f32,
    /// Error-driven splits: an edge of a coarse mesh splits where the
    /// irradiance of its ends differs by more than this share of their
    /// mean (and of 5% of the scene's mean). Lower: more splits, closer to
    /// the noise of the solution (about 5% a vertex at 256 rays).
    pub tolerance: f32,
    /// Most positions refinement may add to the scene's input (the
    /// budget), so a scene of any size refines where its light needs it; a
    /// pass or round that would pass it is cut to it, and a note says so.
    pub max_added: u32,
    /// The lighting mesh's triangle budget: a scene whose input has more
    /// triangles has its dense static meshes simplified until the whole
    /// fits it (`scene/simplify.rs`; their own positions take the
    /// light through a transfer). At least 1000. Lower: faster solves of
    /// dense scenes, light interpolated over larger triangles.
    pub max_triangles: u32,
}

/// The default [`RefineSettings::max_triangles`]: above every built-in
/// scene (conference: 237k triangles), so none is simplified.
pub const DEFAULT_MAX_TRIANGLES: u32 = 300_000;

/// Whether the solver refines coarse meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RefineMode {
    /// Refine coarse meshes (a priori, then where the light needs it).
    Auto,
    /// Keep every mesh as it is.
    Off,
}

/// The automatic a-priori target: this share of the scene's bounding-box
/// diagonal. Measured on the built-ins (longest edge over diagonal):
/// cornell 0.041, furnace 0.024, colorlamp 0.076, window 0.057, torso
/// 0.045, tearoom and dancer 0.039, sculpture 0.031, conference 0.010, so
/// none is refined; McGuire's Cornell box: 0.82 (34 triangles).
pub const AUTO_EDGE_SHARE: f32 = 0.08;

impl Default for RefineSettings {
    fn default() -> Self {
        Self {
            mode: RefineMode::Auto,
            max_edge: 0.0,
            tolerance: 0.25,
            max_added: 250_000,
            max_triangles: DEFAULT_MAX_TRIANGLES,
        }
    }
}

impl RefineSettings {
    /// Refinement off.
    pub const fn off() -> Self {
        Self {
            mode: RefineMode::Off,
            max_edge: 0.0,
            tolerance: 0.25,
            max_added: 250_000,
            max_triangles: DEFAULT_MAX_TRIANGLES,
        }
    }

    /// Whether the lighting mesh is made for the light (`refine = "auto"`:
    /// coarse meshes refined, dense ones simplified).
    pub fn auto(&self) -> bool {
        self.mode == RefineMode::Auto
    }

    /// Checks ranges: finite non-negative edge, positive finite tolerance.
    pub fn validate(&self) -> crate::Result<()> {
        if !(self.max_edge.is_finite() && self.max_edge >= 0.0) {
            return Err(crate::Error::Setting(format!("refine_max_edge = {} is not a length >= 0", self.max_edge)));
        }
        if self.max_triangles < 1000 {
            return Err(crate::Error::Setting(format!(
                "refine_max_triangles = {} is below 1000",
                self.max_triangles
            )));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(crate::Error::Setting(format!("refine_tolerance = {} is not positive", self.tolerance)));
        }
        Ok(())
    }

    /// The a-priori target length for `scene`, metres (`max_edge`, or
    /// `AUTO_EDGE_SHARE` of its diagonal).
    pub fn target_edge(&self, scene: &SceneDesc) -> f32 {
        if self.max_edge > 0.0 {
            self.max_edge
        } else {
            AUTO_EDGE_SHARE * scene_diagonal(scene)
        }
    }
}

/// The diagonal of the bounding box of every mesh's finite world
/// positions, metres (0 for an empty scene).
pub fn scene_diagonal(scene: &SceneDesc) -> f32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for m in &scene.meshes {
        let t = m.transform.matrix();
        for p in m.positions.iter().map(|p| t.transform_point3(*p)).filter(|p| p.is_finite()) {
            (lo, hi) = (lo.min(p), hi.max(p));
        }
    }
    if lo.cmple(hi).all() {
        (hi - lo).length()
    } else {
        0.0
    }
}

/// Per mesh: whether it is coarse, an edge of it longer than `max_edge`
/// world metres (dynamic meshes never are). Error-driven splits touch
/// coarse meshes only, so a finely tessellated scene refines nothing.
pub fn coarse_meshes(scene: &SceneDesc, max_edge: f32) -> Vec<bool> {
    scene
        .meshes
        .iter()
        .map(|m| {
            let limit = max_edge / m.transform.scale.abs();
            refinable(m)
                && m.triangles.iter().filter(|t| !degenerate(t, &m.positions)).any(|t| {
                    (0..3).any(|k| m.positions[t[k] as usize].distance(m.positions[t[(k + 1) % 3] as usize]) > limit)
                })
        })
        .collect()
}

/// The a-priori step of `settings` on `scene` (nothing when off): every
/// mesh's edges split to the target length, then the coarse meshes'
/// triangles in which geometry stands split to half its height
/// ([`super::contact`]), within the budget.
pub fn apriori(scene: &SceneDesc, settings: &RefineSettings) -> (SceneDesc, Vec<RefineStats>) {
    if settings.mode == RefineMode::Off {
        let stats = scene.meshes.iter().map(|m| RefineStats::unchanged(m)).collect();
        return (scene.clone(), stats);
    }
    let max_edge = settings.target_edge(scene);
    let mut out = scene.clone();
    let mut added = 0usize;
    let mut stats = Vec::with_capacity(scene.meshes.len());
    let mut short = Vec::new();
    for (o, m) in out.meshes.iter_mut().zip(&scene.meshes) {
        let room = (settings.max_added as usize).saturating_sub(added);
        let (r, s) = refine_mesh(m, &RefineParams { max_edge, max_vertices: m.positions.len() + room });
        added += r.positions.len() - m.positions.len();
        if s.stopped_by_budget {
            short.push(m.name.as_str());
        }
        *o = r;
        stats.push(s);
    }
    // The second half: triangles in which geometry stands (module contact).
    let coarse = coarse_meshes(scene, max_edge);
    let room = (settings.max_added as usize).saturating_sub(added);
    let t = std::time::Instant::now();
    let (cut, contact) = super::contact::split(scene, &out, &coarse, max_edge, room, &split_world_edges);
    if contact.edges > 0 {
        log::info!(
            "a-priori contact splits: {} edges in {} passes ({:.2} s) where geometry stands in a coarse triangle",
            contact.edges,
            contact.passes,
            t.elapsed().as_secs_f64()
        );
        for (s, m) in stats.iter_mut().zip(&cut.meshes) {
            (s.positions_after, s.triangles_after) = (m.positions.len(), m.triangles.len());
        }
        out = cut;
    }
    if contact.stopped_by_budget {
        short.push("(contact splits)");
    }
    if !short.is_empty() {
        log::info!(
            "the refinement budget (refine_max_added = {}) stopped the a-priori step at {} added positions; \
             edges longer than {max_edge:.3} m remain in {} mesh(es): {}",
            settings.max_added,
            added,
            short.len(),
            short.join(", ")
        );
    }
    (out, stats)
}

pub use super::edges::{world_edge, WorldEdge};

/// One conforming pass over every mesh: the edges whose world key is in
/// `marks` split at their midpoints (the error-driven step). Also returns,
/// per mesh, each new triangle's parent: the index of the triangle of
/// `scene`'s mesh it is a piece of (itself where nothing was split).
pub fn split_world_edges(
    scene: &SceneDesc,
    marks: &std::collections::HashSet<WorldEdge>,
) -> (SceneDesc, Vec<Vec<u32>>) {
    let mut out = scene.clone();
    let mut parents = Vec::with_capacity(out.meshes.len());
    for m in out.meshes.iter_mut() {
        let same = (0..m.triangles.len() as u32).collect();
        if !refinable(m) {
            parents.push(same);
            continue;
        }
        let t = m.transform.matrix();
        let world: Vec<Vec3> = m.positions.iter().map(|p| t.transform_point3(*p)).collect();
        let marked = mark_edges(m, |a, b| marks.contains(&world_edge(world[a as usize], world[b as usize])));
        parents.push(if marked.is_empty() { same } else { split_edges(m, &marked) });
    }
    (out, parents)
}

/// Every mesh of `scene` refined; the stats per mesh.
#[cfg(any(test, feature = "internals"))]
pub fn refine_scene(scene: &SceneDesc, params: &RefineParams) -> (SceneDesc, Vec<RefineStats>) {
    let mut out = scene.clone();
    let mut stats = Vec::with_capacity(scene.meshes.len());
    for (o, m) in out.meshes.iter_mut().zip(&scene.meshes) {
        let (r, s) = refine_mesh(m, params);
        *o = r;
        stats.push(s);
    }
    (out, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes::MeshBuilder;

    /// How many triangles use each edge, positions welded by their bits
    /// (as preparation welds them): 2 everywhere on a closed surface.
    fn edge_uses(m: &MeshDesc) -> HashMap<(u32, u32), u32> {
        let mut first: HashMap<[u32; 3], u32> = HashMap::new();
        let id: Vec<u32> = (0..m.positions.len())
            .map(|i| *first.entry(m.positions[i].to_array().map(f32::to_bits)).or_insert(i as u32))
            .collect();
        let mut uses = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *uses.entry(edge_key(id[t[k] as usize], id[t[(k + 1) % 3] as usize])).or_insert(0) += 1;
            }
        }
        uses
    }

    /// Each triangle's area vector (half its cross product), m^2.
    fn area_vectors(m: &MeshDesc) -> impl Iterator<Item = Vec3> + '_ {
        m.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            (b - a).cross(c - a) * 0.5
        })
    }

    fn coarse_box() -> MeshDesc {
        let mut b = MeshBuilder::new();
        let m = b.add_material("w", Vec3::splat(0.5));
        b.cuboid(Vec3::ZERO, Vec3::new(2.0, 1.0, 3.0), 1, m, true);
        b.finish("box", 30.0)
    }

    #[test]
    fn a_closed_box_stays_closed_and_keeps_its_vertices() {
        let mesh = coarse_box();
        let before = edge_uses(&mesh);
        assert!(before.values().all(|&u| u == 2), "the input box is closed");
        let (r, s) = refine_mesh(&mesh, &RefineParams { max_edge: 0.3, max_vertices: 100_000 });
        eprintln!("{s:?}");
        assert!(s.triangles_after > 10 * s.triangles_before && s.passes > 1);
        assert!(edge_uses(&r).values().all(|&u| u == 2), "a T-junction or a hole after refinement");
        assert_eq!(&r.positions[..mesh.positions.len()], &mesh.positions[..], "input positions moved");
        let longest = r
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .map(|(a, b)| r.positions[a as usize].distance(r.positions[b as usize]))
            .fold(0f32, f32::max);
        assert!(longest <= 0.3, "an edge of {longest} m is left");
        // Area and orientation kept: the area vectors' absolute components sum as before.
        let area = |m: &MeshDesc| -> Vec3 { area_vectors(m).map(Vec3::abs).sum() };
        assert!((area(&r) - area(&mesh)).abs().max_element() < 1e-4, "{} vs {}", area(&r), area(&mesh));
    }

    /// The error-driven pass (edges named by their world positions, any
    /// subset of them) keeps a closed surface closed, its input positions
    /// and its area, also where marks meet triangles in every pattern.
    #[test]
    fn error_driven_splits_stay_conforming() {
        let mesh = coarse_box();
        let (fine, _) = refine_mesh(&mesh, &RefineParams { max_edge: 0.8, max_vertices: 100_000 });
        let mut scene = crate::scene::builtin::closed_room(2, 0.5);
        scene.meshes = vec![fine.clone()];
        let world = |i: u32| scene.meshes[0].transform.matrix().transform_point3(fine.positions[i as usize]);
        // Every third edge, by a hash of its key: one, two and three marks per triangle all occur.
        let marks: std::collections::HashSet<WorldEdge> = fine
            .triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| edge_key(t[k], t[(k + 1) % 3])))
            .filter(|&(a, b)| (a.wrapping_mul(2654435761) ^ b.wrapping_mul(40503)) % 3 == 0)
            .map(|(a, b)| world_edge(world(a), world(b)))
            .collect();
        let (out, parents) = split_world_edges(&scene, &marks);
        let r = &out.meshes[0];
        // Every piece lies in its parent's plane and the pieces of a parent cover its area.
        let mut covered = vec![0f32; fine.triangles.len()];
        for (j, t) in r.triangles.iter().enumerate() {
            let p = parents[0][j] as usize;
            let [a, b, c] = t.map(|i| r.positions[i as usize]);
            let [pa, pb, pc] = fine.triangles[p].map(|i| fine.positions[i as usize]);
            let n = (pb - pa).cross(pc - pa).normalize();
            assert!([a, b, c].iter().all(|x| (*x - pa).dot(n).abs() < 1e-5), "piece {j} off its parent {p}");
            covered[p] += (b - a).cross(c - a).length() * 0.5;
        }
        for (p, t) in fine.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| fine.positions[i as usize]);
            let area = (b - a).cross(c - a).length() * 0.5;
            assert!((covered[p] - area).abs() < 1e-5 * area.max(1.0), "parent {p}: {} of {area}", covered[p]);
        }
        assert!(r.triangles.len() > fine.triangles.len() + marks.len(), "{} marks", marks.len());
        assert!(edge_uses(r).values().all(|&u| u == 2), "a T-junction or a hole after the error-driven pass");
        assert_eq!(&r.positions[..fine.positions.len()], &fine.positions[..], "input positions moved");
        let area = |m: &MeshDesc| -> f32 { area_vectors(m).map(Vec3::length).sum() };
        assert!((area(r) - area(&fine)).abs() < 1e-4 * area(&fine));
    }

    #[test]
    fn a_fine_mesh_refines_nothing_and_the_budget_holds() {
        let mesh = coarse_box();
        let (same, s) = refine_mesh(&mesh, &RefineParams { max_edge: 10.0, max_vertices: 100_000 });
        assert_eq!((same.triangles.clone(), s.passes), (mesh.triangles.clone(), 0));
        let (r, s) = refine_mesh(&mesh, &RefineParams { max_edge: 0.01, max_vertices: 500 });
        assert!(r.positions.len() <= 500 && s.passes > 0, "{s:?}");
        assert!(edge_uses(&r).values().all(|&u| u == 2));
    }
}
