//! Light exchange (docs/DESIGN.md §4): direct light through light links with
//! one-ring oversampled visibility ([`light_links`]), bounces gathered over
//! the vertex links ([`gather`]), feature-aware one-ring smoothing
//! ([`smooth`]).
//!
//! Units: per-vertex irradiance `E` in W/m^2 per RGB channel; radiosity
//! (exitant radiance of a Lambertian vertex) `B = rho / pi * E` in
//! W/(m^2 sr).

pub mod gather;
pub mod light_links;
pub mod smooth;

pub use gather::{gather, GatherParams, GatherResult};
pub use light_links::{LightLinkParams, LightLinks};
pub use smooth::smooth;
