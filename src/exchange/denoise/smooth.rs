//! Feature-aware, noise-aware smoothing of `E_i` over one-rings
//! (docs/DESIGN.md §4). Units follow the input: irradiance in W/m^2, variances
//! in (W/m^2)^2.
//!
//! Neighbours: `N'(v)` is the one-ring without neighbours whose normal
//! differs by more than the feature angle (`n_v . n_u > cos alpha_f`), `k`
//! its size; a feature angle of 0 turns smoothing off.
//!
//! [`smooth`] (the fixed filter, [`SmoothMode::Uniform`]):
//! `E_s(v) = (E(v) + sum_{u in N'(v)} E(u)) / (k + 1)`.
//!
//! [`smooth_adaptive`] ([`SmoothMode::Adaptive`], the default) weighs the
//! neighbours by `beta_v` in `[0, 1]`:
//! `E_s(v) = (E(v) + beta_v sum_{u in N'(v)} E(u)) / (1 + beta_v k)`.
//! With `E(u) = T(u) + n_u` (truth plus noise of variance `s_u^2`, the
//! noise estimate of [`crate::exchange::denoise::noise`]) and the neighbours' mean `M(v)`
//! off the truth at `v` by `b_v = mean_{N'} T - T(v)`, the expected squared
//! error of `E_s(v)` is `(s^2 (1 + beta^2 k) + beta^2 k^2 b^2) / (1 + beta k)^2`
//! (neighbours' noise taken independent and as large as `v`'s). It is
//! smallest at
//!
//! ```text
//! beta_v = s_v^2 / (s_v^2 + k b_v^2)
//! ```
//!
//! (a linear minimum-mean-square-error blend, as a Wiener or Lee filter).
//! The solver gives the filter the noise variance averaged over the
//! feature ring ([`crate::solver::Solver::noise_variance`]): a vertex's
//! own estimate `var_iid` is computed from its own links and radiosity and
//! is correlated with its own noise (an `E(v)` drawn high tends to come
//! with a larger estimate, so it was pulled toward its neighbours more
//! than one drawn low: a bias toward dark, -1.7% on the tearoom at 64
//! rays against -0.7% unsmoothed; pooled, -0.9%, and 5.01 -> 4.84%).
//! `b_v^2` is not known; with `D_v = M(v) - E(v)`, `E[D_v^2] = b_v^2 +
//! s_v^2 (1 + 1/k)`, so `b_v^2` is estimated as `max(0, D^2 - s^2 (1 +
//! 1/k))` averaged over `v` and `N'(v)` (the bias varies slowly; one
//! vertex's `D^2` alone is too noisy). Variances and `D^2` are summed over
//! the three channels, so one `beta_v` serves all channels (no colour
//! shifts). Where noise dominates, `beta -> 1`: today's one-ring average.
//! As rays grow, `s^2 -> 0` and `beta -> 0`: the filter's bias vanishes and
//! the error keeps falling with the rays.
//!
//! Measured (relative RMSE of `E_i` against the reference path tracer,
//! reference noise removed; auto bounces, feature angle 30 degrees;
//! off / fixed average / adaptive in 2 passes, the default):
//!
//! | rays | cornell | tearoom |
//! |---|---|---|
//! | 16 | 0.371 / 0.211 / 0.187 | 0.291 / 0.210 / 0.191 |
//! | 64 | 0.163 / 0.103 / 0.093 | 0.110 / 0.114 / 0.090 |
//! | 256 | 0.064 / 0.061 / 0.042 | 0.056 / 0.094 / 0.051 |
//! | 1024 | 0.0197 / 0.0545 / 0.0183 | 0.0445 / 0.0922 / 0.0445 |
//!
//! One pass gives 0.101 / 0.046 / 0.0176 on the Cornell box at 64 / 256 /
//! 1024 rays and 0.088 / 0.051 / 0.0443 on the tearoom, three passes
//! 0.093 / 0.041 / 0.0190 and 0.093 / 0.052 / 0.0447. Local smoothing
//! cannot do much more at few rays: every vertex shoots the same direction
//! set turned by one of a few interleaved rotations, so the noise of
//! neighbours with the same rotation is alike, and averaging over a wider
//! area adds no new directions (the fixed average lowers the noise seen
//! between two seeds to 0.52 of it in one pass, 0.46 in two, 0.41 in four,
//! where independent noise over a one-ring of six would give 0.38).

//! The sky's direct light `E_sky` ([`crate::sky`]) is estimated from the
//! same rays and is as noisy where a vertex sees the sky through a small
//! opening; it is smoothed by the same filter ([`SmoothParams::sky`]), with
//! the variance of its own samples pooled over the ring
//! ([`pooled_variance`]) times the noise model's stratification ratio. A
//! vertex that sees all of a uniform sky, or none, has variance 0 and
//! keeps its value. Measured on `window` (16384 reference paths, total
//! relative RMSE; `cargo test --release --test measured -- --ignored sky_smoothing_lowers_window_error`,
//! `--off sky_smoothing` without, portals off; now 64 rays 5.90 -> 5.19%,
//! 256 rays 2.043 -> 2.037%, `E_sky` 8.40 -> 7.62%):
//! 256 rays 4.13% -> 3.89%, and with the room's grid refined to 0.125 m
//! 11.6 / 4.86 / 2.04% -> 7.8 / 3.86 / 1.84% at 64 / 256 / 1024 rays.

use crate::scene::prep::Csr;
use glam::Vec3;
use rayon::prelude::*;

/// Parameters of the smoothing of `E_i` (the feature angle is
/// [`crate::solver::SolveParams::smoothing_angle_deg`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothParams {
    /// Noise-aware weights (default) or the fixed one-ring average
    /// (cheaper, blurs edges of light the noise estimate would keep).
    pub mode: SmoothMode,
    /// Passes of the adaptive filter: each pass re-estimates the bias from
    /// the smoothed values and carries the noise variance through the
    /// weights (neighbours taken independent), so a second pass widens the
    /// support to the two-ring only where noise is still large.
    pub passes: u32,
    /// Calibration of the noise estimate (`crate::exchange::denoise::noise`).
    pub noise: crate::exchange::denoise::noise::NoiseParams,
}

impl SmoothParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: SmoothParams = Self {
        mode: SmoothMode::Adaptive,
        passes: 2,
        noise: crate::exchange::denoise::noise::NoiseParams::DEFAULT,
    };
}

impl Default for SmoothParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Which filter smooths `E_i`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SmoothMode {
    /// Neighbour weight from the estimated noise (`smooth_adaptive`).
    #[default]
    Adaptive,
    /// The fixed one-ring average (`smooth`).
    Uniform,
}

/// The neighbours of `v` inside the feature angle (`cos_f`: its cosine).
fn feature_ring<'a>(v: usize, rings: &'a Csr, normals: &'a [Vec3], cos_f: f32) -> impl Iterator<Item = usize> + 'a {
    rings.row(v).iter().map(|&u| u as usize).filter(move |&u| normals[v].dot(normals[u]) > cos_f)
}

/// Smooths `values` over one-rings with the fixed average; `angle_deg = 0`
/// returns them unchanged.
pub fn smooth(values: &[Vec3], rings: &Csr, normals: &[Vec3], angle_deg: f32) -> Vec<Vec3> {
    if angle_deg <= 0.0 {
        return values.to_vec();
    }
    let cos_f = angle_deg.to_radians().cos();
    (0..values.len())
        .into_par_iter()
        .map(|v| {
            let mut sum = values[v];
            let mut count = 1.0f32;
            for u in feature_ring(v, rings, normals, cos_f) {
                sum += values[u];
                count += 1.0;
            }
            sum / count
        })
        .collect()
}

/// Smooths `values` with the noise-aware weights of the module doc, in
/// `passes` passes; `variance[v]` is the noise variance of `values[v]` per
/// channel. `angle_deg = 0` returns the values unchanged.
pub fn smooth_adaptive(
    values: &[Vec3],
    variance: &[Vec3],
    rings: &Csr,
    normals: &[Vec3],
    angle_deg: f32,
    passes: u32,
) -> Vec<Vec3> {
    let mut values = values.to_vec();
    let mut variance = variance.to_vec();
    let cos_f = angle_deg.to_radians().cos();
    for _ in 0..passes {
        let Some(beta) = adaptive_weights(&values, &variance, rings, normals, angle_deg) else { break };
        let next: Vec<(Vec3, Vec3)> = (0..values.len())
            .into_par_iter()
            .map(|v| {
                let (mut sum, mut var, mut k) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
                for u in feature_ring(v, rings, normals, cos_f) {
                    sum += values[u];
                    var += variance[u];
                    k += 1.0;
                }
                let (b, w) = (beta[v], 1.0 + beta[v] * k);
                ((values[v] + b * sum) / w, (variance[v] + b * b * var) / (w * w))
            })
            .collect();
        (values, variance) = next.into_iter().unzip();
    }
    values
}

/// The variance of each vertex's mean of `rays` independent samples, pooled
/// over its feature ring, from the samples' means `mean` and second moments
/// `second` (per channel): `(avg_N M2 - (avg_N mean)^2) / rays` with `avg_N`
/// the average over `v` and `N'(v)`. Pooling keeps a vertex whose rays met
/// none of a light its neighbours see (mean and moment 0) from claiming to
/// be exact, which would let the filter pull its neighbours toward it and
/// never it toward them (a bias toward dark). Units: those of `mean`, squared.
pub fn pooled_variance(
    mean: &[Vec3],
    second: &[Vec3],
    rays: u32,
    rings: &Csr,
    normals: &[Vec3],
    angle_deg: f32,
) -> Vec<Vec3> {
    let cos_f = angle_deg.to_radians().cos();
    let n = rays.max(1) as f32;
    (0..mean.len())
        .into_par_iter()
        .map(|v| {
            let (mut m2, mut m, mut k) = (second[v], mean[v], 1.0f32);
            for u in feature_ring(v, rings, normals, cos_f) {
                m2 += second[u];
                m += mean[u];
                k += 1.0;
            }
            let (m2, m) = (m2 / k, m / k);
            (m2 - m * m).max(Vec3::ZERO) / n
        })
        .collect()
}

/// The neighbour weights `beta_v` of [`smooth_adaptive`] (None when the feature angle is 0).
pub fn adaptive_weights(
    values: &[Vec3],
    variance: &[Vec3],
    rings: &Csr,
    normals: &[Vec3],
    angle_deg: f32,
) -> Option<Vec<f32>> {
    if angle_deg <= 0.0 {
        return None;
    }
    let cos_f = angle_deg.to_radians().cos();
    // Per vertex: k, s^2 (channel sum) and the excess D^2 - s^2 (1 + 1/k).
    let local: Vec<(f32, f32, f32)> = (0..values.len())
        .into_par_iter()
        .map(|v| {
            let (mut sum, mut k) = (Vec3::ZERO, 0.0f32);
            for u in feature_ring(v, rings, normals, cos_f) {
                sum += values[u];
                k += 1.0;
            }
            let s2 = variance[v].element_sum();
            if k == 0.0 {
                return (0.0, s2, 0.0);
            }
            let d = sum / k - values[v];
            (k, s2, d.length_squared() - s2 * (1.0 + 1.0 / k))
        })
        .collect();
    Some(
        (0..values.len())
            .into_par_iter()
            .map(|v| {
                let (k, s2, excess) = local[v];
                if k == 0.0 || s2.is_nan() || s2 <= 0.0 {
                    return 0.0;
                }
                let (mut sum, mut count) = (excess, 1.0f32);
                for u in feature_ring(v, rings, normals, cos_f) {
                    sum += local[u].2;
                    count += 1.0;
                }
                let b2 = (sum / count).max(0.0);
                let beta = s2 / (s2 + k * b2);
                if beta.is_finite() {
                    beta
                } else {
                    0.0
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path of `n` vertices (each linked to its two neighbours), all normals up.
    fn path(n: usize) -> (Csr, Vec<Vec3>) {
        let pairs: Vec<(u32, u32)> = (0..n as u32 - 1).flat_map(|i| [(i, i + 1), (i + 1, i)]).collect();
        (Csr::from_pairs(n, &pairs), vec![Vec3::Y; n])
    }

    #[test]
    fn noise_free_values_are_left_alone_and_pure_noise_gets_the_one_ring_average() {
        let (rings, normals) = path(50);
        let values: Vec<Vec3> = (0..50).map(|i| Vec3::splat(1.0 + ((i * 7) % 5) as f32)).collect();
        // No noise: nothing moves.
        let zero = vec![Vec3::ZERO; 50];
        assert_eq!(smooth_adaptive(&values, &zero, &rings, &normals, 30.0, 1), values);
        // Noise far above the differences: the fixed average.
        let loud = vec![Vec3::splat(1e6); 50];
        let a = smooth_adaptive(&values, &loud, &rings, &normals, 30.0, 1);
        let u = smooth(&values, &rings, &normals, 30.0);
        for (x, y) in a.iter().zip(&u) {
            assert!((*x - *y).abs().max_element() < 1e-3, "{x} vs {y}");
        }
        // Feature angle 0: off.
        assert_eq!(smooth_adaptive(&values, &loud, &rings, &normals, 0.0, 1), values);
    }

    #[test]
    fn pooled_variance_is_zero_for_exact_values_and_shared_by_a_vertex_that_saw_nothing() {
        let (rings, normals) = path(5);
        // Every ray gave 2: no spread, nothing to smooth.
        let two = vec![Vec3::splat(2.0); 5];
        let four = vec![Vec3::splat(4.0); 5];
        assert!(pooled_variance(&two, &four, 64, &rings, &normals, 30.0).iter().all(|v| *v == Vec3::ZERO));
        // Vertex 2's rays all missed the light its neighbours saw in half
        // their rays (X = 0 or 2: mean 1, moment 2): it is not exact.
        let mut mean = vec![Vec3::ONE; 5];
        let mut second = vec![Vec3::splat(2.0); 5];
        mean[2] = Vec3::ZERO;
        second[2] = Vec3::ZERO;
        let var = pooled_variance(&mean, &second, 64, &rings, &normals, 30.0);
        // Ring of 2: avg moment 4/3, avg mean 2/3: (4/3 - 4/9) / 64.
        assert!((var[2].x - (4.0 / 3.0 - 4.0 / 9.0) / 64.0).abs() < 1e-7, "{}", var[2]);
        // Vertex 0 and its neighbour 1 both saw it: the binomial variance 1/64.
        assert!((var[0].x - 1.0 / 64.0).abs() < 1e-7, "{}", var[0]);
    }

    #[test]
    fn a_step_keeps_its_edge_where_noise_is_small() {
        let (rings, normals) = path(40);
        let values: Vec<Vec3> = (0..40).map(|i| Vec3::splat(if i < 20 { 1.0 } else { 2.0 })).collect();
        let var = vec![Vec3::splat(1e-4); 40];
        let a = smooth_adaptive(&values, &var, &rings, &normals, 30.0, 1);
        // The fixed filter blurs the step by a third of its height; the adaptive one barely.
        assert!((a[19].x - 1.0).abs() < 0.01 && (a[20].x - 2.0).abs() < 0.01, "{} {}", a[19], a[20]);
        // Away from the edge, constant values stay exact.
        assert!((a[5].x - 1.0).abs() < 1e-6);
    }
}
