//! The link operator and the radiosity formula (docs/DESIGN.md §4): one
//! bounce `E(v) = sum_j w_vj B(target_j)` over the compact links
//! ([`gather_bounce_padded`], portable and AVX2 kernels with the same bits),
//! and the radiosity a Lambertian vertex sends, `B = rho/pi E + M/pi`
//! ([`radiosity`], the one home of that formula; `shaders/gather.wgsl`
//! mirrors it and `tests/gpu_layout.rs` checks the mirror). Irradiance in
//! W/m^2, radiosity in W/(m^2 sr).

use crate::links::Links;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;

/// One bounce: `out[v] = sum_j w_vj * b[target_j]` (RGB). Pads `b` to
/// [`Vec4`] and runs [`gather_bounce_padded`] (the kernel the solver uses).
#[cfg(any(test, feature = "internals"))]
pub fn gather_bounce(links: &Links, b: &[Vec3], out: &mut [Vec3]) {
    let padded: Vec<Vec4> = b.par_iter().map(|v| v.extend(0.0)).collect();
    gather_bounce_padded(links, &padded, out);
}

/// One bounce with the source radiosity padded to 16 bytes a vertex (one
/// aligned SIMD load per link), reading the compact links
/// ([`crate::links::packed`]: f16 weights and gap-coded targets). Each
/// group is summed in four interleaved partial sums (links `4i`, `4i+1`,
/// ...: one decoded block), so the adds of consecutive links do not wait
/// on each other; the partial sums are added pairwise at the end.
pub fn gather_bounce_padded(links: &Links, b: &[Vec4], out: &mut [Vec3]) {
    const CHUNK: usize = 256;
    assert_eq!(
        links.packed.rows(),
        links.vertex_count(),
        "the links have no packed targets (build them with Links::from_csr or a CsrBuilder)"
    );
    assert!(!b.is_empty() || links.link_count() == 0, "no radiosity to gather");
    #[cfg(target_arch = "x86_64")]
    let simd = std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("f16c");
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(ci, chunk)| {
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: the CPU has AVX2 and F16C (checked above).
            unsafe { gather_chunk_simd(links, b, ci * CHUNK, chunk) };
            return;
        }
        gather_chunk(links, b, ci * CHUNK, chunk);
    });
}

/// Gathers vertices `first..first + chunk.len()` into `chunk` ([`gather_row`]).
fn gather_chunk(links: &Links, b: &[Vec4], first: usize, chunk: &mut [Vec3]) {
    for (i, o) in chunk.iter_mut().enumerate() {
        *o = gather_row(links, b, first + i);
    }
}

/// Vertex `v`'s gather, decoding the targets block by block
/// ([`crate::links::packed::Cursor`]): the portable kernel, and the oracle of the SIMD one.
fn gather_row(links: &Links, b: &[Vec4], v: usize) -> Vec3 {
    let last = b.len().saturating_sub(1);
    let (j0, j1) = (links.offsets[v] as usize, links.offsets[v + 1] as usize);
    let mut c = links.packed.cursor(v, j1.saturating_sub(j0));
    let mut acc = [Vec4::ZERO; 4];
    for j in (j0..j1).step_by(4) {
        let t = c.block(&links.packed.bytes);
        for k in 0..(j1 - j).min(4) {
            acc[k] += b[(t[k] as usize).min(last)] * links.weights[j + k].to_f32();
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])).truncate()
}

/// [`gather_row`] over a chunk with SSSE3 decoding ([`crate::links::packed::simd::Cursor`]),
/// F16C weight conversion and AVX2 arithmetic: two links' radiosity in one
/// 256-bit register (partial sums 0 and 1 in one register, 2 and 3 in
/// another), the same multiplies and adds in the same order per lane, so
/// the same bits.
///
/// Measured on conference (2-core Zen 4 VM, best of 15, same process):
/// this kernel 30 ms a bounce (3.0 G links/s); the same with 128-bit
/// arithmetic 7-10% slower; row offsets widened to 64 bits in SIMD 10%
/// slower; weights broadcast from memory no faster; the targets' prefix
/// sum in scalar registers (fewer shuffles, more integer work) 3-5%
/// slower; AVX-512 (four links a register) 0-8% faster, within the VM's
/// noise, not kept. Every radiosity read sent to one vertex (always in L1)
/// made conference 15% faster (30.7 against 36.0 ms, alternating in one
/// process) and tearoom, whose radiosity fits in L2, no faster: cache
/// misses cost conference a sixth, the rest is the loop's instructions,
/// near this core's issue limit. u32 targets read 39 ms.
///
/// # Safety
/// The CPU must have AVX2 and F16C; `chunk` holds the vertices from
/// `first` on and `b` one radiosity per vertex of `links` (reads go
/// through [`Links::simd_group`], which checks every row's bounds).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,f16c")]
unsafe fn gather_chunk_simd(links: &Links, b: &[Vec4], first: usize, chunk: &mut [Vec3]) {
    use std::arch::x86_64::*;
    let last = _mm_set1_epi32(b.len().saturating_sub(1) as i32);
    let bp = b.as_ptr() as *const f32;
    let wp = links.weights.as_ptr() as *const u16;
    let (lo_pair, hi_pair) = (_mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1), _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3));
    for (i, o) in chunk.iter_mut().enumerate() {
        let v = first + i;
        let Some((j0, j1, mut c)) = links.simd_group(v) else {
            *o = gather_row(links, b, v);
            continue;
        };
        let (mut acc01, mut acc23) = (_mm256_setzero_ps(), _mm256_setzero_ps());
        let mut j = j0;
        while j + 4 <= j1 {
            // Targets beyond the radiosity are clamped (they never occur in
            // valid links: `Links::validate`), so every load is in bounds.
            let t = _mm_min_epu32(c.block(), last);
            let (t01, t23) = (_mm_cvtsi128_si64(t) as u64, _mm_extract_epi64::<1>(t) as u64);
            let row = |t: u64| bp.add(4 * (t as u32) as usize);
            let b01 = _mm256_loadu2_m128(row(t01 >> 32), row(t01));
            let b23 = _mm256_loadu2_m128(row(t23 >> 32), row(t23));
            let w = _mm256_castps128_ps256(_mm_cvtph_ps(_mm_loadl_epi64(wp.add(j) as *const __m128i)));
            acc01 = _mm256_add_ps(acc01, _mm256_mul_ps(b01, _mm256_permutevar8x32_ps(w, lo_pair)));
            acc23 = _mm256_add_ps(acc23, _mm256_mul_ps(b23, _mm256_permutevar8x32_ps(w, hi_pair)));
            j += 4;
        }
        let mut acc = [
            _mm256_castps256_ps128(acc01),
            _mm256_extractf128_ps::<1>(acc01),
            _mm256_castps256_ps128(acc23),
            _mm256_extractf128_ps::<1>(acc23),
        ];
        if j < j1 {
            let mut t = [0u32; 4];
            let d = _mm_min_epu32(c.block(), last);
            _mm_storeu_si128(t.as_mut_ptr() as *mut __m128i, d);
            for (k, a) in acc.iter_mut().enumerate().take(j1 - j) {
                let w = _mm_set1_ps(links.weights[j + k].to_f32());
                *a = _mm_add_ps(*a, _mm_mul_ps(_mm_load_ps(bp.add(4 * t[k] as usize)), w));
            }
        }
        let s = _mm_add_ps(_mm_add_ps(acc[0], acc[1]), _mm_add_ps(acc[2], acc[3]));
        *o = Vec4::from(s).truncate();
    }
}

/// The radiosity of a Lambertian surface of albedo `rho` under irradiance
/// `e` that emits exitance `m`, W/(m^2 sr): `B = rho/pi E + M/pi`.
#[inline]
pub fn radiosity(rho: Vec3, e: Vec3, m: Vec3) -> Vec3 {
    e * rho / PI + m / PI
}

/// The radiosity the bounces start from, W/(m^2 sr):
/// `B_0 = rho/pi * e_source + emission/pi` (`emission` may be empty: none).
pub fn source_radiosity(e_source: &[Vec3], albedo: &[Vec3], emission: &[Vec3]) -> Vec<Vec3> {
    e_source
        .par_iter()
        .zip(albedo)
        .enumerate()
        .map(|(v, (e, r))| radiosity(*r, *e, emission.get(v).copied().unwrap_or(Vec3::ZERO)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD kernel and the portable one give the same bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_kernel_equals_portable_kernel() {
        if !(std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("f16c")) {
            return;
        }
        let n = 2000;
        let links = crate::links::random_links(n, 12, 0.5, 9);
        let b: Vec<Vec4> = (0..n).map(|i| Vec4::new((i as f32).sin(), 0.25, 3.0 / (1.0 + i as f32), 0.0)).collect();
        let (mut a, mut c) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        gather_chunk(&links, &b, 0, &mut a);
        // SAFETY: AVX2 and F16C are supported (checked above).
        unsafe { gather_chunk_simd(&links, &b, 0, &mut c) };
        for (x, y) in a.iter().zip(&c) {
            assert_eq!(x.to_array().map(f32::to_bits), y.to_array().map(f32::to_bits));
        }
    }
}
