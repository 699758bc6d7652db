//! Light at the vertices before any bounce: the lights' direct light
//! through light links ([`light_links`]), the emissive surfaces' by
//! next-event estimation ([`emitter_links`]), and the emitter groups as a
//! control variate of the light the first bounce reflects
//! ([`emitter_cv`]). Irradiance in W/m^2.

pub mod emitter_cv;
pub(crate) mod emitter_geometry;
pub mod emitter_links;
mod emitter_rays;
pub mod light_links;
