//! Mesh preparation: turns a [`SceneDesc`] into the solver's vertex set.
//!
//! Steps, per mesh: apply the transform (object space to world metres),
//! validate (finite coordinates, indices in range), weld corners by exact
//! position, drop zero-area triangles (counted, reported), then split welded
//! vertices at creases and material borders: two triangles sharing an edge
//! stay joined at that edge's ends when their face normals differ by at most
//! the crease angle, their windings agree, their materials match and (for
//! meshes with per-vertex albedo or emission, [`super::MeshDesc::vertex_albedo`]
//! and [`super::MeshDesc::vertex_emission`]) the two corners at each end have
//! the same albedo and emission. Every resulting class of triangle corners is
//! one *solver vertex* with an angle-weighted normal, an albedo and an
//! emission (its material's, or its corners' per-vertex values), a one-ring
//! and a position-welded id. Albedo textures ([`super::MeshDesc::textures`])
//! are kept per triangle corner for the renderer
//! ([`PreparedScene::textures`]). Triangles too large for `f32` (their edge cross
//! product overflows) are an error. Solver vertices are numbered in the
//! order of their first triangle corner; a mesh whose triangles come in
//! scrambled order is renumbered breadth-first ([`super::order`]).
//!
//! Solver vertices on a crease (their welded position has more than one
//! solver vertex) or on an open border are flagged `boundary`: their ray
//! origins are nudged into their own face group (docs/DESIGN.md §3).

use super::texture::{CornerTextures, NO_MAP};
use super::transfer::{Transfer, NO_TRANSFER};
use super::{Light, SceneDesc, Settings};
use crate::sky::Sky;
use crate::{Error, Result};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;

/// Which vertices and triangles of the prepared scene came from one mesh.
#[derive(Clone, Debug)]
pub struct MeshRange {
    /// The mesh's name ([`MeshDesc::name`](super::MeshDesc::name)).
    pub name: String,
    /// Its solver vertices.
    pub vertices: Range<u32>,
    /// Its triangles.
    pub triangles: Range<u32>,
    /// True if the mesh may deform.
    pub dynamic: bool,
    /// Deformers of the mesh (world space), applied to its vertices over time.
    pub deform: Vec<super::deformer::Deform>,
    /// Per input position of the mesh (`MeshDesc::positions` order): the
    /// solver vertex that carries its value, or [`NO_VERTEX`] where no kept
    /// triangle uses it (unused, or used by dropped triangles only). A
    /// position on a crease or material border has a solver vertex per
    /// side; this is the side of the first kept triangle that uses it.
    /// [`PreparedScene::on_input`] reads any per-vertex result this way.
    pub input_vertex: Vec<u32>,
    /// Per solver vertex of the mesh (`vertices` in order): the input
    /// position it was made from (one of them where welding joined
    /// several). [`PreparedScene::positions_from_input`] uses it.
    pub vertex_input: Vec<u32>,
    /// Per solver triangle of the mesh (`triangles` in order): the index of
    /// the input triangle (`MeshDesc::triangles`) it is. Preparation keeps
    /// the input's triangle order and drops only degenerate ones (of a
    /// simplified mesh, the index of its lighting triangle,
    /// [`super::simplify`]).
    pub triangle_input: Vec<u32>,
    /// Of a simplified mesh ([`super::simplify`]), per input position:
    /// where a position the lighting mesh dropped reads its value (a
    /// triangle of [`PreparedScene::triangles`] and its corners' weights,
    /// [`super::transfer`]); [`Transfer::NONE`] for the others. Empty for
    /// a mesh that was not simplified.
    pub input_transfer: Vec<Transfer>,
}

/// A per-vertex value [`PreparedScene::on_input`] can read at an input
/// position a lighting mesh dropped: a weighted sum of three.
pub trait Interpolate: Copy + std::ops::Add<Output = Self> {
    /// `self` times weight `w`.
    fn weighted(self, w: f32) -> Self;
}

impl Interpolate for f32 {
    fn weighted(self, w: f32) -> f32 {
        self * w
    }
}

impl Interpolate for Vec3 {
    fn weighted(self, w: f32) -> Vec3 {
        self * w
    }
}

/// [`MeshRange::input_vertex`] of an input position no kept triangle uses.
pub const NO_VERTEX: u32 = u32::MAX;

pub use super::rings::rings_of;
pub use crate::csr::Csr;

internal_fields! {
/// The scene ready for the solver: world-space solver vertices and triangles.
#[derive(Clone, Debug)]
    pub struct PreparedScene {
    /// Scene name.
    pub name: String,
    /// Solver settings.
    pub settings: Settings,
    /// The lights.
    pub lights: Vec<Light>,
    /// World positions of solver vertices, metres.
    pub positions: Vec<Vec3>,
    /// Unit normals of solver vertices (front side).
    pub normals: Vec<Vec3>,
    /// Albedo per solver vertex and channel, in [0, 1).
    pub albedo: Vec<Vec3>,
    /// Emitted radiant exitance per solver vertex and channel, W/m^2 (its
    /// material's; vertices are split at material borders).
    pub emission: Vec<Vec3>,
    /// Sky light, if any.
    pub sky: Option<crate::sky::Sky>,
    /// Triangles over solver vertices, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Welded position id per solver vertex (equal ids: same point in space, same mesh).
    pub position_id: Vec<u32>,
    /// Crease or border vertex (its ray origin is nudged).
    pub boundary: Vec<bool>,
    /// Buried vertices' ray origins, by vertex ascending: a point of their
    /// own faces out in the open ([`crate::links::buried`]); set by the
    /// solver when it builds (empty until then).
    pub moved_origins: Vec<(u32, Vec3)>,
    /// One-ring: neighbouring solver vertices, sorted.
    pub rings: Csr,
    /// Triangles incident to each solver vertex.
    pub vertex_triangles: Csr,
    /// Ray-frame colour per solver vertex: a colouring of the one-rings
    /// (neighbours differ; [`crate::sampling::colours`]) that picks each
    /// vertex's rotation and direction set
    /// ([`crate::sampling::vertex_rotations_and_sets`]). Set with the
    /// topology; refinement keeps the colours of the vertices it keeps
    /// ([`crate::solver::adaptive`]).
    pub colours: Vec<u32>,
    /// Which solver vertices and triangles came from each input mesh, in input order.
    pub meshes: Vec<MeshRange>,
    /// Zero-area triangles dropped during preparation.
    pub dropped_triangles: usize,
    /// Albedo textures per triangle corner, drawn per pixel by the renderer
    /// (`None`: no mesh has one; shared, so copies of the scene are cheap).
    pub textures: Option<Arc<CornerTextures>>,
}
}

impl PreparedScene {
    /// Scene name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The solver settings it was prepared with.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// The lights.
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// World positions of the lighting mesh's vertices, metres.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Unit normals of the lighting mesh's vertices (front side).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// Albedo per vertex and channel, in [0, 1).
    pub fn albedo(&self) -> &[Vec3] {
        &self.albedo
    }

    /// Emitted radiant exitance per vertex and channel, W/m^2.
    pub fn emission(&self) -> &[Vec3] {
        &self.emission
    }

    /// Triangles over the lighting mesh's vertices, counter-clockwise seen
    /// from the front.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Sky light, if any.
    pub fn sky(&self) -> Option<&Sky> {
        self.sky.as_ref()
    }

    /// Zero-area triangles dropped during preparation.
    pub fn dropped_triangles(&self) -> usize {
        self.dropped_triangles
    }
}

fn geom_err(name: &str, message: String) -> Error {
    Error::Geometry { source_name: name.to_string(), line: None, message }
}

struct UnionFind(Vec<u32>);

impl UnionFind {
    fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let p = self.0[x as usize];
            self.0[x as usize] = self.0[p as usize];
            x = p;
        }
        x
    }
    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            // Smaller root wins so classes are numbered deterministically.
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.0[hi as usize] = lo;
        }
    }
}

/// Result of preparing one mesh, in local indices.
struct MeshPrep {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    albedo: Vec<Vec3>,
    emission: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    position_id: Vec<u32>,
    welded_count: u32,
    dropped: usize,
    /// Albedo textures of the kept triangles (maps numbered within the mesh).
    textures: Option<CornerTextures>,
    /// Per input position: its solver vertex ([`MeshRange::input_vertex`], local).
    input_vertex: Vec<u32>,
    /// Per solver vertex: an input position it came from ([`MeshRange::vertex_input`]).
    vertex_input: Vec<u32>,
    /// Per kept triangle: its input triangle ([`MeshRange::triangle_input`]).
    triangle_input: Vec<u32>,
}

/// The rule by which preparation drops a triangle of cross product
/// `cross` (`(b - a) x (c - a)`) and longest squared side `longest`: no area
/// beside its size (a sliver or collinear corners). Refinement uses it too.
pub(crate) fn zero_area(cross: Vec3, longest: f32) -> bool {
    cross.length_squared() <= 1e-24 * longest * longest
}

/// Checks a mesh as preparation needs it (finite positions before and
/// after the transform, triangles and materials in range, emissions and
/// albedos finite, attribute lengths); the error names the mesh and the
/// problem. Returns the world positions. The one check of a loaded, built
/// ([`super::builder`]) or edited mesh.
pub fn check_mesh(mesh: &super::MeshDesc) -> Result<Vec<Vec3>> {
    let name = &mesh.name;
    let m = mesh.transform.matrix();
    let mut world = Vec::with_capacity(mesh.positions.len());
    for (i, p) in mesh.positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(geom_err(name, format!("vertex {i} has non-finite coordinates {p}")));
        }
        let w = m.transform_point3(*p);
        if !w.is_finite() {
            return Err(geom_err(name, format!("vertex {i} is not finite after the transform ({w})")));
        }
        world.push(w);
    }
    if mesh.triangle_material.len() != mesh.triangles.len() {
        return Err(geom_err(name, "triangle and material counts differ".into()));
    }
    for (ti, t) in mesh.triangles.iter().enumerate() {
        if let Some(&bad) = t.iter().find(|&&i| i as usize >= world.len()) {
            return Err(geom_err(
                name,
                format!("triangle {ti} uses vertex {bad}, but the mesh has {} vertices", world.len()),
            ));
        }
        let mat = mesh.triangle_material[ti];
        if mat as usize >= mesh.materials.len() {
            return Err(geom_err(name, format!("triangle {ti} uses material {mat}, which does not exist")));
        }
    }
    if let Some(m) = mesh.materials.iter().find(|m| !(m.emission.is_finite() && m.emission.min_element() >= 0.0)) {
        return Err(geom_err(
            name,
            format!("material '{}' has emission {}: it must be finite and non-negative", m.name, m.emission),
        ));
    }
    if let Some(va) = &mesh.vertex_albedo {
        if va.len() != mesh.positions.len() {
            return Err(geom_err(name, format!("{} vertex albedos for {} vertices", va.len(), mesh.positions.len())));
        }
        if let Some(i) = va.iter().position(|a| !a.is_finite()) {
            return Err(geom_err(name, format!("vertex {i} has non-finite albedo {}", va[i])));
        }
    }
    if let Some(ve) = &mesh.vertex_emission {
        if ve.len() != mesh.positions.len() {
            return Err(geom_err(name, format!("{} vertex emissions for {} vertices", ve.len(), mesh.positions.len())));
        }
        if let Some(i) = ve.iter().position(|e| !(e.is_finite() && e.min_element() >= 0.0)) {
            return Err(geom_err(
                name,
                format!("vertex {i} has emission {}: it must be finite and non-negative", ve[i]),
            ));
        }
    }
    if let Some(t) = &mesh.textures {
        t.validate(mesh.positions.len(), mesh.triangles.len()).map_err(|m| geom_err(name, m))?;
    }
    Ok(world)
}

fn prepare_mesh(mesh: &super::MeshDesc) -> Result<MeshPrep> {
    let world = check_mesh(mesh)?;
    let name = &mesh.name;
    // Weld by exact position.
    let mut weld: HashMap<[u32; 3], u32> = HashMap::with_capacity(world.len());
    let mut welded_pos: Vec<Vec3> = Vec::new();
    let remap: Vec<u32> = world
        .iter()
        .map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()].map(|b| if b == 0x8000_0000 { 0 } else { b });
            *weld.entry(key).or_insert_with(|| {
                welded_pos.push(*p);
                (welded_pos.len() - 1) as u32
            })
        })
        .collect();
    // Drop zero-area triangles; compute face normals and corner angles.
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    // The kept triangles' corners as given (before welding), for per-vertex albedo.
    let mut tris_given: Vec<[u32; 3]> = Vec::with_capacity(mesh.triangles.len());
    // The kept triangles' indices in the mesh, for textures.
    let mut tris_index: Vec<usize> = Vec::with_capacity(mesh.triangles.len());
    let mut tri_mat = Vec::with_capacity(mesh.triangles.len());
    let mut face_n = Vec::with_capacity(mesh.triangles.len());
    let mut dropped = 0;
    for (ti, (t, &mat)) in mesh.triangles.iter().zip(&mesh.triangle_material).enumerate() {
        let w = t.map(|i| remap[i as usize]);
        let [a, b, c] = w.map(|i| welded_pos[i as usize]);
        let cross = (b - a).cross(c - a);
        let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
        if !(cross.length_squared().is_finite() && (longest * longest).is_finite()) {
            return Err(geom_err(
                name,
                format!(
                    "triangle {ti} ({a}, {b}, {c}) is too large: its size overflows f32 arithmetic (metres expected)"
                ),
            ));
        }
        if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] || zero_area(cross, longest) {
            dropped += 1;
            continue;
        }
        tris.push(w);
        tris_given.push(*t);
        tris_index.push(ti);
        tri_mat.push(mat);
        face_n.push(cross.normalize());
    }
    // Edges: (lo, hi) welded ids -> list of (triangle, corner of lo, forward?)
    let mut edges: HashMap<(u32, u32), Vec<(u32, bool)>> = HashMap::with_capacity(tris.len() * 2);
    for (ti, t) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let key = if a < b { (a, b) } else { (b, a) };
            edges.entry(key).or_default().push((ti as u32, a < b));
        }
    }
    let cos_crease = (mesh.crease_angle_deg.to_radians()).cos() - 1e-6;
    let corner = |ti: u32, v: u32| -> u32 {
        let t = &tris[ti as usize];
        ti * 3 + t.iter().position(|&x| x == v).unwrap() as u32
    };
    // Albedo of the corner of triangle `ti` at welded vertex `v`.
    let corner_albedo = |ti: u32, v: u32| -> Vec3 {
        match &mesh.vertex_albedo {
            Some(va) => va[tris_given[ti as usize][(corner(ti, v) % 3) as usize] as usize],
            None => mesh.materials[tri_mat[ti as usize] as usize].albedo,
        }
    };
    // Emission of the corner of triangle `ti` at welded vertex `v`.
    let corner_emission = |ti: u32, v: u32| -> Vec3 {
        match &mesh.vertex_emission {
            Some(ve) => ve[tris_given[ti as usize][(corner(ti, v) % 3) as usize] as usize],
            None => mesh.materials[tri_mat[ti as usize] as usize].emission,
        }
    };
    let same_emission =
        |t1: u32, t2: u32, v: u32| mesh.vertex_emission.is_none() || corner_emission(t1, v) == corner_emission(t2, v);
    let mut uf = UnionFind((0..tris.len() as u32 * 3).collect());
    let mut keys: Vec<_> = edges.keys().copied().collect();
    keys.sort_unstable();
    for key in keys {
        let list = &edges[&key];
        for i in 0..list.len() {
            for j in i + 1..list.len() {
                let (t1, f1) = list[i];
                let (t2, f2) = list[j];
                let joined = f1 != f2
                    && tri_mat[t1 as usize] == tri_mat[t2 as usize]
                    && face_n[t1 as usize].dot(face_n[t2 as usize]) >= cos_crease
                    && corner_albedo(t1, key.0) == corner_albedo(t2, key.0)
                    && corner_albedo(t1, key.1) == corner_albedo(t2, key.1)
                    && same_emission(t1, t2, key.0)
                    && same_emission(t1, t2, key.1);
                if joined {
                    uf.union(corner(t1, key.0), corner(t2, key.0));
                    uf.union(corner(t1, key.1), corner(t2, key.1));
                }
            }
        }
    }
    // Classes -> solver vertices, numbered in order of first corner.
    let mut class_id: HashMap<u32, u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut albedo = Vec::new();
    let mut emission = Vec::new();
    let mut position_id = Vec::new();
    let mut vertex_input = Vec::new();
    let mut triangles = Vec::with_capacity(tris.len());
    for (ti, t) in tris.iter().enumerate() {
        let mut out = [0u32; 3];
        for k in 0..3 {
            let root = uf.find(ti as u32 * 3 + k as u32);
            let id = *class_id.entry(root).or_insert_with(|| {
                positions.push(welded_pos[t[k] as usize]);
                normals.push(Vec3::ZERO);
                albedo.push(corner_albedo(ti as u32, t[k]));
                emission.push(corner_emission(ti as u32, t[k]));
                position_id.push(t[k]);
                vertex_input.push(tris_given[ti][k]);
                (positions.len() - 1) as u32
            });
            // Angle-weighted normal.
            let p = welded_pos[t[k] as usize];
            let e1 = (welded_pos[t[(k + 1) % 3] as usize] - p).normalize_or_zero();
            let e2 = (welded_pos[t[(k + 2) % 3] as usize] - p).normalize_or_zero();
            let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
            normals[id as usize] += face_n[ti] * angle;
            out[k] = id;
        }
        triangles.push(out);
    }
    for (i, n) in normals.iter_mut().enumerate() {
        *n = n.try_normalize().unwrap_or_else(|| {
            // Corner angles all zero (needle triangles): take a face normal.
            face_n[triangles.iter().position(|t: &[u32; 3]| t.contains(&(i as u32))).unwrap_or(0)]
        });
    }
    let textures = mesh.textures.as_ref().map(|mt| CornerTextures {
        maps: mt.maps.clone(),
        triangle_map: tris_index.iter().map(|&ti| mt.triangle_map[ti]).collect(),
        uv: tris_given.iter().map(|t| t.map(|i| mt.uv[i as usize])).collect(),
        factor: tris_given.iter().map(|t| t.map(|i| mt.factor[i as usize])).collect(),
    });
    let mut input_vertex = vec![NO_VERTEX; mesh.positions.len()];
    for (given, solver) in tris_given.iter().zip(&triangles) {
        for k in 0..3 {
            let slot = &mut input_vertex[given[k] as usize];
            if *slot == NO_VERTEX {
                *slot = solver[k];
            }
        }
    }
    let mut mp = MeshPrep {
        positions,
        normals,
        albedo: albedo.iter().map(|a: &Vec3| a.clamp(Vec3::ZERO, Vec3::splat(super::MAX_ALBEDO))).collect(),
        emission,
        triangles,
        position_id,
        welded_count: welded_pos.len() as u32,
        dropped,
        textures,
        input_vertex,
        vertex_input,
        triangle_input: tris_index.iter().map(|&i| i as u32).collect(),
    };
    if let Some(order) = super::order::better_order(&mp.triangles, mp.positions.len()) {
        mp.renumber(&order);
    }
    Ok(mp)
}

impl MeshPrep {
    /// Renumbers the solver vertices: `order[new] = old` ([`super::order`]).
    fn renumber(&mut self, order: &[u32]) {
        let mut new_of_old = vec![0u32; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        fn permute<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
            *v = order.iter().map(|&o| v[o as usize]).collect();
        }
        permute(&mut self.positions, order);
        permute(&mut self.normals, order);
        permute(&mut self.albedo, order);
        permute(&mut self.emission, order);
        permute(&mut self.position_id, order);
        permute(&mut self.vertex_input, order);
        for t in &mut self.triangles {
            *t = t.map(|v| new_of_old[v as usize]);
        }
        for v in self.input_vertex.iter_mut().filter(|v| **v != NO_VERTEX) {
            *v = new_of_old[*v as usize];
        }
    }
}

/// The lighting mesh of a dense `mesh` ([`super::simplify`]) prepared, and
/// the transfer of every input position it dropped ([`super::transfer`],
/// triangles local to the mesh).
fn lighting_mesh(mesh: &super::MeshDesc, share: f32) -> Result<(MeshPrep, Vec<Transfer>)> {
    use super::{simplify, transfer};
    let world = check_mesh(mesh)?;
    let (lo, hi) = world.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), p| (l.min(*p), h.max(*p)));
    let extent = (hi - lo).max_element().max(0.0);
    let input_region = simplify::regions(mesh);
    let input = transfer::Input { positions: &world, triangles: &mesh.triangles, region: &input_region };
    let mut last = None;
    for (k, &bound) in simplify::ERROR_BOUNDS.iter().enumerate() {
        let s = simplify::simplify(mesh, &world, &input_region, share, bound);
        let mp = prepare_mesh(&s.mesh)?;
        let region: Vec<u32> = mp.triangle_input.iter().map(|&t| s.region[t as usize]).collect();
        let lighting = transfer::Lighting { positions: &mp.positions, triangles: &mp.triangles, region: &region };
        let t = transfer::transfers(&input, &lighting, |i| mp.input_vertex[i] == NO_VERTEX);
        let dropped = (0..world.len()).filter(|&i| mp.input_vertex[i] == NO_VERTEX).count();
        let lost = (0..world.len()).filter(|&i| mp.input_vertex[i] == NO_VERTEX && t[i].tri == NO_TRANSFER).count();
        let mut distances: Vec<f32> = t.iter().filter(|t| t.tri != NO_TRANSFER).map(|t| t.distance).collect();
        let farthest = distances.iter().copied().fold(0f32, f32::max);
        let p999 = if distances.is_empty() {
            0.0
        } else {
            let k = (distances.len() - 1) * 999 / 1000;
            *distances.select_nth_unstable_by(k, f32::total_cmp).1
        };
        let ok = lost as f64 <= simplify::MAX_LOST * dropped.max(1) as f64 && p999 <= simplify::MAX_DISTANCE * extent;
        log::info!(
            "{}: lighting mesh of {} triangles for the input's {} (simplifier's bound {bound} of the extent, \
             error {:.1} mm); {} input positions read it through a transfer, 99.9% within {:.1} mm of it (the \
             farthest {:.1} mm){}{}",
            mesh.name,
            mp.triangles.len(),
            mesh.triangles.len(),
            s.error * 1e3,
            dropped - lost,
            p999 * 1e3,
            farthest * 1e3,
            if lost > 0 { format!(", {lost} find no lighting triangle facing them and keep no value") } else { String::new() },
            match (ok, k + 1 < simplify::ERROR_BOUNDS.len()) {
                (true, _) => "",
                (false, true) => "; the surface moved too far: simplified again with a tighter bound",
                (false, false) => "; the surface moved too far even at the tightest bound: kept",
            }
        );
        last = Some((mp, t));
        if ok {
            break;
        }
    }
    Ok(last.expect("at least one error bound"))
}

/// Prepares a scene for solving. Errors name the mesh and the problem.
pub fn prepare(scene: &SceneDesc) -> Result<PreparedScene> {
    scene.settings.validate()?;
    let mut out = PreparedScene {
        name: scene.name.clone(),
        settings: scene.settings,
        lights: scene.lights.clone(),
        positions: vec![],
        normals: vec![],
        albedo: vec![],
        emission: vec![],
        sky: scene.sky.clone(),
        triangles: vec![],
        position_id: vec![],
        boundary: vec![],
        moved_origins: vec![],
        rings: Csr::default(),
        vertex_triangles: Csr::default(),
        colours: vec![],
        meshes: vec![],
        dropped_triangles: 0,
        textures: None,
    };
    let mut textures = CornerTextures::default();
    let mut pos_base = 0u32;
    let share = super::simplify::keep_share(scene);
    for mesh in &scene.meshes {
        let (mp, mut transfer) = match share.filter(|_| super::simplify::simplifiable(mesh)) {
            Some(share) => lighting_mesh(mesh, share)?,
            None => (prepare_mesh(mesh)?, Vec::new()),
        };
        let n = mp.triangles.len();
        match &mp.textures {
            Some(t) => {
                let base = textures.maps.len() as u32;
                textures.maps.extend(t.maps.iter().cloned());
                textures.triangle_map.extend(t.triangle_map.iter().map(|&m| if m == NO_MAP { m } else { m + base }));
                textures.uv.extend(&t.uv);
                textures.factor.extend(&t.factor);
            }
            None => {
                textures.triangle_map.extend(std::iter::repeat_n(NO_MAP, n));
                textures.uv.extend(std::iter::repeat_n([Vec2::ZERO; 3], n));
                textures.factor.extend(std::iter::repeat_n([Vec3::ZERO; 3], n));
            }
        }
        let vbase = out.positions.len() as u32;
        let tbase = out.triangles.len() as u32;
        transfer.iter_mut().filter(|t| t.tri != NO_TRANSFER).for_each(|t| t.tri += tbase);
        out.positions.extend(&mp.positions);
        out.normals.extend(&mp.normals);
        out.albedo.extend(&mp.albedo);
        out.emission.extend(&mp.emission);
        out.triangles.extend(mp.triangles.iter().map(|t| t.map(|i| i + vbase)));
        out.position_id.extend(mp.position_id.iter().map(|&i| i + pos_base));
        out.dropped_triangles += mp.dropped;
        out.meshes.push(MeshRange {
            name: mesh.name.clone(),
            vertices: vbase..out.positions.len() as u32,
            triangles: tbase..out.triangles.len() as u32,
            dynamic: mesh.dynamic,
            deform: mesh.deform.clone(),
            input_vertex: mp.input_vertex.iter().map(|&v| if v == NO_VERTEX { v } else { v + vbase }).collect(),
            vertex_input: mp.vertex_input.clone(),
            triangle_input: mp.triangle_input.clone(),
            input_transfer: transfer,
        });
        pos_base += mp.welded_count;
    }
    if out.triangles.is_empty() {
        return Err(Error::EmptyScene(scene.name.clone()));
    }
    if textures.triangle_map.iter().any(|&m| m != NO_MAP) {
        out.textures = Some(Arc::new(textures));
    }
    for l in &out.lights {
        let ok = match *l {
            Light::Point { position, intensity } => position.is_finite() && intensity.is_finite(),
            Light::Directional { direction, irradiance } => {
                direction.is_finite() && direction.length_squared() > 0.0 && irradiance.is_finite()
            }
        };
        if !ok {
            return Err(Error::Setting(format!("light {l:?} has non-finite or zero values")));
        }
    }
    if let Some(sky) = &out.sky {
        sky.validate().map_err(|m| Error::Setting(format!("{}: {m}", scene.name)))?;
    }
    out.build_topology();
    Ok(out)
}

impl PreparedScene {
    /// Every solver vertex's world position with mesh `mesh`'s taken from
    /// `world` (new world positions of its input positions, in the
    /// caller's order): a deformation given in input order, ready for
    /// `engine::Change::Deform`. `None` if there is no
    /// mesh `mesh` or `world` has another length than its input.
    pub fn positions_from_input(&self, mesh: usize, world: &[Vec3]) -> Option<Vec<Vec3>> {
        let m = self.meshes.get(mesh)?;
        if world.len() != m.input_vertex.len() {
            return None;
        }
        let mut out = self.positions.clone();
        for (v, &i) in (m.vertices.start as usize..m.vertices.end as usize).zip(&m.vertex_input) {
            out[v] = world[i as usize];
        }
        Some(out)
    }

    /// [`Self::on_input`] into the caller's buffer (one entry per input
    /// position of mesh `mesh`, reused from update to update): positions
    /// that take no value are left as they are. Returns how many entries
    /// were written, 0 if there is no mesh `mesh` or `out` has another length.
    pub fn on_input_into<T: Interpolate>(&self, mesh: usize, values: &[T], out: &mut [T]) -> usize {
        let Some(m) = self.meshes.get(mesh).filter(|m| m.input_vertex.len() == out.len()) else { return 0 };
        let mut written = 0;
        for (i, o) in out.iter_mut().enumerate() {
            if let Some(x) = self.input_value(m, i, values) {
                *o = x;
                written += 1;
            }
        }
        written
    }

    /// A per-vertex result (`values[v]` for solver vertex `v`, e.g.
    /// `Solution::e_indirect`) read on input mesh `mesh`'s own positions,
    /// in their order: a position's solver vertex
    /// (`MeshRange::input_vertex`), or for a position a simplified
    /// lighting mesh dropped, its transfer (`MeshRange::input_transfer`:
    /// the lighting triangle's corner values weighted); `None` where the
    /// position takes no value (no kept triangle uses it, or no lighting
    /// triangle faces it); empty if there is no mesh `mesh`.
    pub fn on_input<T: Interpolate>(&self, mesh: usize, values: &[T]) -> Vec<Option<T>> {
        self.meshes.get(mesh).map_or_else(Vec::new, |m| {
            (0..m.input_vertex.len()).map(|i| self.input_value(m, i, values)).collect()
        })
    }

    /// The value of input position `i` of mesh `m` (see [`Self::on_input`]).
    fn input_value<T: Interpolate>(&self, m: &MeshRange, i: usize, values: &[T]) -> Option<T> {
        let v = m.input_vertex[i];
        if v != NO_VERTEX {
            return values.get(v as usize).copied();
        }
        let t = m.input_transfer.get(i).filter(|t| t.tri != NO_TRANSFER)?;
        let c = self.triangles.get(t.tri as usize)?;
        let [a, b, d] = [values.get(c[0] as usize)?, values.get(c[1] as usize)?, values.get(c[2] as usize)?];
        Some(a.weighted(t.weights[0]) + b.weighted(t.weights[1]) + d.weighted(t.weights[2]))
    }

    /// Number of solver vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Rebuilds one-rings, vertex-triangle adjacency and boundary flags from
    /// `triangles` and `position_id`.
    pub fn build_topology(&mut self) {
        let n = self.positions.len();
        let mut vt = Vec::with_capacity(self.triangles.len() * 3);
        let mut edge_count: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.triangles.len() * 2);
        for (ti, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                vt.push((a, ti as u32));
                *edge_count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        self.rings = rings_of(&self.triangles, n);
        self.vertex_triangles = Csr::from_pairs(n, &vt);
        self.colours = crate::sampling::colours(&self.rings);
        // Crease: more than one solver vertex at a welded position.
        let mut copies: HashMap<u32, u32> = HashMap::new();
        for &p in &self.position_id {
            *copies.entry(p).or_insert(0) += 1;
        }
        let mut boundary: Vec<bool> = self.position_id.iter().map(|p| copies[p] > 1).collect();
        for (&(a, b), &c) in &edge_count {
            if c == 1 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
        self.boundary = boundary;
    }

    /// Mean length of the edges at vertex `v`, metres.
    pub fn mean_edge_length(&self, v: usize) -> f32 {
        let ring = self.rings.row(v);
        if ring.is_empty() {
            return 0.0;
        }
        let p = self.positions[v];
        ring.iter().map(|&u| (self.positions[u as usize] - p).length()).sum::<f32>() / ring.len() as f32
    }

    /// Axis-aligned bounds of all vertices.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions
            .iter()
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }
}
