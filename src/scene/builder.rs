//! Scenes built in code: meshes from position and index buffers, lights,
//! sky, camera and settings, checked as loaded scenes are
//! ([`super::prep::check_mesh`]: the same errors, naming the mesh).
//!
//! Units as in scene files: positions in metres (after the mesh's
//! transform), albedo in [0, 1) per channel, emission given as emitted
//! *radiance* `L` in W/(m^2 sr) and stored as exitance `M = pi L`
//! ([`super::emission::exitance`]). Every input position keeps its index,
//! so results read back per input vertex
//! ([`super::prep::PreparedScene::on_input`]) are in the caller's order.
//!
//! ```
//! use glam::Vec3;
//! use linkgi::scene::builder::{MeshInput, SceneBuilder};
//! use linkgi::scene::Light;
//! let floor = [Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(-1.0, 0.0, -1.0)];
//! let scene = SceneBuilder::new("plate")
//!     .mesh(MeshInput::new("floor", &floor, &[0, 1, 2, 0, 2, 3]).albedo(Vec3::splat(0.5)))
//!     .light(Light::Point { position: Vec3::new(0.0, 1.0, 0.0), intensity: Vec3::ONE })
//!     .build()
//!     .unwrap();
//! assert_eq!(scene.meshes[0].positions.len(), 4);
//! ```

use super::{Camera, Light, Material, MeshDesc, SceneDesc, Settings, Transform};
use crate::sky::Sky;
use glam::Vec3;

/// One mesh given as buffers: `indices` three per triangle,
/// counter-clockwise seen from the lit side.
#[derive(Clone, Debug)]
pub struct MeshInput<'a> {
    name: &'a str,
    positions: &'a [Vec3],
    indices: &'a [u32],
    albedo: Vec3,
    radiance: Vec3,
    vertex_albedo: Option<&'a [Vec3]>,
    crease_angle_deg: f32,
    transform: Transform,
    dynamic: bool,
}

impl<'a> MeshInput<'a> {
    /// A grey (albedo 0.5), non-emitting, static mesh; vertices split where
    /// face normals differ by more than 30 degrees.
    pub fn new(name: &'a str, positions: &'a [Vec3], indices: &'a [u32]) -> Self {
        MeshInput {
            name,
            positions,
            indices,
            albedo: Vec3::splat(0.5),
            radiance: Vec3::ZERO,
            vertex_albedo: None,
            crease_angle_deg: 30.0,
            transform: Transform::default(),
            dynamic: false,
        }
    }
    /// Diffuse albedo of the whole mesh per channel, in [0, 1).
    pub fn albedo(mut self, albedo: Vec3) -> Self {
        self.albedo = albedo;
        self
    }
    /// Emitted radiance of the whole mesh, W/(m^2 sr) per channel (front side).
    pub fn emission_radiance(mut self, radiance: Vec3) -> Self {
        self.radiance = radiance;
        self
    }
    /// Albedo per position (same length as the positions), instead of [`Self::albedo`].
    pub fn vertex_albedo(mut self, albedo: &'a [Vec3]) -> Self {
        self.vertex_albedo = Some(albedo);
        self
    }
    /// Feature angle of the crease split, degrees.
    pub fn crease_angle(mut self, degrees: f32) -> Self {
        self.crease_angle_deg = degrees;
        self
    }
    /// Object-to-world transform.
    pub fn transform(mut self, transform: Transform) -> Self {
        self.transform = transform;
        self
    }
    /// The mesh may deform (the engine refits it; refinement leaves it alone).
    pub fn dynamic(mut self, dynamic: bool) -> Self {
        self.dynamic = dynamic;
        self
    }

    fn desc(&self) -> crate::Result<MeshDesc> {
        if self.indices.len() % 3 != 0 {
            return Err(crate::Error::Geometry {
                source_name: self.name.to_string(),
                line: None,
                message: format!("{} indices: not three per triangle", self.indices.len()),
            });
        }
        let triangles: Vec<[u32; 3]> = self.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mesh = MeshDesc {
            name: self.name.to_string(),
            positions: self.positions.to_vec(),
            triangle_material: vec![0; triangles.len()],
            triangles,
            materials: vec![Material {
                name: self.name.to_string(),
                albedo: self.albedo,
                emission: super::emission::exitance(self.radiance),
            }],
            vertex_albedo: self.vertex_albedo.map(|a| a.to_vec()),
            vertex_emission: None,
            textures: None,
            crease_angle_deg: self.crease_angle_deg,
            transform: self.transform,
            dynamic: self.dynamic,
            deform: Vec::new(),
            source: None,
        };
        super::prep::check_mesh(&mesh)?;
        Ok(mesh)
    }
}

/// A scene assembled in code ([`SceneBuilder::build`] checks it).
#[derive(Clone, Debug)]
pub struct SceneBuilder<'a> {
    name: String,
    settings: Settings,
    camera: Option<Camera>,
    meshes: Vec<MeshInput<'a>>,
    lights: Vec<Light>,
    sky: Option<Sky>,
}

impl<'a> SceneBuilder<'a> {
    /// An empty scene with default settings and no camera (renderers frame it).
    pub fn new(name: &str) -> Self {
        SceneBuilder {
            name: name.to_string(),
            settings: Settings::default(),
            camera: None,
            meshes: Vec::new(),
            lights: Vec::new(),
            sky: None,
        }
    }
    /// Sets the solver settings (default [`Settings::default`]).
    pub fn settings(mut self, settings: Settings) -> Self {
        self.settings = settings;
        self
    }
    /// Sets the camera (none by default: renderers frame the scene automatically).
    pub fn camera(mut self, camera: Camera) -> Self {
        self.camera = Some(camera);
        self
    }
    /// Adds a mesh.
    pub fn mesh(mut self, mesh: MeshInput<'a>) -> Self {
        self.meshes.push(mesh);
        self
    }
    /// Adds a light.
    pub fn light(mut self, light: Light) -> Self {
        self.lights.push(light);
        self
    }
    /// Sets the sky (none by default).
    pub fn sky(mut self, sky: Sky) -> Self {
        self.sky = Some(sky);
        self
    }

    /// The scene description, or the first problem found: settings out of
    /// range, a mesh that preparation would refuse (named), no triangles.
    pub fn build(self) -> crate::Result<SceneDesc> {
        self.settings.validate()?;
        let meshes = self.meshes.iter().map(|m| m.desc()).collect::<crate::Result<Vec<_>>>()?;
        if meshes.iter().all(|m| m.triangles.is_empty()) {
            return Err(crate::Error::EmptyScene(self.name));
        }
        Ok(SceneDesc {
            name: self.name,
            settings: self.settings,
            camera: self.camera,
            meshes,
            lights: self.lights,
            sky: self.sky,
            warnings: Vec::new(),
            notes: Vec::new(),
        })
    }
}
