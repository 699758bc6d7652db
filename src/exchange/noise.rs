//! Noise estimate of the gathered indirect irradiance `E_i` per vertex,
//! from the links and the radiosity they carry (input of the noise-aware
//! smoothing, [`super::smooth`]).
//!
//! In the fixed point of the gather, `E_i(x) = sum_j w_j B(t_j)` with the
//! total radiosity `B = rho/pi * (E_src + E_i) + M_e/pi` (W/(m^2 sr); `E_src` the
//! direct irradiance the bounces start from, `M_e` emitted exitance). Ray `k` of `x` stands for the
//! estimate `X_k = pi * L(hit_k)` with `L(hit) = sum_c beta_c B(c)` over the
//! hit triangle's corners `c` (barycentrics `beta_c`), and
//! `E_i = mean_k X_k`; its link weights are `beta_c * pi / n_C`. The merged
//! links no longer say which ray a link came from, but they give an upper
//! bound of the second moment (Jensen over the corners):
//!
//! ```text
//! mean_k X_k^2 <= pi * sum_j w_j B(t_j)^2        (rays that left the scene give X_k = 0)
//! var_iid(x)    = max(0, pi sum_j w_j B_j^2 - (sum_j w_j B_j)^2) / n_C
//! ```
//!
//! `var_iid` is the variance of `E_i(x)` if the `n_C` rays were drawn
//! independently, in (W/m^2)^2 per channel. The directions are stratified
//! (a `k x k` grid), which removes most of that variance wherever the
//! incoming radiance is smooth; what stays comes from the strata cut by
//! edges (visibility, shadows), and its share falls with the rays. The
//! estimate is therefore
//!
//! ```text
//! var(x) = var_iid(x) * min(1, scale * (reference_rays / n_C)^exponent)
//! ```
//!
//! Calibration ([`NoiseParams`]): the actual variance is measured as half
//! the squared difference of two solves with different seeds (sums over
//! vertices and channels), divided by the summed `var_iid`:
//!
//! | rays | 16 | 64 | 256 | 1024 |
//! |---|---|---|---|---|
//! | cornell | 0.786 | 0.550 | 0.294 | 0.104 |
//! | tearoom | 0.436 | 0.348 | 0.137 | 0.046 |
//! | model: `min(1, 0.2 (256/n)^0.75)` | 1 | 0.57 | 0.20 | 0.071 |
//!
//! (Between a stratified estimate's `n^-3/2` for edges and `n^-2` for smooth
//! integrands, against `n^-1` for independent rays: exponent 0.5 to 1.)
//! The model is within a factor of 2.3 of both scenes at every count;
//! `tests/accuracy.rs` holds it to a factor of 2.5 on the Cornell box.

use crate::links::Links;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Calibration of the noise estimate (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseParams {
    /// Actual variance of `E_i` over the independent-ray estimate at
    /// `reference_rays` rays per vertex (unitless).
    pub scale: f32,
    /// Rays per vertex at which `scale` was measured.
    pub reference_rays: u32,
    /// How the ratio falls with the rays: `scale * (reference_rays / n_C)^exponent`, at most 1.
    pub exponent: f32,
}

impl Default for NoiseParams {
    fn default() -> Self {
        Self { scale: 0.2, reference_rays: 256, exponent: 0.75 }
    }
}

/// Variance of every vertex's `E_i`, (W/m^2)^2 per channel, from `links`
/// shot at `rays_per_vertex`, the per-vertex `albedo` and emitted exitance
/// `emission` (W/m^2, may be empty), the direct
/// irradiance the bounces started from and the gathered `E_i` (W/m^2).
pub fn variance(
    links: &Links,
    albedo: &[Vec3],
    emission: &[Vec3],
    e_source: &[Vec3],
    e_indirect: &[Vec3],
    rays_per_vertex: u32,
    params: &NoiseParams,
) -> Vec<Vec3> {
    let b: Vec<Vec3> = albedo
        .iter()
        .zip(e_source.iter().zip(e_indirect))
        .enumerate()
        .map(|(v, (r, (s, i)))| *r / PI * (*s + *i) + emission.get(v).map_or(Vec3::ZERO, |m| *m / PI))
        .collect();
    let n_c = rays_per_vertex.max(1) as f32;
    let factor = (params.scale * (params.reference_rays as f32 / n_c).powf(params.exponent)).min(1.0) / n_c;
    (0..links.vertex_count())
        .into_par_iter()
        .map(|v| {
            let (targets, weights) = links.group(v);
            let (mut m1, mut m2) = (Vec3::ZERO, Vec3::ZERO);
            for (&t, w) in targets.iter().zip(weights) {
                let (bt, w) = (b[t as usize], w.to_f32());
                m1 += w * bt;
                m2 += w * bt * bt;
            }
            (PI * m2 - m1 * m1).max(Vec3::ZERO) * factor
        })
        .collect()
}
