//! The lighting mesh where the input is denser than the light needs:
//! dense meshes reduced by meshoptimizer's edge-collapse simplifier
//! ([`meshopt`], `simplify_with_locks`), the counterpart of refinement
//! ([`super::refine`]) under one setting,
//! [`RefineSettings`](super::refine::RefineSettings): refinement
//! splits meshes coarser than the light needs, simplification collapses
//! meshes denser than the scene's triangle budget.
//!
//! **Which meshes.** A scene whose input has more triangles than
//! [`RefineSettings::max_triangles`](super::refine::RefineSettings::max_triangles)
//! (with refinement `auto`) has every
//! static mesh of at least [`MIN_TRIANGLES`] triangles reduced to the same
//! share of its triangles, so the whole fits the budget ([`keep_share`]).
//! Deforming meshes are never simplified (their positions move per input
//! vertex).
//!
//! **What is kept.** Corners that differ in region (material and texture
//! map), texture coordinates, texture factor, per-vertex albedo or
//! emission are separate vertices: the boundary between them is a seam,
//! which meshoptimizer collapses only along itself and alike on both
//! sides, so material and texture boundaries stay where they were and
//! every lighting triangle lies in one region. Open borders (a window's
//! edge, a box's opening) likewise collapse only along themselves. A vertex
//! whose faces meet at more than the mesh's crease angle is locked, so
//! creases (a cube's edges, a room's corners) keep every vertex.
//! `Regularize` keeps the triangles' sizes even, which is what light
//! interpolated over them wants: with the borders locked as well, a 40x40
//! grid cut to 600 triangles kept 10x-uniform triangles inside its locked
//! rim; with free borders and `Regularize`, 2.5x (the largest triangle's
//! area over the mean). Curved detail and silhouettes keep their shape up
//! to the error bound, [`MAX_ERROR`].
//!
//! The result keeps the input's positions and numbering and replaces its
//! triangles; the positions no kept triangle uses take their light from
//! the lighting triangle beside them ([`super::transfer`]).

use super::texture::NO_MAP;
use super::{MeshDesc, SceneDesc};
use glam::Vec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};
use std::collections::HashMap;

/// Meshes with fewer triangles are never simplified (they cost little).
pub const MIN_TRIANGLES: usize = 1000;

/// The simplifier's error bounds tried in turn, as shares of each mesh's
/// extent (meshoptimizer's relative error; with `Regularize` it holds a
/// regularisation term beside the distance moved). The first whose
/// lighting mesh passes the transfer's check (`prep.rs`: at most
/// [`MAX_LOST`] of the dropped positions without a facing lighting
/// triangle, and 99.9% of them within [`MAX_DISTANCE`] of the extent of
/// the point they read) is kept, so the budget yields where the surface
/// would move. Sponza (docs/DENSE.md): cut from 4.25M to 300k triangles at
/// a bound of 5% it lost its arches and roof (2% of the dropped positions
/// found no lighting triangle facing them); from 1.06M its error was
/// 0.06% of the extent and the picture the coarse one's. A bound of 0.5%
/// first would cost the regular triangles: the Cornell box's dense copy
/// then kept 34,837 of its 92,928 triangles (budget 5,808).
pub const ERROR_BOUNDS: [f32; 3] = [0.05, 0.005, 0.0005];

/// The share of dropped input positions that may find no lighting
/// triangle facing them (a simplification that loses more is redone
/// with the next of [`ERROR_BOUNDS`]).
pub const MAX_LOST: f64 = 0.001;

/// How far 99.9% of the dropped input positions may lie from the point
/// they read, as a share of the mesh's extent.
pub const MAX_DISTANCE: f32 = 0.01;


/// Whether `mesh` may be simplified: static, and at least [`MIN_TRIANGLES`].
pub fn simplifiable(mesh: &MeshDesc) -> bool {
    !mesh.dynamic && mesh.deform.is_empty() && mesh.triangles.len() >= MIN_TRIANGLES
}

/// The share of its triangles each simplifiable mesh of `scene` keeps so
/// the whole fits
/// [`RefineSettings::max_triangles`](super::refine::RefineSettings::max_triangles);
/// `None` where nothing
/// is simplified (refinement off, the scene within the budget, or no mesh
/// that may be simplified). At least 1% of them.
pub fn keep_share(scene: &SceneDesc) -> Option<f32> {
    let r = &scene.settings.refine;
    if !r.auto() {
        return None;
    }
    let total: usize = scene.meshes.iter().map(|m| m.triangles.len()).sum();
    if total <= r.max_triangles as usize {
        return None;
    }
    let dense: usize = scene.meshes.iter().filter(|m| simplifiable(m)).map(|m| m.triangles.len()).sum();
    if dense == 0 {
        return None;
    }
    let room = (r.max_triangles as usize).saturating_sub(total - dense).max(dense / 100);
    Some((room as f32 / dense as f32).min(1.0))
}

/// What simplifying one mesh gave.
#[derive(Clone, Debug)]
pub struct Simplified {
    /// The mesh with its lighting triangles (positions, materials and
    /// attributes as given; `triangle_material` and the texture maps per
    /// new triangle).
    pub mesh: MeshDesc,
    /// Per triangle of `mesh`: the region it belongs to (one material and
    /// texture map), as [`regions`] numbers them for the input.
    pub region: Vec<u32>,
    /// The surface error of the collapses, metres (meshoptimizer's, with
    /// its regularisation term: an upper bound of the distance moved).
    pub error: f32,
}

/// Per triangle of `mesh`: its region (material and texture map), numbered
/// in order of first appearance; the transfer matches dropped positions to
/// lighting triangles of their own region.
pub fn regions(mesh: &MeshDesc) -> Vec<u32> {
    let mut ids: HashMap<(u32, u32), u32> = HashMap::new();
    (0..mesh.triangles.len())
        .map(|t| {
            let next = ids.len() as u32;
            *ids.entry(region_key(mesh, t)).or_insert(next)
        })
        .collect()
}

fn region_key(mesh: &MeshDesc, t: usize) -> (u32, u32) {
    let map = mesh.textures.as_ref().map_or(NO_MAP, |x| x.triangle_map[t]);
    (mesh.triangle_material[t], map)
}

/// `mesh` (world positions `world`, as [`super::prep::check_mesh`] gives
/// them) reduced to about `share` of its triangles, no collapse moving the
/// surface more than `max_error` of the mesh's extent (module doc);
/// `region` is [`regions`] of `mesh`.
pub fn simplify(mesh: &MeshDesc, world: &[Vec3], region: &[u32], share: f32, max_error: f32) -> Simplified {
    let regions_n = region.iter().copied().max().map_or(0, |m| m as usize + 1);
    let mut key_of_region = vec![(0, 0); regions_n];
    for (t, &r) in region.iter().enumerate() {
        key_of_region[r as usize] = region_key(mesh, t);
    }
    // A vertex per position, attributes and region: corners that differ in
    // any are a seam, which the simplifier keeps on both sides alike.
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut ids: HashMap<[u32; 15], u32> = HashMap::with_capacity(world.len());
    let mut given: Vec<u32> = Vec::new();
    let mut vertex_region: Vec<u32> = Vec::new();
    let mut first_n: Vec<Vec3> = Vec::new();
    let mut lock: Vec<bool> = Vec::new();
    let mut indices: Vec<u32> = Vec::with_capacity(mesh.triangles.len() * 3);
    let cos_crease = mesh.crease_angle_deg.to_radians().cos();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| world[i as usize]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        if n == Vec3::ZERO || a == b || b == c || a == c {
            continue; // preparation drops it anyway
        }
        for &i in tri {
            let i = i as usize;
            let mut k = [0u32; 15];
            k[..3].copy_from_slice(&bits(world[i]));
            if let Some(x) = &mesh.textures {
                k[3..5].copy_from_slice(&x.uv[i].to_array().map(f32::to_bits));
                k[5..8].copy_from_slice(&bits(x.factor[i]));
            }
            if let Some(x) = &mesh.vertex_albedo {
                k[8..11].copy_from_slice(&bits(x[i]));
            }
            if let Some(x) = &mesh.vertex_emission {
                k[11..14].copy_from_slice(&bits(x[i]));
            }
            k[14] = region[t];
            let v = *ids.entry(k).or_insert_with(|| {
                given.push(i as u32);
                vertex_region.push(region[t]);
                first_n.push(n);
                lock.push(false);
                (given.len() - 1) as u32
            });
            // A crease through the vertex: its faces differ by more than the crease angle.
            if first_n[v as usize].dot(n) < cos_crease {
                lock[v as usize] = true;
            }
            indices.push(v);
        }
    }
    let target = ((indices.len() / 3) as f32 * share).ceil() as usize * 3;
    let mut error = 0f32;
    let kept = if target < indices.len() {
        let positions: Vec<[f32; 3]> = given.iter().map(|&i| world[i as usize].to_array()).collect();
        let adapter = VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0)
            .expect("12-byte positions divide their own buffer");
        let mut e = 0f32;
        let s = meshopt::simplify_with_locks(
            &indices,
            &adapter,
            &lock,
            target,
            max_error,
            SimplifyOptions::Regularize,
            Some(&mut e),
        );
        error = e * meshopt::simplify_scale(&adapter);
        s
    } else {
        indices
    };
    let mut out = mesh.clone();
    out.triangles = Vec::with_capacity(kept.len() / 3);
    out.triangle_material = Vec::with_capacity(kept.len() / 3);
    let (mut out_region, mut out_map) = (Vec::new(), Vec::new());
    for t in kept.chunks_exact(3) {
        let r = vertex_region[t[0] as usize];
        let (material, map) = key_of_region[r as usize];
        out.triangles.push([given[t[0] as usize], given[t[1] as usize], given[t[2] as usize]]);
        out.triangle_material.push(material);
        out_region.push(r);
        out_map.push(map);
    }
    if let Some(t) = &mut out.textures {
        t.triangle_map = out_map;
    }
    Simplified { mesh: out, region: out_region, error }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::refine::RefineMode;
    use crate::scene::shapes::MeshBuilder;

    fn world(m: &MeshDesc) -> Vec<Vec3> {
        crate::scene::prep::check_mesh(m).unwrap()
    }

    /// Undirected edges (by their ends' positions) used by exactly one triangle.
    fn border_edges(tris: &[[u32; 3]], w: &[Vec3]) -> Vec<([u32; 3], [u32; 3])> {
        let mut count: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
        let key = |i: u32| w[i as usize].to_array().map(f32::to_bits);
        for t in tris {
            for k in 0..3 {
                let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let mut e: Vec<_> = count.into_iter().filter(|&(_, c)| c == 1).map(|(e, _)| e).collect();
        e.sort_unstable();
        e
    }

    /// A finely tessellated cube: its faces collapse, its twelve edges
    /// keep every vertex (creases locked), and the surface stays on the
    /// cube (every kept vertex was an input vertex; the triangles cover
    /// each face's area).
    #[test]
    fn a_dense_cube_keeps_its_edges() {
        let mut b = MeshBuilder::new();
        let m = b.add_material("white", Vec3::splat(0.5));
        b.cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), 24, m, false);
        let mesh = b.finish("cube", 30.0);
        let w = world(&mesh);
        let s = simplify(&mesh, &w, &regions(&mesh), 0.05, ERROR_BOUNDS[0]);
        assert!(s.mesh.triangles.len() < mesh.triangles.len() / 4, "{} of {}", s.mesh.triangles.len(), mesh.triangles.len());
        let used: std::collections::HashSet<u32> = s.mesh.triangles.iter().flatten().copied().collect();
        let on_edge = |p: Vec3| p.abs().to_array().iter().filter(|c| (**c - 1.0).abs() < 1e-6).count() >= 2;
        // Every position on a cube edge (in any of its copies) is still used.
        let edge_positions: std::collections::HashSet<[u32; 3]> =
            w.iter().filter(|p| on_edge(**p)).map(|p| p.to_array().map(f32::to_bits)).collect();
        let kept: std::collections::HashSet<[u32; 3]> =
            used.iter().map(|&i| w[i as usize].to_array().map(f32::to_bits)).collect();
        assert!(edge_positions.iter().all(|p| kept.contains(p)), "a crease vertex was collapsed");
        let area = |tris: &[[u32; 3]]| -> f32 {
            tris.iter().map(|t| (w[t[1] as usize] - w[t[0] as usize]).cross(w[t[2] as usize] - w[t[0] as usize]).length() / 2.0).sum()
        };
        assert!((area(&s.mesh.triangles) - 24.0).abs() < 1e-3, "area {}", area(&s.mesh.triangles));
    }

    /// A box open on one side: the opening's rim (the mesh's border)
    /// collapses only along itself: every border edge after lies on the
    /// rim, the rim keeps its length and its four corners.
    #[test]
    fn an_open_box_keeps_its_border() {
        let mut b = MeshBuilder::new();
        let m = b.add_material("white", Vec3::splat(0.5));
        let wall = Some(m);
        b.cuboid_holed(Vec3::splat(-1.0), Vec3::splat(1.0), [20, 20, 20], [wall, wall, wall, wall, wall, None], true, None);
        let mesh = b.finish("open box", 30.0);
        let w = world(&mesh);
        let s = simplify(&mesh, &w, &regions(&mesh), 0.05, ERROR_BOUNDS[0]);
        assert!(s.mesh.triangles.len() < mesh.triangles.len() / 4);
        let point = |p: [u32; 3]| Vec3::from_array(p.map(f32::from_bits));
        let length = |e: &[([u32; 3], [u32; 3])]| e.iter().map(|&(a, b)| (point(a) - point(b)).length()).sum::<f32>();
        let before = border_edges(&mesh.triangles, &w);
        let after = border_edges(&s.mesh.triangles, &w);
        assert!(!before.is_empty() && after.len() < before.len(), "{} -> {}", before.len(), after.len());
        // The rim is the square at z = 1 (|x| = 1 or |y| = 1): both ends of an
        // edge on it, and on the same side of the square.
        for &(a, b) in &after {
            let (p, q) = (point(a), point(b));
            assert!(p.z == 1.0 && q.z == 1.0, "border edge {p} - {q} left the rim");
            let same_side = (p.x.abs() == 1.0 && p.x == q.x) || (p.y.abs() == 1.0 && p.y == q.y);
            assert!(same_side, "border edge {p} - {q} cuts across the opening");
        }
        assert!((length(&after) - length(&before)).abs() < 1e-4);
        for c in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            let corner = Vec3::new(c.0, c.1, 1.0).to_array().map(f32::to_bits);
            assert!(after.iter().any(|&(a, b)| a == corner || b == corner), "corner {c:?} lost");
        }
    }

    /// Two materials on one grid: the boundary between them stays on its
    /// line (every vertex both materials use lies on it), each lighting
    /// triangle lies in one material, and each material keeps its area.
    #[test]
    fn material_boundaries_stay() {
        let mut b = MeshBuilder::new();
        let red = b.add_material("red", Vec3::new(0.8, 0.1, 0.1));
        let grey = b.add_material("grey", Vec3::splat(0.5));
        b.quad_grid(Vec3::ZERO, Vec3::X, Vec3::Z, 40, 40, grey);
        b.quad_grid(Vec3::new(1.0, 0.0, 0.0), Vec3::X, Vec3::Z, 40, 40, red);
        let mesh = b.finish("floor", 30.0);
        let w = world(&mesh);
        let s = simplify(&mesh, &w, &regions(&mesh), 0.05, ERROR_BOUNDS[0]);
        assert!(s.mesh.triangles.len() < mesh.triangles.len() / 4);
        let mut area = [0f32; 2];
        let mut of: HashMap<[u32; 3], u32> = HashMap::new();
        for (t, &mat) in s.mesh.triangles.iter().zip(&s.mesh.triangle_material) {
            let [a, b2, c] = t.map(|i| w[i as usize]);
            assert_eq!(mat, if (a + b2 + c).x / 3.0 > 1.0 { red } else { grey });
            area[mat as usize] += (b2 - a).cross(c - a).length() / 2.0;
            for p in [a, b2, c] {
                *of.entry(p.to_array().map(f32::to_bits)).or_default() |= 1 << mat;
            }
        }
        for (p, m) in of {
            if m == 3 {
                assert_eq!(f32::from_bits(p[0]), 1.0, "a vertex of both materials off the boundary");
            }
        }
        assert!((area[0] - 1.0).abs() < 1e-4 && (area[1] - 1.0).abs() < 1e-4, "{area:?}");
    }

    #[test]
    fn the_budget_sets_the_share() {
        let mut scene = crate::scene::builtin::builtin("cornell").unwrap();
        assert_eq!(keep_share(&scene), None, "a built-in is within the default budget");
        let total: usize = scene.meshes.iter().map(|m| m.triangles.len()).sum();
        scene.settings.refine.max_triangles = 1000;
        let dense: usize = scene.meshes.iter().filter(|m| simplifiable(m)).map(|m| m.triangles.len()).sum();
        let share = keep_share(&scene).expect("over the budget");
        let kept = (total - dense) as f32 + share * dense as f32;
        assert!((kept - 1000f32.max(total as f32 - dense as f32 + dense as f32 / 100.0)).abs() < 2.0, "{kept}");
        scene.settings.refine.mode = RefineMode::Off;
        assert_eq!(keep_share(&scene), None);
    }
}
