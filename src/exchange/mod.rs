//! Light exchange (docs/DESIGN.md §4), by concept:
//!
//! - [`sources`]: light at the vertices before any bounce: point and
//!   directional lights through light links (exact at the vertices,
//!   one-ring oversampled as the bounce source), emissive surfaces by
//!   next-event estimation (emitter links), and the emitter groups as a
//!   control variate of the first bounce.
//! - [`near`]: the near field: one interface ([`near::NearTerm`]) for the
//!   radiance at the hit points of short link rays, with four terms
//!   (lights, emitters, sky, and a final gather for the later bounces).
//! - [`bounce`]: the bounce operator: the links' gather and the radiosity
//!   formula, the bounce loop on the CPU (the GPU's in `crate::gpu`),
//!   hidden vertices replaced as link targets, and the gradient-corrected
//!   radiosity the links read.
//! - [`denoise`]: the noise estimate of every vertex's `E_i` from its
//!   links, its calibration on the scene (the noise check), and the
//!   feature-aware, noise-aware one-ring smoothing.
//!
//! Units: per-vertex irradiance `E` in W/m^2 per RGB channel; radiosity
//! (exitant radiance of a Lambertian vertex) `B = rho / pi * E + M / pi`
//! in W/(m^2 sr) ([`bounce::operator::radiosity`]).

pub mod bounce;
pub mod denoise;
pub mod near;
pub mod sources;

pub use bounce::gather::{GatherParams, GatherResult};
#[cfg(any(test, feature = "internals"))]
pub use bounce::gather::gather;
pub use bounce::hidden::HiddenParams;
pub use bounce::reconstruct::Reconstruction;
pub use denoise::noise::NoiseParams;
pub use denoise::noise_check::NoiseCheck;
pub use denoise::smooth::{smooth, smooth_adaptive, SmoothMode, SmoothParams};
pub use near::{
    NearEmitterParams, NearEmitters, NearField, NearGather, NearGatherParams, NearLight, NearSky, NearSkyParams,
};
pub use sources::emitter_cv::EmitterCv;
pub use sources::emitter_links::{EmitterLinkParams, EmitterLinks};
pub use sources::light_links::{BounceSource, LightLinkParams, LightLinks};
