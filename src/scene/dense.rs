//! Dense copies of a scene: midpoint subdivision, each triangle into four,
//! which changes nothing but the tessellation (every new position lies on
//! its edge; texture coordinates, texture factors and per-vertex albedo and
//! emission are the average of the edge's ends). What the simplification
//! ([`super::simplify`]) is measured and tested on: the scaling bench
//! (`linkgi bench --scale`) and `tests/dense.rs`.

use super::{MeshDesc, SceneDesc};
use std::collections::HashMap;

/// `mesh` with every triangle split into four at its edges' midpoints; an
/// edge's midpoint is shared by the triangles on both sides where they
/// share the edge's ends (its input positions).
pub fn subdivide(mesh: &MeshDesc) -> MeshDesc {
    let mut out = mesh.clone();
    out.triangles = Vec::with_capacity(mesh.triangles.len() * 4);
    out.triangle_material = Vec::with_capacity(mesh.triangles.len() * 4);
    let mut map = mesh.textures.as_ref().map(|_| Vec::with_capacity(mesh.triangles.len() * 4));
    let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 3 / 2);
    let mut midpoint = |out: &mut MeshDesc, a: u32, b: u32| -> u32 {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            let (i, j) = (a as usize, b as usize);
            out.positions.push((out.positions[i] + out.positions[j]) * 0.5);
            if let Some(t) = &mut out.textures {
                t.uv.push((t.uv[i] + t.uv[j]) * 0.5);
                t.factor.push((t.factor[i] + t.factor[j]) * 0.5);
            }
            if let Some(v) = &mut out.vertex_albedo {
                v.push((v[i] + v[j]) * 0.5);
            }
            if let Some(v) = &mut out.vertex_emission {
                v.push((v[i] + v[j]) * 0.5);
            }
            (out.positions.len() - 1) as u32
        })
    };
    for (t, &[a, b, c]) in mesh.triangles.iter().enumerate() {
        let (ab, bc, ca) = (midpoint(&mut out, a, b), midpoint(&mut out, b, c), midpoint(&mut out, c, a));
        for tri in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
            out.triangles.push(tri);
            out.triangle_material.push(mesh.triangle_material[t]);
            if let (Some(m), Some(tex)) = (&mut map, &mesh.textures) {
                m.push(tex.triangle_map[t]);
            }
        }
    }
    if let (Some(t), Some(m)) = (&mut out.textures, map) {
        t.triangle_map = m;
    }
    out
}

/// `scene` with every static mesh subdivided `levels` times (4^levels
/// times the triangles); deforming meshes are left as they are.
pub fn dense_copy(scene: &SceneDesc, levels: u32) -> SceneDesc {
    let mut out = scene.clone();
    for m in out.meshes.iter_mut().filter(|m| !m.dynamic && m.deform.is_empty()) {
        for _ in 0..levels {
            *m = subdivide(m);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Four times the triangles, the same area and the same positions
    /// first; every new position the midpoint of an edge; a closed mesh
    /// stays closed (each edge used twice).
    #[test]
    fn subdivision_keeps_the_surface() {
        let scene = crate::scene::builtin::builtin("cornell").unwrap();
        let m = &scene.meshes[0];
        let s = subdivide(m);
        assert_eq!(s.triangles.len(), 4 * m.triangles.len());
        assert_eq!(&s.positions[..m.positions.len()], &m.positions[..]);
        let area = |d: &MeshDesc| -> f64 {
            d.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| d.positions[i as usize]);
                    (b - a).cross(c - a).length() as f64 / 2.0
                })
                .sum()
        };
        assert!((area(&s) / area(m) - 1.0).abs() < 1e-5);
        if let Some(t) = &s.textures {
            t.validate(s.positions.len(), s.triangles.len()).unwrap();
        }
        let sphere = crate::scene::builtin::furnace(0.5, 2, Vec3::ZERO, 1.0);
        let d = subdivide(&sphere.meshes[0]);
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &d.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(uses.values().all(|&u| u == 2), "the closed sphere stays closed");
    }
}
