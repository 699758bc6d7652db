//! Writes a [`SceneDesc`] as glTF 2.0: `name.gltf` with its buffer in
//! `name.bin` beside it, or a single binary `name.glb` (by the extension of
//! the path given). [`super::gltf`] reads it back to the same triangles,
//! albedo, lights and camera direction.
//!
//! - Each mesh becomes one node (translation, rotation and uniform scale of
//!   its [`super::Transform`]) holding one glTF mesh. Its object-space
//!   positions are one POSITION accessor shared by the primitives; there is
//!   one primitive per run of consecutive triangles with the same material,
//!   so triangle order is kept. Materials become glTF materials with
//!   `baseColorFactor` = albedo (metallic 0, roughness 1). A mesh with
//!   per-vertex albedo writes it as `COLOR_0` (float RGB) with factor 1.
//! - Lights become `KHR_lights_punctual` lights on their own nodes: the
//!   colour is the W/sr (or W/m^2) triple divided by its largest channel, the
//!   intensity that channel times [`LUMENS_PER_WATT`] in cd (or lux), the
//!   inverse of the import's conversion. A directional light's node turns -z
//!   onto its direction.
//! - The camera becomes a perspective camera (`yfov` = `fov_deg`) on a node
//!   at its position looking at its target with y up.
//!
//! Not representable in glTF, so not written: solver settings, crease
//! angles, `dynamic` and deformers (reloading gives the defaults).

use super::gltf::LUMENS_PER_WATT;
use super::{Light, SceneDesc};
use crate::{Error, Result};
use glam::{Mat3, Quat, Vec3};
use serde_json::{json, Value};
use std::path::Path;

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// The binary buffer and the views and accessors into it.
#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// Appends `bytes` as a new buffer view (4-byte aligned); returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len(), "target": target}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn vec3(&mut self, v: &[Vec3], with_bounds: bool) -> usize {
        let flat: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
        let view = self.view(bytemuck::cast_slice(&flat), ARRAY_BUFFER);
        let mut acc = json!({"bufferView": view, "componentType": FLOAT, "count": v.len(), "type": "VEC3"});
        if with_bounds {
            let lo = v.iter().fold(Vec3::splat(f32::MAX), |a, p| a.min(*p));
            let hi = v.iter().fold(Vec3::splat(f32::MIN), |a, p| a.max(*p));
            acc["min"] = json!(lo.to_array());
            acc["max"] = json!(hi.to_array());
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn indices(&mut self, tris: &[[u32; 3]]) -> usize {
        let flat: Vec<u32> = tris.iter().flatten().copied().collect();
        let view = self.view(bytemuck::cast_slice(&flat), ELEMENT_ARRAY_BUFFER);
        self.accessors
            .push(json!({"bufferView": view, "componentType": UNSIGNED_INT, "count": flat.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }
}

/// Splits a radiometric RGB triple into a glTF colour (largest channel 1) and
/// a photometric intensity.
fn photometric(rgb: Vec3) -> (Vec3, f32) {
    let m = rgb.max_element();
    if m > 0.0 {
        (rgb / m, m * LUMENS_PER_WATT)
    } else {
        (Vec3::ONE, 0.0)
    }
}

/// The rotation whose -z axis is `forward` (unit) and whose y axis is as close to up as it can be.
fn facing(forward: Vec3) -> Quat {
    let right = forward.cross(Vec3::Y);
    if right.length_squared() < 1e-12 {
        return Quat::from_rotation_arc(Vec3::NEG_Z, forward);
    }
    let right = right.normalize();
    Quat::from_mat3(&Mat3::from_cols(right, right.cross(forward), -forward)).normalize()
}

/// Builds the glTF JSON document and binary buffer of `scene`.
fn build(scene: &SceneDesc) -> (Value, Vec<u8>) {
    let mut b = Builder::default();
    let mut materials = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    for mesh in scene.meshes.iter().filter(|m| !m.positions.is_empty() && !m.triangles.is_empty()) {
        let positions = b.vec3(&mesh.positions, true);
        let colours = mesh.vertex_albedo.as_ref().map(|va| b.vec3(va, false));
        let first_material = materials.len();
        for m in &mesh.materials {
            let factor = if colours.is_some() { Vec3::ONE } else { m.albedo };
            let mut material = json!({
                "name": m.name,
                "pbrMetallicRoughness": {"baseColorFactor": [factor.x, factor.y, factor.z, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            });
            if m.emission != Vec3::ZERO {
                // Emitted radiance M / pi as factor (at most 1) times strength.
                let radiance = super::emission::radiance(m.emission);
                let strength = radiance.max_element().max(1.0);
                let f = radiance / strength;
                material["emissiveFactor"] = json!([f.x, f.y, f.z]);
                if strength > 1.0 {
                    material["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": strength}});
                }
            }
            materials.push(material);
        }
        let mut primitives = Vec::new();
        let mut start = 0;
        while start < mesh.triangles.len() {
            let mat = mesh.triangle_material[start];
            let end = (start..mesh.triangles.len())
                .find(|&i| mesh.triangle_material[i] != mat)
                .unwrap_or(mesh.triangles.len());
            let mut attributes = json!({"POSITION": positions});
            if let Some(c) = colours {
                attributes["COLOR_0"] = json!(c);
            }
            primitives.push(json!({
                "attributes": attributes,
                "indices": b.indices(&mesh.triangles[start..end]),
                "material": first_material + mat as usize,
            }));
            start = end;
        }
        meshes.push(json!({"name": mesh.name, "primitives": primitives}));
        let t = &mesh.transform;
        nodes.push(json!({
            "name": mesh.name,
            "mesh": meshes.len() - 1,
            "translation": t.translate.to_array(),
            "rotation": t.rotation().to_array(),
            "scale": [t.scale, t.scale, t.scale],
        }));
    }
    let mut lights = Vec::new();
    for light in &scene.lights {
        let (node, value) = match *light {
            Light::Point { position, intensity } => {
                let (color, cd) = photometric(intensity);
                (
                    json!({"translation": position.to_array()}),
                    json!({"type": "point", "color": color.to_array(), "intensity": cd}),
                )
            }
            Light::Directional { direction, irradiance } => {
                let (color, lux) = photometric(irradiance);
                (
                    json!({"rotation": facing(direction.normalize()).to_array()}),
                    json!({"type": "directional", "color": color.to_array(), "intensity": lux}),
                )
            }
        };
        lights.push(value);
        let mut node = node;
        node["extensions"] = json!({"KHR_lights_punctual": {"light": lights.len() - 1}});
        nodes.push(node);
    }
    let mut cameras = Vec::new();
    if let Some(cam) = scene.camera.filter(|c| (c.target - c.position).normalize_or_zero() != Vec3::ZERO) {
        let forward = (cam.target - cam.position).normalize();
        cameras.push(json!({"type": "perspective", "perspective": {"yfov": cam.fov_deg.to_radians(), "znear": 0.01}}));
        nodes.push(json!({"name": "camera", "camera": 0, "translation": cam.position.to_array(), "rotation": facing(forward).to_array()}));
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "linkgi"},
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "buffers": [{"byteLength": b.bin.len()}],
        "bufferViews": b.views,
        "accessors": b.accessors,
    });
    if !cameras.is_empty() {
        doc["cameras"] = json!(cameras);
    }
    let mut used = Vec::new();
    if !lights.is_empty() {
        used.push("KHR_lights_punctual");
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": lights}});
    }
    if materials.iter().any(|m| m.get("extensions").is_some()) {
        used.push("KHR_materials_emissive_strength");
    }
    if !used.is_empty() {
        doc["extensionsUsed"] = json!(used);
    }
    (doc, b.bin)
}

/// Writes `scene` to `path`: binary glTF if it ends in `.glb`, else a
/// `.gltf` JSON file and its buffer `<stem>.bin` beside it.
pub fn write_gltf(scene: &SceneDesc, path: &Path) -> Result<()> {
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| Error::Io { path: p, source }
    };
    let (mut doc, bin) = build(scene);
    let binary = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    if binary {
        let json = serde_json::to_vec(&doc).expect("glTF JSON serializes");
        let glb = ::gltf::binary::Glb {
            header: ::gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
            json: json.into(),
            bin: Some(bin.into()),
        };
        let bytes = glb.to_vec().map_err(|e| Error::Gltf { path: path.to_path_buf(), message: e.to_string() })?;
        return std::fs::write(path, bytes).map_err(io(path));
    }
    let bin_path = path.with_extension("bin");
    let bin_name = bin_path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    doc["buffers"][0]["uri"] = json!(urlencoding::encode(&bin_name));
    std::fs::write(&bin_path, bin).map_err(io(&bin_path))?;
    std::fs::write(path, serde_json::to_string_pretty(&doc).expect("glTF JSON serializes")).map_err(io(path))
}
