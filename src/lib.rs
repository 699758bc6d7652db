//! linkgi: explicit-visibility vertex link radiosity (docs/DESIGN.md):
//! diffuse global illumination at a scene's vertices for moving lights and
//! deforming meshes.
//!
//! Pipeline: [`scene`] (load, build in code, refine, prepare) → [`bvh`]
//! (8-wide BVH, the CPU tracer; [`kdtree`] with ropes for the GPU shader)
//! → [`sampling`] (cosine ray directions) → [`links`] (vertex links) →
//! [`exchange`] (light links, emitters, sky, bounces, near-field terms,
//! smoothing), driven by [`solver`]; [`engine`] runs it in the background,
//! [`render`] draws it.
//!
//! The whole loop, with a scene built in code: solve, read the irradiance
//! on the caller's own vertices, move the light, read again.
//!
//! ```
//! use glam::Vec3;
//! use linkgi::scene::builder::{MeshInput, SceneBuilder};
//! use linkgi::scene::{prep, Light};
//! use linkgi::solver::{SolveParams, Solver};
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
//! let prepared = prep::prepare(&scene)?;
//! let mut solver = Solver::new(prepared, SolveParams::from_settings(&scene.settings), &|_, _| {});
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

// The CLI's harnesses: the accuracy sweep and the benchmarks (the
// integration tests and benches, built with the default features, use them).
#[cfg(feature = "cli")]
pub mod accuracy;
#[cfg(feature = "cli")]
pub mod bench;
pub mod bvh;
pub mod csr;
pub mod engine;
pub mod error;
pub mod exchange;
pub mod export;
pub mod gpu;
pub mod kdtree;
pub mod links;
pub mod reference;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod sky;
pub mod solver;
pub mod trace;

pub use error::{Error, Result};
