//! Hand-built glTF documents for tests: a JSON value and its binary buffer,
//! written as `.gltf` + `.bin` or as `.glb`. Used where the library's writer
//! (`scene::gltf_write`) cannot express the case (node hierarchies,
//! textures, malformed files).
#![allow(dead_code)]

use serde_json::{json, Value};
use std::path::{Path, PathBuf};

pub struct Doc {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Default for Doc {
    fn default() -> Self {
        Self::new()
    }
}

impl Doc {
    pub fn new() -> Self {
        let json = json!({
            "asset": {"version": "2.0"},
            "buffers": [{"byteLength": 0}],
            "bufferViews": [],
            "accessors": [],
            "meshes": [],
            "nodes": [],
            "materials": [],
            "scene": 0,
            "scenes": [{"nodes": []}],
        });
        Self { json, bin: Vec::new() }
    }

    fn push(&mut self, key: &str, v: Value) -> usize {
        let a = self.json[key].as_array_mut().unwrap();
        a.push(v);
        a.len() - 1
    }

    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let off = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.json["buffers"][0]["byteLength"] = json!(self.bin.len());
        self.push("bufferViews", json!({"buffer": 0, "byteOffset": off, "byteLength": bytes.len()}))
    }

    /// A float accessor of `ty` ("VEC2", "VEC3", ...); VEC3 gets min/max.
    pub fn floats(&mut self, ty: &str, data: &[f32]) -> usize {
        let n = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let view = self.view(bytemuck::cast_slice(data));
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len() / n, "type": ty});
        if n == 3 {
            let col = |k: usize| data.iter().skip(k).step_by(3).copied();
            let lo: Vec<f32> = (0..3).map(|k| col(k).fold(f32::MAX, f32::min)).collect();
            let hi: Vec<f32> = (0..3).map(|k| col(k).fold(f32::MIN, f32::max)).collect();
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.push("accessors", acc)
    }

    /// A u32 index accessor.
    pub fn indices(&mut self, data: &[u32]) -> usize {
        let view = self.view(bytemuck::cast_slice(data));
        self.push(
            "accessors",
            json!({"bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR"}),
        )
    }

    pub fn material(&mut self, m: Value) -> usize {
        self.push("materials", m)
    }

    /// A mesh of one primitive; returns the mesh index.
    pub fn mesh(&mut self, primitive: Value) -> usize {
        self.push("meshes", json!({"primitives": [primitive]}))
    }

    /// A node; `root` puts it in the scene's node list.
    pub fn node(&mut self, node: Value, root: bool) -> usize {
        let i = self.push("nodes", node);
        if root {
            self.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(i));
        }
        i
    }

    /// Byte offset in `bin` of accessor `a`'s first element.
    pub fn offset_of(&self, a: usize) -> usize {
        let view = self.json["accessors"][a]["bufferView"].as_u64().unwrap() as usize;
        self.json["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize
    }

    /// Writes `dir/name`: binary if it ends in `.glb`, else JSON with the
    /// buffer in `<stem>.bin`.
    pub fn write(&self, dir: &Path, name: &str) -> PathBuf {
        let path = dir.join(name);
        let mut json = self.json.clone();
        if name.ends_with(".glb") {
            let glb = gltf::binary::Glb {
                header: gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
                json: serde_json::to_vec(&json).unwrap().into(),
                bin: Some(self.bin.clone().into()),
            };
            std::fs::write(&path, glb.to_vec().unwrap()).unwrap();
        } else {
            let bin = path.with_extension("bin");
            json["buffers"][0]["uri"] = json!(bin.file_name().unwrap().to_str().unwrap());
            std::fs::write(&bin, &self.bin).unwrap();
            std::fs::write(&path, serde_json::to_string_pretty(&json).unwrap()).unwrap();
        }
        path
    }
}
