//! linkgi: explicit-visibility vertex link radiosity (docs/DESIGN.md):
//! diffuse global illumination at a scene's vertices for moving lights and
//! deforming meshes.
//!
//! The API, all at the crate root:
//!
//! - **Scenes**: [`load_scene`] reads a `.toml`, `.obj`, `.gltf` or `.glb`
//!   file or a built-in name into a [`SceneDesc`] ([`MeshDesc`],
//!   [`Material`], [`Light`], [`Sky`], [`Camera`], [`Settings`]);
//!   [`SceneBuilder`] builds one from the caller's own arrays; [`prepare`]
//!   turns it into the lighting mesh, a [`PreparedScene`].
//! - **Solving**: [`solve`] prepares a scene, refines its coarse meshes
//!   where the light needs it and solves it, as `linkgi solve` does. A
//!   [`Solver`] holds the scene, its ray tracer and links ([`SolveParams`]
//!   and its presets, the stages' parameters in [`params`], [`Terms`],
//!   [`TracerKind`], [`Backend`], [`Compute`]); [`Solver::solve`] gives a
//!   [`Solution`] (irradiance per lighting-mesh vertex, W/m^2;
//!   [`export_solution`] writes it), [`Solver::stats`] its figures
//!   ([`SolveStats`], [`stats`]). [`Engine`] runs a solver on its own
//!   thread and takes [`Change`]s (lights moved, meshes deformed) while the
//!   caller draws the newest [`GiResult`].
//! - **Pictures**: [`Renderer`] draws a [`Frame`] into an [`HdrImage`];
//!   [`write_png`] and [`write_exr`] save it.
//!
//! Inside, the pipeline is: scene (load, refine, prepare) → tracer (an
//! 8-wide BVH on the CPU; a BVH walk, a rope kd-tree walk or ray queries on
//! the GPU) → cosine ray directions → vertex links → light links,
//! emitters, sky, bounces, near-field terms and smoothing (docs/DESIGN.md).
//!
//! The whole loop, with a scene built in code: solve, read the irradiance
//! on the caller's own vertices, move the light, read again.
//!
//! ```
//! use glam::Vec3;
//! use linkgi::{prepare, Light, MeshInput, SceneBuilder, SolveParams, Solver};
//!
//! // A floor and a back wall, 4 x 4 quads each, and a point light (W/sr).
//! let (mut positions, mut indices) = (Vec::new(), Vec::new());
//! for (origin, u, v) in [
//!     (Vec3::new(-1.0, 0.0, 1.0), Vec3::X * 2.0, Vec3::Z * -2.0),
//!     (Vec3::new(-1.0, 0.0, -1.0), Vec3::X * 2.0, Vec3::Y * 2.0),
//! ] {
//!     let base = positions.len() as u32;
//!     for j in 0..=4 {
//!         for i in 0..=4 {
//!             positions.push(origin + u * (i as f32 / 4.0) + v * (j as f32 / 4.0));
//!         }
//!     }
//!     let at = |i: u32, j: u32| base + j * 5 + i;
//!     for j in 0..4 {
//!         for i in 0..4 {
//!             indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
//!         }
//!     }
//! }
//! let light = Light::Point { position: Vec3::new(0.0, 1.0, 0.5), intensity: Vec3::splat(2.0) };
//! let scene = SceneBuilder::new("corner")
//!     .mesh(MeshInput::new("walls", &positions, &indices).albedo(Vec3::splat(0.6)))
//!     .light(light)
//!     .build()?;
//! let prepared = prepare(&scene)?;
//! let mut solver = Solver::new(prepared, SolveParams::from_settings(&scene.settings), &|_, _| {})?;
//! let before = solver.solve();
//! // Indirect irradiance (W/m^2) at the caller's vertex 12 (the floor's middle).
//! let e = solver.scene().on_input(0, &before.e_indirect)[12].unwrap();
//! assert!(e.x > 0.0 && e.is_finite());
//!
//! // Move the light toward the wall: only its light links are traced again.
//! solver.set_lights(vec![Light::Point { position: Vec3::new(0.0, 1.0, -0.5), intensity: Vec3::splat(2.0) }]);
//! let after = solver.solve();
//! let e2 = solver.scene().on_input(0, &after.e_indirect)[12].unwrap();
//! assert_ne!(e, e2);
//! # Ok::<(), linkgi::Error>(())
//! ```

#![warn(missing_docs)]

/// Methods the API does not offer but the integration tests and benches
/// call: `pub(crate)`, or `pub` and hidden from the docs with the
/// `internals` feature. Some are read only by the CLI's harnesses, so
/// without the `cli` feature they are allowed to be unused.
macro_rules! internal {
    ($($(#[$attr:meta])* pub fn $name:ident ($($args:tt)*) $(-> $ret:ty)? $body:block)*) => {$(
        $(#[$attr])*
        #[cfg(feature = "internals")]
        #[doc(hidden)]
        pub fn $name($($args)*) $(-> $ret)? $body
        $(#[$attr])*
        #[cfg(not(feature = "internals"))]
        #[cfg_attr(not(feature = "cli"), allow(dead_code))]
        pub(crate) fn $name($($args)*) $(-> $ret)? $body
    )*};
}

/// A struct of the API whose fields other items trust: the fields are
/// `pub(crate)` (read through methods), or `pub` with the `internals`
/// feature for the integration tests and benches.
macro_rules! internal_fields {
    ($(#[$attr:meta])* pub struct $name:ident { $($(#[$fattr:meta])* pub $field:ident : $ty:ty),* $(,)? }) => {
        $(#[$attr])*
        #[cfg(feature = "internals")]
        pub struct $name { $($(#[$fattr])* pub $field: $ty),* }
        $(#[$attr])*
        #[cfg(not(feature = "internals"))]
        pub struct $name { $($(#[$fattr])* pub(crate) $field: $ty),* }
    };
}

/// Declares the internal modules: private to the crate, or public but
/// hidden from the docs with the `internals` feature (the integration
/// tests' and benches' only way in; it is not part of the API).
macro_rules! internal_modules {
    ($($(#[$attr:meta])* $name:ident),* $(,)?) => {$(
        $(#[$attr])*
        #[cfg(feature = "internals")]
        #[doc(hidden)]
        pub mod $name;
        $(#[$attr])*
        #[cfg(not(feature = "internals"))]
        mod $name;
    )*};
}

internal_modules! {
    // The CLI's harnesses: the accuracy sweep, the benchmarks and the
    // Monte Carlo reference they score against.
    #[cfg(feature = "cli")]
    accuracy,
    #[cfg(feature = "cli")]
    bench,
    #[cfg(any(feature = "cli", feature = "internals"))]
    reference,
    bvh,
    csr,
    engine,
    error,
    exchange,
    export,
    gpu,
    kdtree,
    links,
    render,
    sampling,
    scene,
    sky,
    solver,
    trace,
}

#[cfg(feature = "cli")]
mod cli;

/// The `linkgi` command line (feature `cli`): parses the process's
/// arguments and runs the subcommand; the binary's whole `main`.
#[cfg(feature = "cli")]
pub fn run_cli() -> anyhow::Result<()> {
    cli::run()
}

pub use engine::{Adopted, Change, Counters, Engine, EngineParams, GiResult};
pub use error::{Error, Result};
pub use export::export as export_solution;
pub use gpu::GpuDevice;
pub use render::exposure::auto_exposure;
pub use render::{write_exr, write_png, Frame, HdrImage, RenderParams, RenderStats, Renderer, View};
pub use scene::builder::{MeshInput, SceneBuilder};
pub use scene::deform::{deform_scene, has_deformers, Deform, DeformKind};
pub use scene::file::write_scene;
pub use scene::load as load_scene;
pub use scene::prep::{prepare, Interpolate, PreparedScene};
pub use scene::refine::{RefineMode, RefineSettings};
pub use scene::terms::Terms;
pub use scene::texture::{CornerTextures, MeshTextures, Sampler, Texture, TextureMap, Wrap};
pub use scene::{Backend, Bounces, Camera, Light, Material, MeshDesc, SceneDesc, Settings, TracerKind, Transform};
pub use sky::{EnvMap, Portal, Sky, SkyModel};
pub use solver::adaptive::{solve, Refined};
pub use solver::{Compute, DeformStats, GpuCompute, Preview, Solution, SolveParams, SolveStats, Solver};

/// The scene's own camera, or where it has none (a bare OBJ, a glTF
/// without cameras) one framed automatically: outside the scene looking
/// in, or inside an enclosed room looking across it.
pub fn camera_for(scene: &PreparedScene, camera: Option<Camera>) -> Camera {
    render::framing::camera_or_framed(camera, scene, None).0
}

/// Statistics of the stages a [`SolveStats`] or [`DeformStats`] reports.
pub mod stats {
    pub use crate::bvh::BvhStats;
    pub use crate::exchange::GatherResult;
    pub use crate::kdtree::KdStats;
    pub use crate::links::{LinkStats, ReshootStats};
    pub use crate::solver::adaptive::Round;
}

/// The stages' parameters that [`SolveParams`] gathers, each with its
/// documented defaults (a `DEFAULT` const) and trade-offs.
pub mod params {
    pub use crate::bvh::BvhBuildParams;
    pub use crate::exchange::{
        BounceSource, EmitterLinkParams, GatherParams, HiddenParams, LightLinkParams, NearEmitterParams,
        NearGatherParams, NearSkyParams, NoiseParams, SmoothMode, SmoothParams,
    };
    pub use crate::gpu::{DeviceShare, ScheduleParams};
    pub use crate::kdtree::KdBuildParams;
    pub use crate::links::{LinkParams, NearParams};
    pub use crate::sky::{PortalParams, SkyRefineParams};
}
