//! Scenes made for the benchmark alone, named like built-in scenes
//! (`linkgi bench glowsphere`) but not listed among them.
//!
//! - `glowsphere`: the Cornell box (`cornell`, its point light kept) with
//!   a glowing geodesic sphere of radius 0.22 m (2562 vertices, 5120
//!   triangles, every vertex emitting (6, 5, 4) W/m^2) floating between
//!   the boxes and the light, clear of both: one solve traces the light
//!   links' and the emitter links' shadow rays side by side (issue 32:
//!   a mesh whose every vertex emits).

use crate::scene::{builtin, shapes::MeshBuilder, SceneDesc};
use glam::Vec3;

/// The benchmark scene of this name, if there is one.
pub fn scene(name: &str) -> Option<SceneDesc> {
    match name {
        "glowsphere" => Some(glowsphere()),
        _ => None,
    }
}

fn glowsphere() -> SceneDesc {
    let mut desc = builtin::builtin("cornell").expect("a built-in scene");
    let mut b = MeshBuilder::new();
    let m = b.add_material("glow", Vec3::splat(0.5));
    b.materials[m as usize].emission = Vec3::new(6.0, 5.0, 4.0);
    b.icosphere(Vec3::new(0.1, 1.3, 0.45), 0.22, 4, m, false);
    desc.meshes.push(b.finish("glowsphere/sphere", 30.0));
    desc.name = "glowsphere".into();
    desc
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::prep;

    /// Every vertex of the sphere emits, it stays inside the room, and it
    /// meets neither box nor the light.
    #[test]
    fn glowsphere_emits_everywhere_and_floats_free() {
        let desc = scene("glowsphere").unwrap();
        assert!(scene("cornell").is_none());
        let s = prep::prepare(&desc).unwrap();
        let sphere = s.meshes.iter().find(|m| m.name == "glowsphere/sphere").unwrap();
        assert_eq!(sphere.vertices.len(), 2562);
        assert!(sphere.vertices.clone().all(|v| s.emission[v as usize] == Vec3::new(6.0, 5.0, 4.0)));
        assert!(s.emission.iter().filter(|e| **e != Vec3::ZERO).count() == 2562);
        let c = Vec3::new(0.1, 1.3, 0.45);
        let boxes = s.meshes.iter().find(|m| m.name == "cornell/boxes").unwrap();
        let nearest = boxes.vertices.clone().map(|v| (s.positions[v as usize] - c).length()).fold(f32::MAX, f32::min);
        // Box faces are 0.1 m grids: a vertex 0.1 m off would leave room for a face inside the sphere.
        assert!(nearest > 0.22 + 0.1, "a box vertex {nearest} m from the centre");
        for l in &s.lights {
            if let crate::scene::Light::Point { position, .. } = l {
                assert!((*position - c).length() > 0.3);
            }
        }
    }
}
