//! Denoising the gathered `E_i`: a noise estimate of every vertex from its
//! links ([`noise`]), calibrated on the scene by a second estimate at a
//! sample of vertices ([`noise_check`]), and the feature-aware,
//! noise-aware one-ring smoothing ([`mod@smooth`]). Irradiance in W/m^2.

pub mod noise;
pub mod noise_check;
pub mod smooth;
