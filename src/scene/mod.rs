//! Scene description: meshes, materials, lights, camera and solver settings,
//! as read from a TOML scene file (with OBJ/MTL meshes) or built in code.
//!
//! glTF 2.0 scenes load through [`gltf`] (meshes, albedo, lights, camera).
//!
//! Units (docs/DESIGN.md, units and conventions): right-handed, y up, metres; albedo `rho` per RGB channel
//! in [0, 1); point lights carry radiant intensity `I` in W/sr per channel;
//! directional lights carry irradiance in W/m^2 on a surface facing them and a
//! `direction` of travel. Nothing here is prepared for solving yet: see
//! [`prep`] for welding, crease splitting and one-rings.

pub mod builder;
pub mod builtin;
pub mod contact;
pub mod deform;
pub mod deformer;
// Dense copies: the scaling bench and the tests.
#[cfg(any(test, feature = "internals", feature = "cli"))]
pub mod dense;
pub mod edges;
pub mod emission;
pub mod file;
pub mod gltf;
mod gltf_mesh;
// The glTF writer: the tests write scenes with it (issue 46 makes it the bake).
#[cfg(any(test, feature = "internals"))]
pub mod gltf_write;
pub mod motion;
pub mod obj;
pub mod order;
pub mod prep;
pub mod refine;
pub mod rings;
pub mod shapes;
pub mod simplify;
pub mod terms;
pub mod texture;
pub mod transfer;

use glam::{Mat4, Quat, Vec3};
use std::path::PathBuf;

/// Largest albedo the solver accepts; larger values are clamped with a warning
/// (an albedo of 1 makes the bounce series diverge).
pub const MAX_ALBEDO: f32 = 0.999;

/// A named Lambertian material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Material name (from the MTL or glTF file, or the built-in scene).
    pub name: String,
    /// Diffuse albedo per channel, in [0, MAX_ALBEDO].
    pub albedo: Vec3,
    /// Emitted radiant exitance `M` per channel, W/m^2; zero for surfaces
    /// that do not glow. Files give emitted radiance `L` (MTL `Ke`, the
    /// scene file's `emission`, glTF's emissive factor x strength), read as
    /// `M = pi L` by `emission::exitance`.
    pub emission: Vec3,
}

/// Placement of a mesh: scale, then rotate (x, then y, then z, degrees), then translate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Translation, metres.
    pub translate: Vec3,
    /// Rotations about x, y and z, degrees.
    pub rotate_deg: Vec3,
    /// Uniform scale factor.
    pub scale: f32,
}

impl Default for Transform {
    fn default() -> Self {
        Self { translate: Vec3::ZERO, rotate_deg: Vec3::ZERO, scale: 1.0 }
    }
}

impl Transform {
    /// The affine matrix of this transform.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(Vec3::splat(self.scale), self.rotation(), self.translate)
    }

    /// The rotation part (x, then y, then z).
    pub fn rotation(&self) -> Quat {
        let r = self.rotate_deg * (std::f32::consts::PI / 180.0);
        Quat::from_rotation_z(r.z) * Quat::from_rotation_y(r.y) * Quat::from_rotation_x(r.x)
    }
}

/// One triangle mesh as loaded, before preparation.
#[derive(Clone, Debug)]
pub struct MeshDesc {
    /// Name used in messages (file path or built-in name).
    pub name: String,
    /// Object-space positions, metres.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles (front face where the normal points).
    pub triangles: Vec<[u32; 3]>,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    /// The materials that `triangle_material` indexes.
    pub materials: Vec<Material>,
    /// Albedo per position (same length as `positions`), used instead of the
    /// material's albedo when present (glTF base colour textures and vertex
    /// colours). Triangles still carry materials, which split vertices at
    /// material borders; corners whose albedo differs are split as well.
    pub vertex_albedo: Option<Vec<Vec3>>,
    /// Emitted radiant exitance per position, W/m^2 (same length as
    /// `positions`), used instead of the material's when present (glTF
    /// emissive textures); corners whose emission differs are split.
    pub vertex_emission: Option<Vec<Vec3>>,
    /// Albedo textures drawn per pixel by the renderer (the solver reads
    /// `vertex_albedo`, which the loaders sample from them).
    pub textures: Option<texture::MeshTextures>,
    /// Vertices are split where adjacent face normals differ by more than this.
    pub crease_angle_deg: f32,
    /// Placement of the mesh in the world.
    pub transform: Transform,
    /// True if the mesh may deform.
    pub dynamic: bool,
    /// Deformers applied over time (dynamic meshes only), in order; see `deform`.
    pub deform: Vec<deform::Deform>,
    /// The OBJ or glTF file this mesh came from, if any (for errors and for writing scenes back).
    pub source: Option<PathBuf>,
}

/// A light source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light; `intensity` in W/sr per channel.
    Point {
        /// Position, metres.
        position: Vec3,
        /// Radiant intensity, W/sr per channel.
        intensity: Vec3,
    },
    /// Distant light; `direction` is where the light travels (unit),
    /// `irradiance` in W/m^2 on a surface facing it.
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance on a surface facing the light, W/m^2 per channel.
        irradiance: Vec3,
    },
}

/// Edits of a light (the viewer's keys, panel and script, `animate`).
impl Light {
    /// Its strength: the largest channel of a point light's intensity (W/sr)
    /// or a directional light's irradiance (W/m^2).
    pub fn strength(&self) -> f32 {
        self.power().max_element()
    }

    /// What multiplies a light-link factor into irradiance: a point light's
    /// intensity (W/sr) or a directional light's irradiance (W/m^2), per channel.
    pub fn power(&self) -> Vec3 {
        match *self {
            Light::Point { intensity, .. } => intensity,
            Light::Directional { irradiance, .. } => irradiance,
        }
    }

    /// A point light moved by `delta` (metres); a directional light's
    /// direction offset by `delta` and renormalised (kept when the sum is zero).
    pub fn moved(self, delta: Vec3) -> Light {
        match self {
            Light::Point { position, intensity } => Light::Point { position: position + delta, intensity },
            Light::Directional { direction, irradiance } => {
                let d = (direction + delta).normalize_or_zero();
                Light::Directional { direction: if d == Vec3::ZERO { direction } else { d }, irradiance }
            }
        }
    }

    /// The light with its [`strength`](Light::strength) set to `value`, its
    /// colour kept (a black light becomes grey, all channels `value`).
    pub fn with_strength(self, value: f32) -> Light {
        let rescale = |c: Vec3| {
            let m = c.max_element();
            if m > 0.0 {
                c * (value / m)
            } else {
                Vec3::splat(value)
            }
        };
        match self {
            Light::Point { position, intensity } => Light::Point { position, intensity: rescale(intensity) },
            Light::Directional { direction, irradiance } => {
                Light::Directional { direction, irradiance: rescale(irradiance) }
            }
        }
    }
}

/// How many bounces the gather runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounces {
    /// Exactly this many bounces.
    Fixed(u32),
    /// Until the newest bounce (plus its estimated tail) adds less than the
    /// tolerance of the running total.
    Auto,
}

/// Which structure traces rays (`tracer` in the scene TOML, `--tracer`).
/// On the CPU path `bvh` and `kd` name the CPU structure (the others trace
/// with the BVH); on the GPU path they name the structure the GPU walks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TracerKind {
    /// The fastest the path has: the BVH on the CPU; on a GPU, hardware ray
    /// queries where the adapter has them, else the BVH.
    #[default]
    Auto,
    /// The 8-wide BVH with SIMD node tests (`crate::bvh`); on a GPU, the
    /// same tree walked with a short stack.
    Bvh,
    /// The kd-tree with ropes (`crate::kdtree`), on the CPU or the GPU.
    Kd,
    /// Hardware ray queries (GPU path, adapters with `EXPERIMENTAL_RAY_QUERY`;
    /// elsewhere an error on the GPU path, the BVH on the CPU path).
    #[serde(rename = "rq")]
    RayQuery,
}

impl std::str::FromStr for TracerKind {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<TracerKind> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(TracerKind::Auto),
            "bvh" => Ok(TracerKind::Bvh),
            "kd" => Ok(TracerKind::Kd),
            "rq" | "rayquery" | "ray-query" => Ok(TracerKind::RayQuery),
            _ => Err(crate::Error::Setting(format!("tracer \"{s}\": expected auto, bvh, kd or rq"))),
        }
    }
}

impl TracerKind {
    /// The setting's name ("auto", "bvh", "kd", "rq").
    pub fn name(self) -> &'static str {
        match self {
            TracerKind::Auto => "auto",
            TracerKind::Bvh => "bvh",
            TracerKind::Kd => "kd",
            TracerKind::RayQuery => "rq",
        }
    }

    /// The CPU structure this setting traces with: the kd-tree for `kd`,
    /// else the BVH.
    pub fn cpu(self) -> TracerKind {
        match self {
            TracerKind::Kd => TracerKind::Kd,
            _ => TracerKind::Bvh,
        }
    }
}

/// Which path computes links and bounces (`backend` in the scene TOML, `--backend`).
/// Also reachable as `crate::gpu::Backend`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// A hardware GPU when one exists, else the CPU path (a software
    /// rasterizer such as lavapipe is slower than the CPU path, so `auto`
    /// does not pick it).
    #[default]
    Auto,
    /// Any adapter, software ones included; an error if there is none.
    Gpu,
    /// The CPU path (rayon).
    Cpu,
}

impl std::str::FromStr for Backend {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Backend> {
        match s {
            "auto" => Ok(Backend::Auto),
            "gpu" => Ok(Backend::Gpu),
            "cpu" => Ok(Backend::Cpu),
            _ => Err(crate::Error::Setting(format!("backend \"{s}\": expected auto, gpu or cpu"))),
        }
    }
}

impl Backend {
    /// The setting's name ("auto", "gpu", "cpu").
    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Gpu => "gpu",
            Backend::Cpu => "cpu",
        }
    }
}

/// Solver settings (the scene file's `[settings]` table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Rays shot per vertex, `k*k` (a square number).
    pub rays_per_vertex: u32,
    /// How many bounces the gather runs.
    pub bounces: Bounces,
    /// Feature angle `alpha_f` of one-ring smoothing, degrees; 0 turns smoothing off.
    pub smoothing_angle_deg: f32,
    /// Seed of the direction set and per-vertex rotations.
    pub seed: u64,
    /// Where links and bounces are computed.
    pub backend: Backend,
    /// Which structure traces rays.
    pub tracer: TracerKind,
    /// Which optional terms of the solve are on (`off = [...]`; all on by default).
    pub terms: terms::Terms,
    /// Terms forced on (`on = [...]`; none by default): kept whatever a
    /// sample of their work says ([`terms::Terms::DECIDED`]).
    pub forced: terms::Terms,
    /// How coarse meshes are refined (`refine = "auto"` by default).
    pub refine: refine::RefineSettings,
    /// The near hits a vertex keeps, as a share of its link rays, in
    /// `(0, 1]` ([`crate::links::NearParams::max_share`]): lower traces
    /// fewer near-field rays where most rays land close by, with more
    /// noise in the near-field terms; 1 keeps every near hit.
    pub near_share: f32,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            rays_per_vertex: 256,
            bounces: Bounces::Auto,
            smoothing_angle_deg: 30.0,
            seed: 1,
            backend: Backend::Auto,
            tracer: TracerKind::Auto,
            terms: terms::Terms::ALL,
            forced: terms::Terms::NONE,
            refine: refine::RefineSettings::default(),
            near_share: crate::links::NearParams::default().max_share,
        }
    }
}

impl Settings {
    /// Checks ranges: rays a non-zero perfect square, finite non-negative angle.
    pub fn validate(&self) -> crate::Result<()> {
        let k = (self.rays_per_vertex as f64).sqrt().round() as u64;
        if self.rays_per_vertex == 0 || k * k != self.rays_per_vertex as u64 {
            return Err(crate::Error::Setting(format!(
                "rays_per_vertex = {} is not a non-zero square number (k*k)",
                self.rays_per_vertex
            )));
        }
        if !(self.smoothing_angle_deg.is_finite() && (0.0..=180.0).contains(&self.smoothing_angle_deg)) {
            return Err(crate::Error::Setting(format!(
                "smoothing_angle_deg = {} is not in [0, 180]",
                self.smoothing_angle_deg
            )));
        }
        if !(self.near_share > 0.0 && self.near_share <= 1.0) {
            return Err(crate::Error::Setting(format!("near_share = {} is not in (0, 1]", self.near_share)));
        }
        if self.bounces == Bounces::Fixed(0) {
            return Err(crate::Error::Setting("bounces must be at least 1 (or \"auto\")".into()));
        }
        self.refine.validate()
    }
}

/// Pinhole camera (used by renderers; stored so exported scenes keep it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position, metres.
    pub position: Vec3,
    /// The point looked at, metres.
    pub target: Vec3,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self { position: Vec3::new(0.0, 1.0, 3.5), target: Vec3::new(0.0, 1.0, 0.0), fov_deg: 40.0 }
    }
}

/// A whole scene as described, before preparation.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    /// Scene name (the scene file's stem, or the name given to a built-in scene or a `SceneBuilder`).
    pub name: String,
    /// Solver settings.
    pub settings: Settings,
    /// The file's camera; `None` where it has none (a bare OBJ, a glTF
    /// without cameras, a TOML without `[camera]`): renderers then frame the
    /// scene automatically (`crate::render::framing`).
    pub camera: Option<Camera>,
    /// The triangle meshes.
    pub meshes: Vec<MeshDesc>,
    /// The lights.
    pub lights: Vec<Light>,
    /// Sky light (`[sky]` in the scene file), if any (`crate::sky`).
    pub sky: Option<crate::sky::Sky>,
    /// Problems that were fixed up while loading (clamped albedo, missing MTL, ...),
    /// for the caller to show. Empty for built-in scenes.
    pub warnings: Vec<String>,
    /// What the loaders assumed where a file leaves it open (how an
    /// emission was read, `emission::note`), for the caller to show as
    /// notes. Empty for built-in scenes.
    pub notes: Vec<String>,
}

/// Loads a scene given a path to a `.toml` file (or a bare `.obj`, or a
/// `.gltf`/`.glb`, see `gltf`), or the name of a built-in scene.
pub fn load(name_or_path: &str) -> crate::Result<SceneDesc> {
    let path = std::path::Path::new(name_or_path);
    if path.exists() {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        return match ext.as_deref() {
            Some("obj") => file::load_bare_obj(path),
            Some("gltf" | "glb") => gltf::load_scene(path),
            _ => file::load_toml(path),
        };
    }
    if let Some(scene) = builtin::builtin(name_or_path) {
        return Ok(scene);
    }
    if path.extension().is_some() || name_or_path.contains('/') {
        return Err(crate::Error::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    Err(crate::Error::UnknownScene(name_or_path.to_string(), builtin::NAMES.join(", ")))
}

#[cfg(test)]
mod light_tests {
    use super::Light;
    use glam::Vec3;

    #[test]
    fn point_light_moves_and_keeps_its_intensity() {
        let l = Light::Point { position: Vec3::new(1.0, 2.0, 3.0), intensity: Vec3::new(2.0, 1.0, 0.5) };
        let m = l.moved(Vec3::new(0.5, -1.0, 0.0));
        assert_eq!(m, Light::Point { position: Vec3::new(1.5, 1.0, 3.0), intensity: Vec3::new(2.0, 1.0, 0.5) });
    }

    #[test]
    fn directional_light_turns_and_stays_unit() {
        let l = Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::ONE };
        let Light::Directional { direction, irradiance } = l.moved(Vec3::new(1.0, 0.0, 0.0)) else { panic!() };
        assert!((direction - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6, "{direction}");
        assert_eq!(irradiance, Vec3::ONE);
        // Offsetting by the opposite direction would leave no direction: it is kept.
        assert_eq!(l.moved(Vec3::Y), l);
    }

    #[test]
    fn strength_scales_the_colour() {
        let l = Light::Point { position: Vec3::ZERO, intensity: Vec3::new(4.0, 2.0, 1.0) };
        assert_eq!(l.strength(), 4.0);
        let s = l.with_strength(8.0);
        assert_eq!(s, Light::Point { position: Vec3::ZERO, intensity: Vec3::new(8.0, 4.0, 2.0) });
        assert_eq!(s.strength(), 8.0);
        let black = Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::ZERO };
        assert_eq!(black.strength(), 0.0);
        assert_eq!(
            black.with_strength(3.0),
            Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::splat(3.0) }
        );
    }
}
