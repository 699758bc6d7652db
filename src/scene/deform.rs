//! A prepared scene posed by its deformers ([`super::deformer`]) at a time:
//! deformed positions and the normals recomputed from the triangles
//! (angle-weighted face normals over each solver vertex's incident
//! triangles, so creases stay split). Positions in metres, time in seconds.

pub use super::deformer::{deform_positions, Deform, DeformKind};
use crate::scene::prep::PreparedScene;
use glam::Vec3;

/// Angle-weighted vertex normals from the triangles incident to each
/// solver vertex (`scene.vertex_triangles`) at `positions`. A vertex whose
/// triangles have no area keeps its `fallback` normal.
pub fn vertex_normals(scene: &PreparedScene, positions: &[Vec3], fallback: &[Vec3]) -> Vec<Vec3> {
    (0..positions.len())
        .map(|v| {
            let mut n = Vec3::ZERO;
            for &ti in scene.vertex_triangles.row(v) {
                let t = scene.triangles[ti as usize];
                let k = t.iter().position(|&i| i as usize == v).unwrap_or(0);
                let (a, b, c) =
                    (positions[t[k] as usize], positions[t[(k + 1) % 3] as usize], positions[t[(k + 2) % 3] as usize]);
                let face = (b - a).cross(c - a);
                let (e1, e2) = ((b - a).normalize_or_zero(), (c - a).normalize_or_zero());
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                n += face.normalize_or_zero() * angle;
            }
            n.try_normalize().unwrap_or(fallback[v])
        })
        .collect()
}

/// Normals after the vertices moved from `old` to `new` positions: vertices
/// with a moved incident triangle get [`vertex_normals`] at `new`; the
/// others keep `normals` bit for bit (so their rays are unchanged, which
/// selective updates rely on).
pub fn moved_normals(scene: &PreparedScene, old: &[Vec3], new: &[Vec3], normals: &[Vec3]) -> Vec<Vec3> {
    let fresh = vertex_normals(scene, new, normals);
    (0..new.len())
        .map(|v| {
            let moved = scene
                .vertex_triangles
                .row(v)
                .iter()
                .any(|&t| scene.triangles[t as usize].iter().any(|&i| old[i as usize] != new[i as usize]));
            if moved {
                fresh[v]
            } else {
                normals[v]
            }
        })
        .collect()
}

/// Positions of the whole prepared scene at time `t`: every dynamic mesh
/// with deformers is deformed from `rest` (the positions as prepared);
/// other vertices keep their rest positions and normals (`moved_normals`).
/// Returns `(positions, normals)`.
pub fn deform_scene(scene: &PreparedScene, rest: &[Vec3], rest_normals: &[Vec3], t: f32) -> (Vec<Vec3>, Vec<Vec3>) {
    let mut positions = rest.to_vec();
    let mut any = false;
    for m in &scene.meshes {
        if !m.dynamic || m.deform.is_empty() {
            continue;
        }
        any = true;
        let r = m.vertices.start as usize..m.vertices.end as usize;
        let moved = deform_positions(&m.deform, &rest[r.clone()], t);
        positions[r].copy_from_slice(&moved);
    }
    if !any {
        return (positions, rest_normals.to_vec());
    }
    let normals = moved_normals(scene, rest, &positions, rest_normals);
    (positions, normals)
}

/// True when some mesh of the scene deforms over time.
pub fn has_deformers(scene: &PreparedScene) -> bool {
    scene.meshes.iter().any(|m| m.dynamic && !m.deform.is_empty())
}
