//! linkgi: explicit-visibility vertex link radiosity (docs/DESIGN.md).
//!
//! Pipeline: [`scene`] (load and prepare) → [`kdtree`] (SAH kd-tree with
//! ropes) → [`sampling`] (cosine ray directions) → [`links`] (vertex links)
//! → [`exchange`] (light links, bounces, smoothing), driven by [`solver`].

pub mod accuracy;
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
