//! Buried vertices (issue 43): a corner of a visible face that lies inside
//! another part of the model (overlapping boxes of a modelled desk, a
//! board pushed into a wall, interpenetrating parts of a foreign mesh)
//! sends its rays into back faces at once, so it reads no light in any
//! term, and the face it belongs to interpolates black between such
//! corners although its inside is in plain view. Refinement cannot see it
//! (all the corners agree).
//!
//! Found: a vertex of a static mesh is *buried* when at least
//! [`BURIED_SHARE`] of [`PROBE_RAYS`] cosine-distributed rays about its
//! area-weighted face normal, from its ray origin, meet a back face within
//! [`REACH`] times its mean edge length (inside something small; a vertex
//! outside an open building that sees the walls' backs from afar is not).
//!
//! Handled: the vertex shoots all its rays (links, light and emitter
//! links, and so the sky and near hits) from the first point of its own
//! faces that is not buried: on each incident triangle in order, at
//! [`STEPS`] of the way from the vertex to the triangle's centroid, lifted
//! off it by [`crate::trace::RAY_OFFSET`] times its mean edge length; the
//! point whose probe meets the fewest back faces (the first on a tie),
//! if that is under half. So the vertex carries the light of the nearest
//! visible part of its faces, which the renderer interpolates. A vertex
//! with no such point keeps its origin (its faces are all inside).
//!
//! The probe reads only positions, triangles and the structure (no vertex
//! normals), so a refinement's kept vertices and a fresh preparation find
//! the same points. Deviations: dynamic meshes' vertices are not probed
//! and the probe looks through dynamic meshes (what moves could uncover a
//! vertex), so a deformation needs no new probe. Lengths in metres.

use crate::trace::ray::Ray;
use crate::sampling::stream::{cosine_direction, splitmix64};
use crate::scene::prep::PreparedScene;
use crate::trace::{CpuTracer, RAY_OFFSET};
use glam::Vec3;
use rayon::prelude::*;

/// Probe rays a vertex (and a candidate point).
pub const PROBE_RAYS: u64 = 16;
/// Least share of the probe rays that meet a back face within reach for
/// a vertex to be buried.
pub const BURIED_SHARE: f32 = 0.75;
/// How far a back face may be to count, in mean edge lengths of the vertex.
pub const REACH: f32 = 2.0;
/// Where on an incident triangle a new origin is tried: shares of the way
/// from the vertex to the triangle's centroid.
pub const STEPS: [f32; 3] = [0.25, 0.5, 0.9];

/// The share of `PROBE_RAYS` rays about `normal` from `origin` (skipping
/// the triangles of vertex `skip`) that meet a back face closer than `reach`.
/// Dynamic meshes (`moving[tri]`) are looked through: the probe reads the
/// static scene alone, so what may move neither buries a vertex nor hides
/// what does (a deformation needs no new probe).
fn back_share(tracer: &dyn CpuTracer, moving: &[bool], origin: Vec3, normal: Vec3, reach: f32, skip: u32) -> f32 {
    let mut back = 0u32;
    for i in 0..PROBE_RAYS {
        let Some(dir) = cosine_direction(splitmix64(0x6275_7269_6564 ^ i), normal) else { continue };
        let mut ray = Ray { origin, dir, tmin: 0.0, tmax: reach, skip };
        // Past at most a few dynamic surfaces, each left behind by a relative step.
        for _ in 0..8 {
            match tracer.intersect(&ray) {
                Some(h) if moving[h.tri as usize] => ray.tmin = h.t + (h.t.abs() * 1e-5).max(1e-7),
                Some(h) => {
                    back += u32::from(!h.front);
                    break;
                }
                None => break,
            }
        }
    }
    back as f32 / PROBE_RAYS as f32
}

/// The area-weighted normal of vertex `v`'s triangles (not the solver's
/// vertex normal, so the probe does not depend on it), or `None`.
fn face_normal(scene: &PreparedScene, v: usize) -> Option<Vec3> {
    let n: Vec3 = scene
        .vertex_triangles
        .row(v)
        .iter()
        .map(|&t| {
            let [a, b, c] = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
            (b - a).cross(c - a)
        })
        .sum();
    let n = n.normalize_or_zero();
    (n != Vec3::ZERO).then_some(n)
}

/// The buried vertices of `scene`'s static meshes that have a point of
/// their faces out in the open, with that point (module doc), in vertex
/// order: what [`crate::links::shoot::ray_origin`] returns for them.
pub fn find(scene: &PreparedScene, tracer: &dyn CpuTracer, nudge: f32) -> Vec<(u32, Vec3)> {
    let mut dynamic = vec![false; scene.vertex_count()];
    let mut moving = vec![false; scene.triangles.len()];
    for m in scene.meshes.iter().filter(|m| m.dynamic) {
        dynamic[m.vertices.start as usize..m.vertices.end as usize].iter_mut().for_each(|x| *x = true);
        moving[m.triangles.start as usize..m.triangles.end as usize].iter_mut().for_each(|x| *x = true);
    }
    (0..scene.vertex_count())
        .into_par_iter()
        .filter_map(|v| {
            if dynamic[v] {
                return None;
            }
            let normal = face_normal(scene, v)?;
            let l = scene.mean_edge_length(v);
            let reach = REACH * l;
            if !(reach > 0.0) {
                return None;
            }
            let origin = super::shoot::plain_origin(scene, v, nudge);
            if back_share(tracer, &moving, origin, normal, reach, v as u32) < BURIED_SHARE {
                return None;
            }
            let p = scene.positions[v];
            let mut best: Option<(f32, Vec3)> = None;
            for &t in scene.vertex_triangles.row(v) {
                let [a, b, c] = scene.triangles[t as usize].map(|i| scene.positions[i as usize]);
                let n = (b - a).cross(c - a).normalize_or_zero();
                if n == Vec3::ZERO {
                    continue;
                }
                let centroid = (a + b + c) / 3.0;
                for s in STEPS {
                    let q = p + (centroid - p) * s + n * (RAY_OFFSET * l);
                    let share = back_share(tracer, &moving, q, n, reach, v as u32);
                    if best.is_none_or(|(b, _)| share < b) {
                        best = Some((share, q));
                    }
                }
            }
            best.filter(|(share, q)| *share < 0.5 && q.is_finite()).map(|(_, q)| (v as u32, q))
        })
        .collect()
}
