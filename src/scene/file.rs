//! TOML scene files (format in README.md / issue 2): `[settings]`, `[camera]`,
//! `[[mesh]]` tables naming an OBJ (`obj = "m.obj"`) or a glTF file
//! (`gltf = "m.glb"`) relative to the scene file, optionally with an
//! `emission = [r, g, b]` (emitted radiance, W/(m^2 sr), for all its
//! materials, replacing their MTL `Ke` or glTF emission; read as exitance
//! `pi * emission` by [`super::emission::exitance`], with a note saying
//! so), `[[light]]`s and an optional `[sky]` ([`SkyFile`]).
//!
//! A glTF `[[mesh]]` brings every mesh of the glTF's scene (world transforms
//! baked in, see [`super::gltf`]); the table's transform, crease angle,
//! `dynamic` and deformers apply to each of them. The glTF's own lights and
//! cameras are ignored with a warning: the scene file's `[[light]]`s and
//! `[camera]` describe the scene.
//! The same serde types write scene files back out (built-in scenes are
//! written to `scenes/` this way).

use super::deformer::{Deform, DeformKind};
use super::{emission, gltf, obj, Backend, Bounces, Camera, Light, SceneDesc, Settings, TracerKind, Transform};
use crate::sky::{EnvMap, Portal, Sky, SkyModel};
use crate::{Error, Result};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A whole scene TOML file as parsed (and as written back out).
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The `[settings]` table; every key left out takes the default.
    #[serde(default)]
    pub settings: SettingsFile,
    /// The `[camera]` table, if any.
    #[serde(default)]
    pub camera: Option<CameraFile>,
    /// The `[[mesh]]` tables; at least one is required.
    #[serde(default, rename = "mesh")]
    pub meshes: Vec<MeshFile>,
    /// The `[[light]]` tables.
    #[serde(default, rename = "light")]
    pub lights: Vec<LightFile>,
    /// The `[sky]` table, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sky: Option<SkyFile>,
}

/// `[sky]`: exactly one of `radiance` (uniform), `zenith` + `horizon`
/// (+ `ground`, default black: the gradient sky) and `image` (EXR or
/// Radiance HDR, equirectangular, relative to the scene file); radiance in
/// W/(m^2 sr). `rotate_deg` turns it about +y, `intensity` scales it.
/// `portals`: openings through which the scene sees the sky (each four
/// corners of a parallelogram in order around it, metres), which get rays
/// of their own ([`crate::sky::portal`]).
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyFile {
    /// Uniform sky radiance, W/(m^2 sr) per channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radiance: Option<[f32; 3]>,
    /// Gradient sky: radiance straight up, W/(m^2 sr) per channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub zenith: Option<[f32; 3]>,
    /// Gradient sky: radiance at the horizon, W/(m^2 sr) per channel.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon: Option<[f32; 3]>,
    /// Gradient sky: radiance below the horizon, W/(m^2 sr) per channel (default black).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground: Option<[f32; 3]>,
    /// Image sky: an equirectangular EXR or Radiance HDR file, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<PathBuf>,
    /// Rotation of the sky about +y, degrees (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotate_deg: Option<f32>,
    /// Scale applied to the sky's radiance (default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intensity: Option<f32>,
    /// Sky portals: four corners each (metres), in order around a parallelogram.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub portals: Vec<[[f32; 3]; 4]>,
}

/// The `[settings]` table; each key left out takes the value of [`Settings::default`].
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SettingsFile {
    /// Rays shot per vertex; a non-zero square number `k*k`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rays_per_vertex: Option<u32>,
    /// Number of bounces, or `"auto"`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<BouncesFile>,
    /// Feature angle of one-ring smoothing, degrees; 0 turns smoothing off.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub smoothing_angle_deg: Option<f32>,
    /// Seed of the direction set and per-vertex rotations.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// "auto", "gpu" or "cpu".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub backend: Option<String>,
    /// "bvh" or "kd".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracer: Option<String>,
    /// Optional terms of the solve to switch off ([`super::terms::Terms::NAMES`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub off: Vec<String>,
    /// Terms forced on, kept whatever a sample of their work says ([`super::terms::Terms::DECIDED`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub on: Vec<String>,
    /// "auto" or "off" ([`super::refine::RefineSettings`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine: Option<String>,
    /// Longest edge kept by a-priori refinement, metres; 0 takes a share of the scene's diagonal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine_max_edge: Option<f32>,
    /// Error-driven refinement tolerance: the share of the mean irradiance of an edge's ends above which it splits.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine_tolerance: Option<f32>,
    /// Most positions refinement may add to the scene's input (the budget).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine_max_added: Option<u32>,
    /// The lighting mesh's triangle budget (dense meshes above it are simplified).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine_max_triangles: Option<u32>,
    /// The budget's former key (read as `refine_max_added`, with a warning).
    #[serde(skip_serializing)]
    pub refine_max_vertices: Option<u32>,
    /// The near hits a vertex keeps, as a share of its link rays, in (0, 1].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub near_share: Option<f32>,
}

/// `bounces = 3` or `bounces = "auto"`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(untagged)]
pub enum BouncesFile {
    /// A fixed number of bounces.
    Count(u32),
    /// A word; only `"auto"` is accepted.
    Word(String),
}

/// The `[camera]` table.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraFile {
    /// Eye position, metres.
    pub position: [f32; 3],
    /// The point looked at, metres.
    pub target: [f32; 3],
    /// Vertical field of view, degrees, in (0, 180) (default 40).
    #[serde(default = "default_fov")]
    pub fov_deg: f32,
}

fn default_fov() -> f32 {
    40.0
}

/// One `[[mesh]]` table.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshFile {
    /// An OBJ file; exactly one of `obj` and `gltf` is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj: Option<PathBuf>,
    /// A `.gltf` or `.glb` file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gltf: Option<PathBuf>,
    /// Vertices are split where adjacent face normals differ by more than this, degrees, in [0, 180] (default 30).
    #[serde(default = "default_crease")]
    pub crease_angle_deg: f32,
    /// Placement of the mesh (the `[mesh.transform]` table).
    #[serde(default)]
    pub transform: TransformFile,
    /// True if the mesh may deform (needed for `[[mesh.deform]]`).
    #[serde(default)]
    pub dynamic: bool,
    /// `[[mesh.deform]]` tables (dynamic meshes only); see `scene::deform` for units.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub deform: Vec<DeformFile>,
    /// Emitted radiance of every material of the mesh, W/(m^2 sr) (replaces
    /// MTL `Ke` or the glTF's emission); the solver uses `pi` times it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub emission: Option<[f32; 3]>,
}

/// One `[[mesh.deform]]` table.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeformFile {
    /// "twist", "bend" or "wave".
    pub kind: String,
    /// Twist/bend: degrees per metre of height along the axis; wave: metres.
    pub amount: f32,
    /// Unit axis (height direction); default +y.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<[f32; 3]>,
    /// A point on the axis, metres; default the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub center: Option<[f32; 3]>,
    /// Direction that bend and wave move towards (made perpendicular to the axis).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub toward: Option<[f32; 3]>,
    /// Period of the time factor, seconds (> 0); default 4.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period_s: Option<f32>,
    /// Wave length along the axis, metres (> 0); default 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength: Option<f32>,
}

fn deform_from(path: &Path, mesh: &str, d: &DeformFile) -> Result<Deform> {
    let kind = match d.kind.as_str() {
        "twist" => DeformKind::Twist,
        "bend" => DeformKind::Bend,
        "wave" => DeformKind::Wave,
        k => {
            return Err(scene_err(
                path,
                format!("mesh '{mesh}': deform.kind = \"{k}\": expected \"twist\", \"bend\" or \"wave\""),
            ))
        }
    };
    let mut out = Deform::new(kind, d.amount);
    if let Some(a) = d.axis {
        out.axis = Vec3::from(a);
    }
    if let Some(c) = d.center {
        out.center = Vec3::from(c);
    }
    if let Some(t) = d.toward {
        out.toward = Vec3::from(t);
    }
    if let Some(p) = d.period_s {
        out.period_s = p;
    }
    if let Some(w) = d.wavelength {
        out.wavelength = w;
    }
    out.validate().map_err(|m| scene_err(path, format!("mesh '{mesh}': {m}")))?;
    Ok(out.normalized())
}

fn deform_to_file(d: &Deform) -> DeformFile {
    DeformFile {
        kind: format!("{:?}", d.kind).to_lowercase(),
        amount: d.amount,
        axis: Some(d.axis.into()),
        center: Some(d.center.into()),
        toward: Some(d.toward.into()),
        period_s: Some(d.period_s),
        wavelength: Some(d.wavelength),
    }
}

fn default_crease() -> f32 {
    30.0
}

/// A `[mesh.transform]` table: scale, then rotate (x, then y, then z), then translate.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformFile {
    /// Translation, metres (default zero).
    #[serde(default)]
    pub translate: [f32; 3],
    /// Rotations about x, y and z, degrees (default zero).
    #[serde(default)]
    pub rotate_deg: [f32; 3],
    /// Uniform scale factor, positive (default 1).
    #[serde(default = "one")]
    pub scale: f32,
}

fn one() -> f32 {
    1.0
}

impl Default for TransformFile {
    fn default() -> Self {
        Self { translate: [0.0; 3], rotate_deg: [0.0; 3], scale: 1.0 }
    }
}

/// One `[[light]]` table, told apart by its `kind` key (`"point"` or `"directional"`).
#[derive(Debug, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightFile {
    /// `kind = "point"`: an isotropic point light.
    Point {
        /// Position, metres.
        position: [f32; 3],
        /// Radiant intensity, W/sr per channel (non-negative).
        intensity: [f32; 3],
    },
    /// `kind = "directional"`: a distant light.
    Directional {
        /// Direction the light travels in (normalized on loading; must not be zero).
        direction: [f32; 3],
        /// Irradiance on a surface facing the light, W/m^2 per channel (non-negative).
        irradiance: [f32; 3],
    },
}

fn scene_err(path: &Path, message: impl Into<String>) -> Error {
    Error::SceneFile { path: path.to_path_buf(), message: message.into() }
}

fn finite3(path: &Path, what: &str, v: [f32; 3]) -> Result<Vec3> {
    let v = Vec3::from(v);
    if !v.is_finite() {
        return Err(scene_err(path, format!("{what} = {v} is not finite")));
    }
    Ok(v)
}

/// Converts parsed settings into [`Settings`], checking ranges.
fn settings_from(path: &Path, s: &SettingsFile) -> Result<Settings> {
    let d = Settings::default();
    let bounces = match &s.bounces {
        None => d.bounces,
        Some(BouncesFile::Count(n)) => Bounces::Fixed(*n),
        Some(BouncesFile::Word(w)) if w == "auto" => Bounces::Auto,
        Some(BouncesFile::Word(w)) => {
            return Err(scene_err(path, format!("settings.bounces = \"{w}\": expected a number or \"auto\"")))
        }
    };
    let settings = Settings {
        rays_per_vertex: s.rays_per_vertex.unwrap_or(d.rays_per_vertex),
        bounces,
        smoothing_angle_deg: s.smoothing_angle_deg.unwrap_or(d.smoothing_angle_deg),
        seed: s.seed.unwrap_or(d.seed),
        backend: match &s.backend {
            None => d.backend,
            Some(b) => b.parse::<Backend>().map_err(|_| {
                scene_err(path, format!("settings.backend = \"{b}\": expected \"auto\", \"gpu\" or \"cpu\""))
            })?,
        },
        tracer: match &s.tracer {
            None => d.tracer,
            Some(t) => t.parse::<TracerKind>().map_err(|_| {
                scene_err(path, format!("settings.tracer = \"{t}\": expected \"auto\", \"bvh\", \"kd\" or \"rq\""))
            })?,
        },
        terms: super::terms::Terms::with_off(s.off.iter().map(String::as_str))
            .map_err(|e| scene_err(path, format!("settings.off: {e}")))?,
        forced: super::terms::Terms::with_on(s.on.iter().map(String::as_str))
            .map_err(|e| scene_err(path, format!("settings.on: {e}")))?,
        refine: super::refine::RefineSettings {
            mode: match s.refine.as_deref() {
                None => d.refine.mode,
                Some("auto") => super::refine::RefineMode::Auto,
                Some("off") => super::refine::RefineMode::Off,
                Some(r) => {
                    return Err(scene_err(path, format!("settings.refine = \"{r}\": expected \"auto\" or \"off\"")))
                }
            },
            max_edge: s.refine_max_edge.unwrap_or(d.refine.max_edge),
            tolerance: s.refine_tolerance.unwrap_or(d.refine.tolerance),
            max_added: match (s.refine_max_added, s.refine_max_vertices) {
                (Some(n), _) => n,
                (None, Some(n)) => {
                    log::warn!(
                        "{}: settings.refine_max_vertices is now refine_max_added (positions refinement may \
                         add to the input); read as refine_max_added = {n}",
                        path.display()
                    );
                    n
                }
                (None, None) => d.refine.max_added,
            },
            max_triangles: s.refine_max_triangles.unwrap_or(d.refine.max_triangles),
        },
        near_share: s.near_share.unwrap_or(d.near_share),
    };
    settings.validate().map_err(|e| scene_err(path, e.to_string()))?;
    Ok(settings)
}

fn sky_from(path: &Path, dir: &Path, s: &SkyFile) -> Result<Sky> {
    let colour = |what: &str, v: [f32; 3]| -> Result<Vec3> {
        let v = finite3(path, what, v)?;
        if v.min_element() < 0.0 {
            return Err(scene_err(path, format!("{what} = {v} is negative")));
        }
        Ok(v)
    };
    let mut sky = match (&s.radiance, &s.zenith, &s.horizon, &s.image) {
        (Some(r), None, None, None) if s.ground.is_none() => Sky::uniform(colour("sky.radiance", *r)?),
        (None, Some(z), Some(h), None) => Sky::gradient(
            colour("sky.zenith", *z)?,
            colour("sky.horizon", *h)?,
            s.ground.map(|g| colour("sky.ground", g)).transpose()?.unwrap_or(Vec3::ZERO),
        ),
        (None, None, None, Some(img)) if s.ground.is_none() => Sky::image(img.clone(), EnvMap::load(&dir.join(img))?),
        _ => {
            return Err(scene_err(
                path,
                "[sky] needs exactly one of radiance = [r, g, b], zenith + horizon (+ ground), or image = \"sky.exr\"",
            ))
        }
    };
    sky.rotate_deg = s.rotate_deg.unwrap_or(0.0);
    sky.intensity = s.intensity.unwrap_or(1.0);
    for (i, corners) in s.portals.iter().enumerate() {
        let portal = Portal::from_corners(corners.map(Vec3::from_array))
            .map_err(|m| scene_err(path, format!("[sky] portals[{i}]: {m}")))?;
        sky.portals.push(portal);
    }
    sky.validate().map_err(|m| scene_err(path, format!("[sky]: {m}")))?;
    Ok(sky)
}

fn sky_to_file(s: &Sky) -> SkyFile {
    let mut f = SkyFile {
        rotate_deg: (s.rotate_deg != 0.0).then_some(s.rotate_deg),
        intensity: (s.intensity != 1.0).then_some(s.intensity),
        portals: s.portals.iter().map(|p| p.corners().map(|c| c.to_array())).collect(),
        ..Default::default()
    };
    match &s.model {
        SkyModel::Uniform { radiance } => f.radiance = Some(radiance.to_array()),
        SkyModel::Gradient { zenith, horizon, ground } => {
            f.zenith = Some(zenith.to_array());
            f.horizon = Some(horizon.to_array());
            f.ground = Some(ground.to_array());
        }
        SkyModel::Image { path, .. } => f.image = Some(path.clone()),
    }
    f
}

fn light_from(path: &Path, l: &LightFile) -> Result<Light> {
    Ok(match l {
        LightFile::Point { position, intensity } => {
            let intensity = finite3(path, "light.intensity", *intensity)?;
            if intensity.min_element() < 0.0 {
                return Err(scene_err(path, format!("light.intensity = {intensity} is negative")));
            }
            Light::Point { position: finite3(path, "light.position", *position)?, intensity }
        }
        LightFile::Directional { direction, irradiance } => {
            let d = finite3(path, "light.direction", *direction)?;
            if d.length_squared() < 1e-20 || d.normalize_or_zero() == Vec3::ZERO {
                return Err(scene_err(path, format!("light.direction = {d} has no unit vector (zero or too long)")));
            }
            let irradiance = finite3(path, "light.irradiance", *irradiance)?;
            if irradiance.min_element() < 0.0 {
                return Err(scene_err(path, format!("light.irradiance = {irradiance} is negative")));
            }
            Light::Directional { direction: d.normalize(), irradiance }
        }
    })
}

/// Parses a scene TOML from text (paths in it are resolved against `dir`).
pub fn parse_toml(path: &Path, text: &str) -> Result<SceneDesc> {
    let file: SceneFile = toml::from_str(text).map_err(|e| scene_err(path, e.to_string()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let settings = settings_from(path, &file.settings)?;
    let camera = match &file.camera {
        None => None,
        Some(c) => Some(Camera {
            position: finite3(path, "camera.position", c.position)?,
            target: finite3(path, "camera.target", c.target)?,
            fov_deg: c.fov_deg,
        }),
    };
    if let Some(camera) = camera.filter(|c| !(c.fov_deg.is_finite() && c.fov_deg > 0.0 && c.fov_deg < 180.0)) {
        return Err(scene_err(path, format!("camera.fov_deg = {} is not in (0, 180)", camera.fov_deg)));
    }
    if file.meshes.is_empty() {
        return Err(scene_err(path, "no [[mesh]] tables: the scene has no geometry"));
    }
    let mut meshes = Vec::with_capacity(file.meshes.len());
    let mut warnings = Vec::new();
    let mut notes = Vec::new();
    for m in &file.meshes {
        let t = &m.transform;
        let transform = Transform {
            translate: finite3(path, "mesh.transform.translate", t.translate)?,
            rotate_deg: finite3(path, "mesh.transform.rotate_deg", t.rotate_deg)?,
            scale: t.scale,
        };
        if !(t.scale.is_finite() && t.scale > 0.0) {
            return Err(scene_err(path, format!("mesh.transform.scale = {} must be positive", t.scale)));
        }
        if !(m.crease_angle_deg.is_finite() && (0.0..=180.0).contains(&m.crease_angle_deg)) {
            return Err(scene_err(path, format!("mesh.crease_angle_deg = {} is not in [0, 180]", m.crease_angle_deg)));
        }
        // The mesh's own notes (its files' emission), dropped where `emission` replaces it.
        let mut mesh_notes = Vec::new();
        let (loaded, file_name) = match (&m.obj, &m.gltf) {
            (Some(o), None) => (vec![obj::load_obj(&dir.join(o), &mut warnings, &mut mesh_notes)?], o),
            (None, Some(g)) => {
                let full = dir.join(g);
                let scene = gltf::load_gltf(&full, &mut warnings, &mut mesh_notes)?;
                if !scene.lights.is_empty() || scene.camera.is_some() {
                    warnings.push(format!(
                        "{}: the lights and camera of {} are ignored (this scene file's [[light]]s and [camera] apply)",
                        path.display(),
                        full.display()
                    ));
                }
                (scene.meshes, g)
            }
            _ => return Err(scene_err(path, "a [[mesh]] table needs exactly one of obj = \"...\" and gltf = \"...\"")),
        };
        let mesh_name = file_name.display().to_string();
        if !m.deform.is_empty() && !m.dynamic {
            return Err(scene_err(path, format!("mesh '{mesh_name}': [[mesh.deform]] needs dynamic = true")));
        }
        let deform = m.deform.iter().map(|d| deform_from(path, &mesh_name, d)).collect::<Result<Vec<_>>>()?;
        let emission = match m.emission {
            None => None,
            Some(e) => {
                let e = finite3(path, "mesh.emission", e)?;
                if e.min_element() < 0.0 {
                    return Err(scene_err(path, format!("mesh '{mesh_name}': emission = {e} is negative")));
                }
                let m_e = emission::exitance(e);
                let all = (format!("every material of {mesh_name} (replacing its own emission)"), m_e);
                mesh_notes = emission::note(&path.display().to_string(), "emission", [all]).into_iter().collect();
                Some(m_e)
            }
        };
        notes.append(&mut mesh_notes);
        for mut mesh in loaded {
            if let Some(e) = emission {
                mesh.materials.iter_mut().for_each(|mat| mat.emission = e);
                // Uniform over the mesh: replaces an emissive texture's per-vertex values.
                mesh.vertex_emission = None;
            }
            mesh.crease_angle_deg = m.crease_angle_deg;
            mesh.transform = transform;
            mesh.dynamic = m.dynamic;
            mesh.deform = deform.clone();
            meshes.push(mesh);
        }
    }
    let lights = file.lights.iter().map(|l| light_from(path, l)).collect::<Result<Vec<_>>>()?;
    let sky = file.sky.as_ref().map(|s| sky_from(path, dir, s)).transpose()?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(SceneDesc { name, settings, camera, meshes, lights, sky, warnings, notes })
}

/// Loads a scene TOML file.
pub fn load_toml(path: &Path) -> Result<SceneDesc> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    parse_toml(path, &text)
}

/// Loads a bare OBJ as a scene with default settings, no camera (renderers
/// frame it: [`crate::render::framing`]) and no lights.
pub fn load_bare_obj(path: &Path) -> Result<SceneDesc> {
    let (mut warnings, mut notes) = (Vec::new(), Vec::new());
    let mesh = obj::load_obj(path, &mut warnings, &mut notes)?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(SceneDesc {
        name,
        settings: Settings::default(),
        camera: None,
        meshes: vec![mesh],
        lights: vec![],
        sky: None,
        warnings,
        notes,
    })
}

/// Builds the TOML text describing `scene`, naming mesh `i`'s OBJ as `obj_names[i]`.
pub fn to_toml(scene: &SceneDesc, obj_names: &[String]) -> String {
    use super::refine::{RefineMode, RefineSettings};
    let s = &scene.settings;
    let dr = RefineSettings::default();
    let file = SceneFile {
        settings: SettingsFile {
            rays_per_vertex: Some(s.rays_per_vertex),
            bounces: Some(match s.bounces {
                Bounces::Fixed(n) => BouncesFile::Count(n),
                Bounces::Auto => BouncesFile::Word("auto".into()),
            }),
            smoothing_angle_deg: Some(s.smoothing_angle_deg),
            seed: Some(s.seed),
            backend: match s.backend {
                Backend::Auto => None,
                b => Some(b.name().to_string()),
            },
            tracer: match s.tracer {
                TracerKind::Auto => None,
                t => Some(t.name().to_string()),
            },
            off: s.terms.off().into_iter().map(String::from).collect(),
            on: s.forced.on().into_iter().map(String::from).collect(),
            refine: (s.refine.mode == RefineMode::Off).then(|| "off".to_string()),
            refine_max_edge: (s.refine.max_edge != dr.max_edge).then_some(s.refine.max_edge),
            refine_tolerance: (s.refine.tolerance != dr.tolerance).then_some(s.refine.tolerance),
            refine_max_added: (s.refine.max_added != dr.max_added).then_some(s.refine.max_added),
            refine_max_triangles: (s.refine.max_triangles != dr.max_triangles).then_some(s.refine.max_triangles),
            refine_max_vertices: None,
            near_share: (s.near_share != Settings::default().near_share).then_some(s.near_share),
        },
        camera: scene.camera.map(|c| CameraFile {
            position: c.position.into(),
            target: c.target.into(),
            fov_deg: c.fov_deg,
        }),
        meshes: scene
            .meshes
            .iter()
            .zip(obj_names)
            .map(|(m, name)| MeshFile {
                obj: Some(PathBuf::from(name)),
                gltf: None,
                crease_angle_deg: m.crease_angle_deg,
                transform: TransformFile {
                    translate: m.transform.translate.into(),
                    rotate_deg: m.transform.rotate_deg.into(),
                    scale: m.transform.scale,
                },
                dynamic: m.dynamic,
                deform: m.deform.iter().map(deform_to_file).collect(),
                // Emission travels in the MTL (`Ke`).
                emission: None,
            })
            .collect(),
        lights: scene
            .lights
            .iter()
            .map(|l| match *l {
                Light::Point { position, intensity } => {
                    LightFile::Point { position: position.into(), intensity: intensity.into() }
                }
                Light::Directional { direction, irradiance } => {
                    LightFile::Directional { direction: direction.into(), irradiance: irradiance.into() }
                }
            })
            .collect(),
        sky: scene.sky.as_ref().map(sky_to_file),
    };
    toml::to_string(&file).expect("scene description serializes")
}

/// Writes `scene` as `dir/<name>.toml` plus one `.obj`/`.mtl` pair per mesh.
pub fn write_scene(scene: &SceneDesc, dir: &Path) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.to_path_buf(), source })?;
    let mut names = Vec::new();
    for (i, mesh) in scene.meshes.iter().enumerate() {
        let stem = if scene.meshes.len() == 1 { scene.name.clone() } else { format!("{}_{i}", scene.name) };
        obj::write_obj(mesh, &dir.join(format!("{stem}.obj")))?;
        names.push(format!("{stem}.obj"));
    }
    let path = dir.join(format!("{}.toml", scene.name));
    let text = format!(
        "# linkgi scene '{}' (written by `linkgi scenes`; the same scene is built in under this name)\n{}",
        scene.name,
        to_toml(scene, &names)
    );
    std::fs::write(&path, text).map_err(|source| Error::Io { path: path.clone(), source })?;
    Ok(path)
}
