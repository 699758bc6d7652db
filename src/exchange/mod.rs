//! Light exchange (docs/DESIGN.md §4): direct light through light links, exact
//! at the vertices and one-ring oversampled as the bounce source
//! ([`light_links`]), emissive surfaces' direct light by next-event
//! estimation ([`emitter_links`], which also serve as a control variate of
//! the light emitters reflect, [`emitter_cv`]), exact direct light at the hit points of
//! short link rays ([`near_field`], and the emitters' and sky's there: [`near_emitters`], [`near_sky`]; the later bounces' by a final gather
//! from the hit, [`near_gather`]), bounces gathered over the vertex links ([`mod@gather`]),
//! hidden vertices' radiosity replaced as link targets by their visible
//! neighbours' ([`hidden`]), a noise estimate of every vertex's `E_i` from
//! its links ([`noise`]), calibrated on the scene by a second estimate at a
//! sample of vertices ([`noise_check`]), and feature-aware, noise-aware one-ring smoothing
//! ([`mod@smooth`]).
//!
//! Units: per-vertex irradiance `E` in W/m^2 per RGB channel; radiosity
//! (exitant radiance of a Lambertian vertex) `B = rho / pi * E` in
//! W/(m^2 sr).

pub mod emitter_cv;
pub mod emitter_links;
pub mod gather;
pub mod hidden;
pub mod light_links;
pub mod near_emitters;
pub mod near_field;
pub mod near_gather;
pub mod near_sky;
pub mod noise;
pub mod noise_check;
pub mod reconstruct;
pub mod smooth;

pub use emitter_cv::EmitterCv;
pub use emitter_links::{EmitterLinkParams, EmitterLinks};
pub use gather::{gather, GatherParams, GatherResult};
pub use hidden::HiddenParams;
pub use light_links::{BounceSource, LightLinkParams, LightLinks};
pub use near_emitters::{NearEmitterParams, NearEmitters};
pub use near_field::NearLight;
pub use near_gather::{NearGather, NearGatherParams};
pub use near_sky::{NearSky, NearSkyParams};
pub use noise::NoiseParams;
pub use noise_check::NoiseCheck;
pub use reconstruct::Reconstruction;
pub use smooth::{smooth, smooth_adaptive, SmoothMode, SmoothParams};
