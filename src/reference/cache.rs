//! Disk cache of reference results: one file `<key>.ref` per scene and
//! parameter set, where the key is a 64-bit FNV-1a hash of the geometry
//! (positions, normals, triangles), albedo, emission, sky (its description
//! and coefficients), lights and reference parameters and a format version.
//! The file holds a magic tag, the vertex count and `E_d`, `E_sky`, `E_i`
//! and the standard errors of `E_i` and of `E_sky + E_i` per vertex as
//! little-endian `f32` (W/m^2). A file that does not match (size, magic, count) is ignored.
//! Reference images (`linkgi error --image`) are kept beside them as
//! `<key>.img` ([`image_key`]: the scene's key with the camera, size and
//! paths a pixel): width, height and the linear pixels as `f32`.

use super::{Reference, ReferenceParams};
use crate::scene::prep::PreparedScene;
use crate::scene::Light;
use crate::sky::SkyModel;
use glam::Vec3;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"LGIREF02";
/// Bump when the estimator changes, so old cached results are not reused.
const VERSION: u64 = 5;
/// Per-vertex Vec3 parts stored: E_d, E_sky, E_i, stderr of E_i, stderr of E_sky + E_i.
const PARTS: usize = 5;

/// 64-bit FNV-1a.
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u64(&mut self, x: u64) {
        self.bytes(&x.to_le_bytes());
    }
    fn f32s(&mut self, xs: &[f32]) {
        self.u64(xs.len() as u64);
        self.bytes(bytemuck::cast_slice(xs));
    }
}

/// The default cache folder: `$CARGO_TARGET_DIR/reference-cache`, or `target/reference-cache`.
pub fn default_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target"))
        .join("reference-cache")
}

/// Hash of everything the reference result depends on.
pub fn key(scene: &PreparedScene, params: &ReferenceParams) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.u64(VERSION);
    let v3 = |v: &[Vec3]| -> Vec<f32> { v.iter().flat_map(|p| p.to_array()).collect() };
    h.f32s(&v3(&scene.positions));
    h.f32s(&v3(&scene.normals));
    h.f32s(&v3(&scene.albedo));
    h.f32s(&v3(&scene.emission));
    if let Some(sky) = &scene.sky {
        h.bytes(sky.describe().as_bytes());
        h.f32s(&[sky.rotate_deg, sky.intensity]);
        match &sky.model {
            SkyModel::Uniform { radiance } => h.f32s(&radiance.to_array()),
            SkyModel::Gradient { zenith, horizon, ground } => h.f32s(&v3(&[*zenith, *horizon, *ground])),
            SkyModel::Image { map, .. } => h.f32s(&v3(&map.pixels)),
        }
    }
    h.u64(scene.triangles.len() as u64);
    h.bytes(bytemuck::cast_slice(&scene.triangles));
    for l in &scene.lights {
        match *l {
            Light::Point { position, intensity } => {
                h.u64(1);
                h.f32s(&[position.to_array(), intensity.to_array()].concat());
            }
            Light::Directional { direction, irradiance } => {
                h.u64(2);
                h.f32s(&[direction.to_array(), irradiance.to_array()].concat());
            }
        }
    }
    let p = params;
    h.u64(p.samples_per_vertex as u64);
    h.u64(p.max_depth as u64);
    h.u64(p.rr_start as u64);
    h.f32s(&[p.rr_min_survival, p.offset, p.min_distance]);
    h.u64(p.seed);
    h.0
}

fn file(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.ref"))
}

/// The cached result for `key`, if a valid one for `n` vertices is there.
pub fn load(dir: &Path, key: u64, n: usize, params: &ReferenceParams) -> Option<Reference> {
    let bytes = std::fs::read(file(dir, key)).ok()?;
    if bytes.len() != 16 + 12 * PARTS * n || &bytes[..8] != MAGIC || bytes[8..16] != (n as u64).to_le_bytes() {
        return None;
    }
    let floats: Vec<f32> = bytes[16..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let part =
        |k: usize| -> Vec<Vec3> { floats[k * 3 * n..(k + 1) * 3 * n].chunks_exact(3).map(Vec3::from_slice).collect() };
    Some(Reference {
        e_direct: part(0),
        e_sky: part(1),
        e_indirect: part(2),
        e_indirect_stderr: part(3),
        e_total_stderr: part(4),
        params: *params,
        ms: 0.0,
        from_cache: true,
    })
}

/// Writes `r` under `key` (creating `dir`), via a temporary file and a rename.
pub fn store(dir: &Path, key: u64, r: &Reference) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let n = r.e_direct.len();
    let mut bytes = Vec::with_capacity(16 + 12 * PARTS * n);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(n as u64).to_le_bytes());
    for part in [&r.e_direct, &r.e_sky, &r.e_indirect, &r.e_indirect_stderr, &r.e_total_stderr] {
        for v in part.iter() {
            for x in v.to_array() {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
    }
    let tmp = dir.join(format!("{key:016x}.ref.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(tmp, file(dir, key))
}

const IMAGE_MAGIC: &[u8; 8] = b"LGIIMG01";

/// The key of a reference image of `scene` (the vertex reference's key
/// with `params`) seen by `camera` at `width` x `height`, `spp` paths a pixel.
pub fn image_key(
    scene: &PreparedScene,
    params: &ReferenceParams,
    camera: &crate::scene::Camera,
    size: (u32, u32),
    spp: u32,
) -> u64 {
    let mut h = Fnv(key(scene, params));
    h.f32s(&[camera.position.to_array(), camera.target.to_array(), [camera.fov_deg, 0.0, 0.0]].concat());
    h.u64(u64::from(size.0) << 32 | u64::from(size.1));
    h.u64(u64::from(spp));
    h.0
}

fn image_file(dir: &Path, key: u64) -> PathBuf {
    dir.join(format!("{key:016x}.img"))
}

/// The cached reference image for `key`, if a valid one is there.
pub fn load_image(dir: &Path, key: u64) -> Option<crate::render::HdrImage> {
    let bytes = std::fs::read(image_file(dir, key)).ok()?;
    if bytes.len() < 16 || &bytes[..8] != IMAGE_MAGIC {
        return None;
    }
    let (w, h) =
        (u32::from_le_bytes(bytes[8..12].try_into().ok()?), u32::from_le_bytes(bytes[12..16].try_into().ok()?));
    if bytes.len() != 16 + 12 * w as usize * h as usize {
        return None;
    }
    let floats: Vec<f32> = bytes[16..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    Some(crate::render::HdrImage {
        width: w,
        height: h,
        pixels: floats.chunks_exact(3).map(Vec3::from_slice).collect(),
    })
}

/// Writes the reference image `img` under `key` (creating `dir`), via a temporary file and a rename.
pub fn store_image(dir: &Path, key: u64, img: &crate::render::HdrImage) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut bytes = Vec::with_capacity(16 + 12 * img.pixels.len());
    bytes.extend_from_slice(IMAGE_MAGIC);
    bytes.extend_from_slice(&img.width.to_le_bytes());
    bytes.extend_from_slice(&img.height.to_le_bytes());
    for x in img.pixels.iter().flat_map(|p| p.to_array()) {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    let tmp = dir.join(format!("{key:016x}.img.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(tmp, image_file(dir, key))
}
