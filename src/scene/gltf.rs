//! glTF 2.0 scenes (`.gltf` with its buffers and images, or binary `.glb`),
//! read with the `gltf` crate: meshes, base colour, `KHR_lights_punctual`
//! lights and the first perspective camera.
//!
//! What is read, from the default scene (else the first scene, else every
//! node that is no other node's child), depth first:
//! - Every mesh primitive of mode TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN,
//!   with its node's world transform (the product of the node hierarchy's
//!   matrices or translation/rotation/scale) baked into the positions. glTF
//!   is right-handed, y up, in metres, as linkgi is. Where a world transform
//!   mirrors (negative determinant) the winding is reversed so that front
//!   faces stay front faces. Each node holding a mesh becomes one
//!   [`MeshDesc`] named `file#node` (its node name, else `node<index>`), with
//!   the identity [`super::Transform`]; welding, crease splitting and
//!   one-rings happen in [`super::prep`] as for OBJ.
//! - Albedo: see `scene::gltf_mesh` (`baseColorFactor` times the base
//!   colour texture at each vertex's UV times `COLOR_0`, per vertex).
//! - `KHR_lights_punctual` lights at their nodes' world positions; light
//!   `direction`s are the node's -z axis.
//! - The first perspective camera met, at its node's position looking down
//!   the node's -z axis, `fov_deg` = `yfov` in degrees. linkgi cameras keep
//!   y up, so a camera's roll is lost. The orbit target is put where the view
//!   axis passes closest to the centre of the meshes' bounding box. Without a
//!   camera, the scene has none and is framed when rendered
//!   ([`crate::render::framing`]), as a bare OBJ is.
//!
//! Light units. glTF gives point and spot intensity in candela (lm/sr) and
//! directional intensity in lux (lm/m^2), times a linear RGB `color`. linkgi
//! works in watts, so both are converted with the luminous efficacy
//! [`LUMENS_PER_WATT`] = 683 lm/W (the photometric definition, exact at
//! 555 nm): point `I [W/sr] = intensity / 683 * color` per channel and
//! directional `E [W/m^2] = intensity / 683 * color` per channel. This treats
//! every channel as if it were light at the eye's peak sensitivity; it is a
//! fixed scale, so relative lighting is exact and [`super::gltf_write`]
//! inverts it.
//!
//! Ignored, each with a warning: spot cones (a spot light becomes a point
//! light of the same intensity), light `range`, emissive textures (a
//! material's emission is uniform: `emissiveFactor * emissive_strength`
//! read as emitted radiance, W/(m^2 sr), exitance `pi` times it,
//! [`super::emission`], with a note saying so), skins and morph targets (the bind pose is used),
//! orthographic cameras, and extensions other than `KHR_lights_punctual`
//! and `KHR_materials_emissive_strength`.
//! Extensions a file *requires* that the crate does not know are an error.
//!
//! Bad files are errors ([`Error::Gltf`]) naming the file and the place
//! (buffer, view, mesh and primitive, node, light), never panics: the
//! crate's readers assume a valid document, so the GLB header, the
//! references the crate's own validation dereferences, URIs, buffer views
//! and every accessor read are checked first, then the crate validates
//! indices and required fields.

use super::gltf_mesh::{self, MeshContext};
use super::{Camera, Light, MeshDesc, SceneDesc, Settings};
use crate::{Error, Result};
use ::gltf::json;
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

/// Luminous efficacy that converts glTF's photometric light units to watts, lm/W.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// What a glTF file describes, before preparation.
#[derive(Clone, Debug)]
pub struct GltfScene {
    /// One mesh per node that holds a mesh, world transforms baked in.
    pub meshes: Vec<MeshDesc>,
    /// The file's `KHR_lights_punctual` lights.
    pub lights: Vec<Light>,
    /// The first perspective camera, if any.
    pub camera: Option<Camera>,
}

pub(super) fn gltf_err(path: &Path, message: impl Into<String>) -> Error {
    Error::Gltf { path: path.to_path_buf(), message: message.into() }
}

/// A parsed and validated document with its buffers loaded.
struct Loaded {
    doc: ::gltf::Document,
    buffers: Vec<::gltf::buffer::Data>,
    base: PathBuf,
}

/// Loads a `.gltf` or `.glb` file as a scene with default settings.
pub fn load_scene(path: &Path) -> Result<SceneDesc> {
    let (mut warnings, mut notes) = (Vec::new(), Vec::new());
    let g = load_gltf(path, &mut warnings, &mut notes)?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(SceneDesc {
        name,
        settings: Settings::default(),
        camera: g.camera,
        meshes: g.meshes,
        lights: g.lights,
        sky: None,
        warnings,
        notes,
    })
}

/// Loads the meshes, lights and camera of a `.gltf` or `.glb` file.
/// Problems that were worked around are appended to `warnings`, what was
/// assumed (how emission was read) to `notes`.
pub fn load_gltf(path: &Path, warnings: &mut Vec<String>, notes: &mut Vec<String>) -> Result<GltfScene> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    let loaded = open(path, &bytes)?;
    let doc = &loaded.doc;
    let warn = |warnings: &mut Vec<String>, m: String| warnings.push(format!("{}: {m}", path.display()));
    for ext in doc.extensions_used() {
        if ext != "KHR_lights_punctual" && ext != "KHR_materials_emissive_strength" {
            warn(warnings, format!("extension {ext} is not supported and is ignored"));
        }
    }
    let roots: Vec<::gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut cx = MeshContext::new(path, &loaded.base, &loaded.buffers);
    let mut meshes = Vec::new();
    let mut lights = Vec::new();
    let mut camera: Option<(Vec3, Vec3, f32)> = None;
    let mut seen = vec![false; doc.nodes().len()];
    let mut stack: Vec<(::gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let ni = node.index();
        if std::mem::replace(&mut seen[ni], true) {
            return Err(gltf_err(path, format!("node {ni} is reached twice (the node hierarchy must be a tree)")));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let label = node.name().map(str::to_string).unwrap_or_else(|| format!("node{ni}"));
        if let Some(mesh) = node.mesh() {
            if node.skin().is_some() {
                warn(warnings, format!("node {ni} ('{label}'): its skin is ignored (the bind pose is used)"));
            }
            let name = format!("{}#{label}", path.display());
            match gltf_mesh::build_mesh(&mut cx, &mesh, world, name, warnings)
                .map_err(|m| gltf_err(path, format!("node {ni} ('{label}'): {m}")))?
            {
                Some(m) => meshes.push(m),
                None => warn(warnings, format!("node {ni} ('{label}'): its mesh has no triangles; skipped")),
            }
        }
        if let Some(light) = node.light() {
            lights.push(
                light_from(&light, world, path, warnings)
                    .map_err(|m| gltf_err(path, format!("node {ni} ('{label}'), light {}: {m}", light.index())))?,
            );
        }
        if let (None, Some(cam)) = (camera, node.camera()) {
            camera = camera_from(&cam, world, &label, path, warnings);
        }
        let children: Vec<_> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    if meshes.is_empty() {
        return Err(gltf_err(path, "the scene has no triangle meshes"));
    }
    let camera = camera.map(|(position, forward, fov_deg)| {
        let (lo, hi) = meshes
            .iter()
            .flat_map(|m| &m.positions)
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        let along = (centre - position).dot(forward);
        let distance = if along.is_finite() && along > 1e-3 * radius { along } else { radius };
        Camera { position, target: position + forward * distance, fov_deg }
    });
    // One entry per material, however many nodes use it.
    let mut emitters: Vec<(String, Vec3)> = Vec::new();
    for m in meshes.iter().flat_map(|m| super::emission::materials(&m.materials)) {
        if !emitters.iter().any(|e| e.0 == m.0) {
            emitters.push(m);
        }
    }
    notes.extend(super::emission::note(&path.display().to_string(), "emissiveFactor x emissive_strength", emitters));
    Ok(GltfScene { meshes, lights, camera })
}

/// Converts one `KHR_lights_punctual` light placed by `world`.
fn light_from(
    light: &::gltf::khr_lights_punctual::Light,
    world: Mat4,
    path: &Path,
    warnings: &mut Vec<String>,
) -> std::result::Result<Light, String> {
    use ::gltf::khr_lights_punctual::Kind;
    let color = Vec3::from(light.color());
    let intensity = light.intensity();
    if !(color.is_finite() && intensity.is_finite()) || intensity < 0.0 || color.min_element() < 0.0 {
        return Err(format!("color {color} and intensity {intensity} must be finite and non-negative"));
    }
    let rgb = color * (intensity / LUMENS_PER_WATT);
    if let Some(range) = light.range() {
        warnings.push(format!(
            "{}: light {}: range {range} is ignored (light falls off with the inverse square everywhere)",
            path.display(),
            light.index()
        ));
    }
    let position = world.transform_point3(Vec3::ZERO);
    let point = |position: Vec3| -> std::result::Result<Light, String> {
        if !position.is_finite() {
            return Err(format!("its node's transform puts it at {position}"));
        }
        Ok(Light::Point { position, intensity: rgb })
    };
    match light.kind() {
        Kind::Point => point(position),
        Kind::Spot { .. } => {
            warnings.push(format!(
                "{}: light {} is a spot light; loaded as a point light (its cone is ignored)",
                path.display(),
                light.index()
            ));
            point(position)
        }
        Kind::Directional => {
            let d = world.transform_vector3(Vec3::NEG_Z);
            let direction = d.normalize_or_zero();
            if direction == Vec3::ZERO {
                return Err(format!("its node's transform gives the direction {d}, which has no unit vector"));
            }
            Ok(Light::Directional { direction, irradiance: rgb })
        }
    }
}

/// Position, unit view direction and vertical field of view (degrees) of a
/// perspective camera placed by `world`; `None` (with a warning) otherwise.
fn camera_from(
    cam: &::gltf::Camera,
    world: Mat4,
    label: &str,
    path: &Path,
    warnings: &mut Vec<String>,
) -> Option<(Vec3, Vec3, f32)> {
    let mut warn =
        |m: String| warnings.push(format!("{}: camera {} at node '{label}': {m}", path.display(), cam.index()));
    let ::gltf::camera::Projection::Perspective(p) = cam.projection() else {
        warn("orthographic cameras are not supported; ignored".into());
        return None;
    };
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    if !position.is_finite() || forward == Vec3::ZERO || !forward.is_finite() {
        warn(format!("its node's transform gives position {position}, direction {forward}; ignored"));
        return None;
    }
    let fov_deg = p.yfov().to_degrees();
    if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
        warn(format!("yfov of {fov_deg} degrees is not in (0, 180); ignored"));
        return None;
    }
    Some((position, forward, fov_deg))
}

/// Parses and validates `bytes` (the content of `path`) and loads its buffers.
fn open(path: &Path, bytes: &[u8]) -> Result<Loaded> {
    let err = |m: String| gltf_err(path, m);
    if bytes.starts_with(b"glTF") {
        check_glb_header(bytes).map_err(err)?;
    }
    let ::gltf::Gltf { document, mut blob } =
        ::gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| err(format!("not a glTF 2.0 file ({e})")))?;
    let root = document.as_json();
    check_before_validation(root).map_err(err)?;
    let mut problems = Vec::new();
    {
        use json::validation::Validate;
        root.validate(root, json::Path::new, &mut |p, e| problems.push(format!("{}: {e}", p())));
    }
    if !problems.is_empty() {
        let more = if problems.len() > 3 { format!(" (and {} more)", problems.len() - 3) } else { String::new() };
        problems.truncate(3);
        return Err(err(format!("invalid glTF: {}{more}", problems.join("; "))));
    }
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mut buffers = Vec::new();
    for b in document.buffers() {
        let what = match b.source() {
            ::gltf::buffer::Source::Bin => "the GLB binary chunk".to_string(),
            ::gltf::buffer::Source::Uri(u) if u.starts_with("data:") => "a data URI".to_string(),
            ::gltf::buffer::Source::Uri(u) => format!("file '{u}'"),
        };
        let data = ::gltf::buffer::Data::from_source_and_blob(b.source(), Some(&base), &mut blob)
            .map_err(|e| err(format!("buffer {} ({what}) could not be read: {e}", b.index())))?;
        if data.len() < b.length() {
            return Err(err(format!(
                "buffer {} ({what}) has {} bytes but declares byteLength {}",
                b.index(),
                data.len(),
                b.length()
            )));
        }
        buffers.push(data);
    }
    for v in document.views() {
        let len = buffers[v.buffer().index()].len();
        if v.offset().checked_add(v.length()).is_none_or(|end| end > len) {
            return Err(err(format!(
                "buffer view {} (offset {}, length {}) reaches past the end of buffer {} ({len} bytes)",
                v.index(),
                v.offset(),
                v.length(),
                v.buffer().index()
            )));
        }
    }
    Ok(Loaded { doc: document, buffers, base })
}

/// The GLB header fields the crate subtracts from without checking.
fn check_glb_header(bytes: &[u8]) -> std::result::Result<(), String> {
    let word = |i: usize| bytes.get(i..i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    match (word(4), word(8)) {
        (Some(2), Some(len)) if len >= 20 && len as usize <= bytes.len() => Ok(()),
        (Some(2), Some(len)) => {
            Err(format!("GLB header declares {len} bytes but the file has {} (at least 20 needed)", bytes.len()))
        }
        (Some(v), Some(_)) => Err(format!("GLB version {v} is not supported (expected 2)")),
        _ => Err("GLB header is truncated".into()),
    }
}

/// Checks what the crate's validation dereferences before checking it, and
/// what its importer and accessors unwrap: POSITION accessor indices, URIs,
/// image sources and MIME types, camera projections.
fn check_before_validation(root: &json::Root) -> std::result::Result<(), String> {
    let position = json::validation::Checked::Valid(json::mesh::Semantic::Positions);
    for (mi, m) in root.meshes.iter().enumerate() {
        for (pi, p) in m.primitives.iter().enumerate() {
            if let Some(a) = p.attributes.get(&position) {
                if a.value() >= root.accessors.len() {
                    return Err(format!(
                        "mesh {mi} primitive {pi}: POSITION accessor {} does not exist ({} accessors)",
                        a.value(),
                        root.accessors.len()
                    ));
                }
            }
        }
    }
    let buffer_uris = root.buffers.iter().enumerate().map(|(i, b)| ("buffer", i, &b.uri));
    for (what, i, uri) in buffer_uris.chain(root.images.iter().enumerate().map(|(i, im)| ("image", i, &im.uri))) {
        if let Some(uri) = uri {
            if !uri.contains(':') && urlencoding::decode(uri).is_err() {
                return Err(format!("{what} {i}: URI '{uri}' does not decode to UTF-8"));
            }
        }
    }
    for (i, image) in root.images.iter().enumerate() {
        if image.buffer_view.is_some() && image.mime_type.is_none() {
            return Err(format!("image {i} is stored in a buffer view but has no mimeType"));
        }
        if image.buffer_view.is_none() && image.uri.is_none() {
            return Err(format!("image {i} has neither a uri nor a bufferView"));
        }
    }
    for (i, camera) in root.cameras.iter().enumerate() {
        use json::camera::Type;
        let missing = match camera.type_ {
            json::validation::Checked::Valid(Type::Perspective) => camera.perspective.is_none(),
            json::validation::Checked::Valid(Type::Orthographic) => camera.orthographic.is_none(),
            _ => false,
        };
        if missing {
            return Err(format!("camera {i} lacks the projection its type names"));
        }
    }
    Ok(())
}
