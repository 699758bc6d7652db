//! Noise estimate of the gathered indirect irradiance `E_i` per vertex,
//! from the links and the radiosity they carry (input of the noise-aware
//! smoothing, [`mod@crate::exchange::denoise::smooth`]).
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
//! The model is within a factor of 2.3 of both scenes at every count, but
//! twice too large on `window` and off by more inside one scene where the
//! light is uneven: the solver measures the ratio on the scene instead,
//! locally ([`crate::exchange::denoise::noise_check`]), and keeps the model for a solver
//! without a check (the `noise_check` term off).

use crate::exchange::bounce::operator::radiosity;
use crate::links::Links;
use glam::{Vec3, Vec4};
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
    /// Vertices of the noise check (`crate::exchange::denoise::noise_check`), whose measured
    /// ratio replaces the model's; at least 1 (the `noise_check` term off:
    /// the model alone).
    pub check_vertices: u32,
    /// The check's ratio around a sampled vertex is a Gaussian kernel
    /// average whose width is the distance to its `check_neighbours`-th
    /// nearest sampled vertex; 0: one ratio for the scene.
    pub check_neighbours: u32,
}

impl NoiseParams {
    /// Actual over independent-ray variance at `rays` rays per vertex:
    /// `min(1, scale * (reference_rays / rays)^exponent)`.
    pub fn ratio(&self, rays: u32) -> f32 {
        let n = rays.max(1) as f32;
        (self.scale * (self.reference_rays as f32 / n).powf(self.exponent)).min(1.0)
    }
}

impl NoiseParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: NoiseParams =
        Self { scale: 0.2, reference_rays: 256, exponent: 0.75, check_vertices: 512, check_neighbours: 24 };
}

impl Default for NoiseParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Variance of every vertex's `E_i`, (W/m^2)^2 per channel, from `links`
/// shot at `rays_per_vertex`, the per-vertex `albedo` and emitted exitance
/// `emission` (W/m^2, may be empty), the direct
/// irradiance the bounces started from and the gathered `E_i` (W/m^2),
/// with the model's stratification ratio ([`NoiseParams::ratio`]).
#[cfg(any(test, feature = "internals"))]
pub fn variance(
    links: &Links,
    albedo: &[Vec3],
    emission: &[Vec3],
    e_source: &[Vec3],
    e_indirect: &[Vec3],
    rays_per_vertex: u32,
    params: &NoiseParams,
) -> Vec<Vec3> {
    let b = radiosity_moments(albedo, emission, e_source, e_indirect);
    let ratio = params.ratio(rays_per_vertex);
    let mut var = variance_iid(links, &b, rays_per_vertex);
    var.iter_mut().for_each(|v| *v *= ratio);
    var
}

/// The total radiosity `B = rho/pi (E_src + E_i) + M_e/pi` (W/(m^2 sr)) of
/// every vertex and its square, side by side (one 32-byte read a link),
/// from the direct irradiance the bounces started from, the gathered `E_i`
/// (W/m^2) and the emitted exitance the links carry (may be empty).
pub fn radiosity_moments(albedo: &[Vec3], emission: &[Vec3], e_source: &[Vec3], e_indirect: &[Vec3]) -> Vec<[Vec4; 2]> {
    albedo
        .par_iter()
        .zip(e_source.par_iter().zip(e_indirect))
        .enumerate()
        .map(|(v, (r, (s, i)))| {
            let b = radiosity(*r, *s + *i, emission.get(v).copied().unwrap_or(Vec3::ZERO));
            [b.extend(0.0), (b * b).extend(0.0)]
        })
        .collect()
}

/// `var_iid` of every vertex (see the module doc), (W/m^2)^2 per channel:
/// the variance of `E_i` had its `rays_per_vertex` rays been drawn
/// independently, for radiosity moments `b` ([`radiosity_moments`]).
pub fn variance_iid(links: &Links, b: &[[Vec4; 2]], rays_per_vertex: u32) -> Vec<Vec3> {
    assert_eq!(links.packed.rows(), links.vertex_count(), "the links have no packed targets");
    (0..links.vertex_count())
        .into_par_iter()
        .map(|v| {
            let (m1, m2) = vertex_moments(links, b, v);
            iid_variance(m1, m2, rays_per_vertex)
        })
        .collect()
}

/// `var_iid` of one vertex from its moments `(sum_j w_j B_j, sum_j w_j
/// B_j^2)` ([`vertex_moments`]) and its rays: `max(0, pi m2 - m1^2) / n_C`.
#[inline]
pub fn iid_variance(m1: Vec3, m2: Vec3, rays_per_vertex: u32) -> Vec3 {
    (PI * m2 - m1 * m1).max(Vec3::ZERO) * (1.0 / rays_per_vertex.max(1) as f32)
}

/// `(sum_j w_j B_j, sum_j w_j B_j^2)` over vertex `v`'s links (W/m^2 and
/// (W/m^2)(W/(m^2 sr))), with the SIMD kernel where the CPU has it.
pub fn vertex_moments(links: &Links, b: &[[Vec4; 2]], v: usize) -> (Vec3, Vec3) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("f16c") {
        // SAFETY: the CPU supports AVX2 and F16C (checked above).
        return unsafe { moments_simd(links, b, v) };
    }
    moments(links, b, v)
}

/// [`moments`] with SSSE3 block decoding ([`crate::links::packed::simd::Cursor`]),
/// F16C weights and AVX2 arithmetic: a target's `[B, B^2]` (32 bytes) in
/// one register, so one load, multiply and add a link; the same arithmetic
/// per lane in the same order as [`moments`], so the same bits.
///
/// # Safety
/// The CPU must have AVX2 and F16C; `b` holds one entry per vertex of
/// `links` (targets are clamped to its last); rows are read through
/// [`Links::simd_group`], which checks their bounds.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,f16c")]
unsafe fn moments_simd(links: &Links, b: &[[Vec4; 2]], v: usize) -> (Vec3, Vec3) {
    use std::arch::x86_64::*;
    let last = _mm_set1_epi32(b.len().saturating_sub(1) as i32);
    let bp = b.as_ptr() as *const f32;
    let wp = links.weights.as_ptr() as *const u16;
    let row = |t: u32| _mm256_loadu_ps(bp.add(8 * t as usize));
    let Some((j0, j1, mut c)) = links.simd_group(v) else {
        return moments(links, b, v);
    };
    let mut acc = [_mm256_setzero_ps(); 2];
    let mut j = j0;
    while j + 4 <= j1 {
        // Clamped as in the gather: every load is in bounds.
        let t = _mm_min_epu32(c.block(), last);
        let (t01, t23) = (_mm_cvtsi128_si64(t) as u64, _mm_extract_epi64::<1>(t) as u64);
        let w = _mm256_castps128_ps256(_mm_cvtph_ps(_mm_loadl_epi64(wp.add(j) as *const __m128i)));
        let lane = |k: i32| _mm256_permutevar8x32_ps(w, _mm256_set1_epi32(k));
        acc[0] = _mm256_add_ps(acc[0], _mm256_mul_ps(row(t01 as u32), lane(0)));
        acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(row((t01 >> 32) as u32), lane(1)));
        acc[0] = _mm256_add_ps(acc[0], _mm256_mul_ps(row(t23 as u32), lane(2)));
        acc[1] = _mm256_add_ps(acc[1], _mm256_mul_ps(row((t23 >> 32) as u32), lane(3)));
        j += 4;
    }
    if j < j1 {
        let mut t = [0u32; 4];
        let d = _mm_min_epu32(c.block(), last);
        _mm_storeu_si128(t.as_mut_ptr() as *mut __m128i, d);
        for k in 0..j1 - j {
            let w = _mm256_set1_ps(links.weights[j + k].to_f32());
            acc[k & 1] = _mm256_add_ps(acc[k & 1], _mm256_mul_ps(row(t[k]), w));
        }
    }
    let half =
        |a: __m256, hi: bool| Vec4::from(if hi { _mm256_extractf128_ps::<1>(a) } else { _mm256_castps256_ps128(a) });
    let m1 = half(acc[0], false) + half(acc[1], false);
    let m2 = half(acc[0], true) + half(acc[1], true);
    (m1.truncate(), m2.truncate())
}

/// `(sum_j w_j B_j, sum_j w_j B_j^2)` over vertex `v`'s links, in two
/// interleaved partial sums (even and odd links), decoding the packed
/// targets block by block as the gather does.
#[inline(always)]
fn moments(links: &Links, b: &[[Vec4; 2]], v: usize) -> (Vec3, Vec3) {
    let (j0, j1) = (links.offsets[v] as usize, links.offsets[v + 1] as usize);
    let mut c = links.packed.cursor(v, j1.saturating_sub(j0));
    let (mut m1, mut m2) = ([Vec4::ZERO; 2], [Vec4::ZERO; 2]);
    for j in (j0..j1).step_by(4) {
        let t = c.block(&links.packed.bytes);
        for k in 0..(j1 - j).min(4) {
            let (x, w) = (&b[t[k] as usize], links.weights[j + k].to_f32());
            m1[k & 1] += x[0] * w;
            m2[k & 1] += x[1] * w;
        }
    }
    ((m1[0] + m1[1]).truncate(), (m2[0] + m2[1]).truncate())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD decoding kernel gives the portable kernel's bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_moments_equal_portable_moments() {
        if !(std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("f16c")) {
            return;
        }
        let n = 700;
        let links = crate::links::random_links(n, 13, 0.3, 5);
        let b: Vec<[Vec4; 2]> =
            (0..n).map(|i| [Vec4::splat(1.0 + (i as f32).sin()), Vec4::splat(0.3 * i as f32)]).collect();
        for v in 0..n {
            // SAFETY: AVX2 and F16C are available (checked above).
            let (a, c) = (moments(&links, &b, v), unsafe { moments_simd(&links, &b, v) });
            assert_eq!((a.0.to_array(), a.1.to_array()), (c.0.to_array(), c.1.to_array()), "vertex {v}");
        }
    }

    /// The interleaved kernel equals a plain f64 sum of `w B` and `w B^2`.
    #[test]
    fn moments_equal_f64_sums() {
        let n = 500;
        let links = crate::links::random_links(n, 9, 0.3, 3);
        let bv: Vec<Vec3> = (0..n).map(|i| Vec3::new(1.0 + i as f32 * 0.01, 0.5, (i % 7) as f32)).collect();
        let b: Vec<[Vec4; 2]> = bv.iter().map(|x| [x.extend(0.0), (*x * *x).extend(0.0)]).collect();
        for v in 0..n {
            let (m1, m2) = moments(&links, &b, v);
            let (t, w) = links.group(v);
            for c in 0..3 {
                let want1: f64 = t.iter().zip(w).map(|(&t, w)| w.to_f64() * bv[t as usize][c] as f64).sum();
                let want2: f64 = t.iter().zip(w).map(|(&t, w)| w.to_f64() * (bv[t as usize][c] as f64).powi(2)).sum();
                assert!((m1[c] as f64 - want1).abs() <= 1e-5 * want1.abs() + 1e-9, "vertex {v}");
                assert!((m2[c] as f64 - want2).abs() <= 1e-5 * want2.abs() + 1e-9, "vertex {v}");
            }
        }
    }
}
