//! Bounce gathering over the link matrix `W` (docs/DESIGN.md §4):
//! `B_0 = rho/pi * E_src + M_e/pi` ([`source_radiosity`]: `E_src` the
//! direct irradiance of lights and sky, `M_e` the emitted exitance, W/m^2),
//! `E^(b) = W B_(b-1)`, `B_b = rho/pi * E^(b)`, `E_i = sum_b E^(b)`. One
//! pass over all links is one bounce. Emission is a source term only: an
//! emitter's own exitance never appears in its `E_i`, the light it sends
//! reaches other vertices through their links. With the radiosity
//! correction on ([`super::reconstruct`]), each bounce after the first
//! gathers `Btilde = R B_(b-1)` instead (the solver corrects `B_0` itself).
//!
//! Bounce count is fixed or `auto`: stop once the newest bounce adds less
//! than `tolerance` of the running total (per channel, over all vertices).
//! The ratio `q` of the last two bounces' totals estimates the remaining
//! geometric tail `E^(b) q / (1 - q)`; in `auto` mode that tail is added to
//! `E_i` (this is exact for the sphere furnace, whose bounces are uniform,
//! and keeps stiff scenes with rho near 1 from stopping short), in fixed
//! mode it is only reported. Irradiances in W/m^2.

use crate::links::Links;
use crate::scene::Bounces;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;

/// Parameters of the gather.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherParams {
    pub bounces: Bounces,
    /// `auto`: relative contribution of the newest bounce at which to stop.
    pub tolerance: f32,
    /// `auto`: upper limit on bounces.
    pub max_bounces: u32,
}

impl Default for GatherParams {
    fn default() -> Self {
        Self { bounces: Bounces::Fixed(3), tolerance: 1e-4, max_bounces: 100_000 }
    }
}

/// Result of a gather.
#[derive(Clone, Debug, Default)]
pub struct GatherResult {
    /// Indirect irradiance per vertex (unsmoothed), W/m^2.
    pub e_indirect: Vec<Vec3>,
    pub bounces: u32,
    /// Sum over vertices of each bounce's irradiance, per channel.
    pub bounce_totals: Vec<Vec3>,
    /// Estimated remaining tail relative to the total (per channel, the largest).
    pub tail_relative: f32,
    /// True if the tail estimate was added to `e_indirect` (auto mode).
    pub tail_added: bool,
    pub ms: f64,
}

/// One bounce: `out[v] = sum_j w_vj * b[target_j]` (RGB). Pads `b` to
/// [`Vec4`] and runs [`gather_bounce_padded`] (the kernel the solver uses).
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

fn total(e: &[Vec3]) -> [f64; 3] {
    e.par_iter()
        .fold(
            || [0f64; 3],
            |mut s, v| {
                s[0] += v.x as f64;
                s[1] += v.y as f64;
                s[2] += v.z as f64;
                s
            },
        )
        .reduce(|| [0f64; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
}

/// One implementation of the bounce loop (the CPU here, the GPU in
/// `crate::gpu::gather`); [`drive`] holds the stopping rule and the tail
/// estimate, so both paths stop after the same bounce.
pub trait BounceKernel {
    /// Runs `count` bounces; returns each one's total irradiance over all
    /// vertices per channel (W/m^2 summed, f64).
    fn run_bounces(&mut self, count: u32) -> crate::Result<Vec<[f64; 3]>>;
    /// `E_i` so far plus `tail` (per channel) times the newest bounce.
    fn finish(&mut self, tail: Vec3) -> crate::Result<Vec<Vec3>>;
}

/// The CPU bounce kernel (rayon).
pub struct CpuBounces<'a> {
    links: &'a Links,
    albedo: &'a [Vec3],
    /// Hidden vertices and their linkers ([`super::hidden::stand_ins`]):
    /// from the second bounce on, a hidden vertex's radiosity is
    /// `rho/pi` times its linkers' irradiance of the bounce.
    stand_ins: &'a [super::hidden::StandIn],
    e_i: Vec<Vec3>,
    e_b: Vec<Vec3>,
    /// Radiosity `rho/pi * E` of the newest bounce, padded to 16 bytes.
    b: Vec<Vec4>,
    /// The gradient correction of the radiosity each bounce after the
    /// first gathers ([`super::reconstruct`]; the first bounce's source
    /// comes corrected), and its output.
    reconstruction: Option<&'a super::Reconstruction>,
    corrected: Vec<Vec4>,
    bounces_run: u32,
}

/// The radiosity the bounces start from, W/(m^2 sr):
/// `B_0 = rho/pi * e_source + emission/pi` (`emission` may be empty: none).
pub fn source_radiosity(e_source: &[Vec3], albedo: &[Vec3], emission: &[Vec3]) -> Vec<Vec3> {
    e_source
        .par_iter()
        .zip(albedo)
        .enumerate()
        .map(|(v, (e, r))| *e * *r / PI + emission.get(v).map_or(Vec3::ZERO, |m| *m / PI))
        .collect()
}

impl<'a> CpuBounces<'a> {
    /// The kernel starting from direct irradiance `e_direct` (no emission).
    pub fn new(links: &'a Links, albedo: &'a [Vec3], e_direct: &[Vec3]) -> Self {
        Self::from_radiosity(links, albedo, &source_radiosity(e_direct, albedo, &[]))
    }

    /// The kernel starting from radiosity `b0` ([`source_radiosity`]).
    pub fn from_radiosity(links: &'a Links, albedo: &'a [Vec3], b0: &[Vec3]) -> Self {
        let n = b0.len();
        let b = b0.iter().map(|b| b.extend(0.0)).collect();
        Self {
            links,
            albedo,
            stand_ins: &[],
            e_i: vec![Vec3::ZERO; n],
            e_b: vec![Vec3::ZERO; n],
            b,
            reconstruction: None,
            corrected: Vec::new(),
            bounces_run: 0,
        }
    }

    /// The kernel with the hidden-vertex substitution applied in every
    /// bounce (the module doc of [`super::hidden`]: the same fixed point
    /// as [`super::hidden::correct`] after the bounces, without its extra
    /// passes over the links).
    pub fn with_stand_ins(mut self, stand_ins: &'a [super::hidden::StandIn]) -> Self {
        self.stand_ins = stand_ins;
        self
    }

    /// The kernel gathering, from the second bounce on, the radiosity
    /// corrected by `r` ([`super::reconstruct`]; `None`: as it is). The
    /// starting radiosity is gathered as given.
    pub fn with_reconstruction(mut self, r: Option<&'a super::Reconstruction>) -> Self {
        self.reconstruction = r;
        self
    }
}

impl BounceKernel for CpuBounces<'_> {
    fn run_bounces(&mut self, count: u32) -> crate::Result<Vec<[f64; 3]>> {
        let mut totals = Vec::with_capacity(count as usize);
        for _ in 0..count {
            match self.reconstruction {
                Some(r) if self.bounces_run > 0 => {
                    self.corrected.resize(self.b.len(), Vec4::ZERO);
                    r.apply(&self.b, &mut self.corrected);
                    gather_bounce_padded(self.links, &self.corrected, &mut self.e_b);
                }
                _ => gather_bounce_padded(self.links, &self.b, &mut self.e_b),
            }
            self.bounces_run += 1;
            self.e_i.par_iter_mut().zip(&self.e_b).for_each(|(i, e)| *i += *e);
            self.b
                .par_iter_mut()
                .zip(&self.e_b)
                .zip(self.albedo)
                .for_each(|((b, e), r)| *b = (*e * *r / PI).extend(0.0));
            for (h, linkers) in self.stand_ins {
                let e = super::hidden::stand_in_irradiance(linkers, |u| self.e_b[u]);
                self.b[*h] = (e * self.albedo[*h] / PI).extend(0.0);
            }
            totals.push(total(&self.e_b));
        }
        Ok(totals)
    }

    fn finish(&mut self, tail: Vec3) -> crate::Result<Vec<Vec3>> {
        let mut e_i = std::mem::take(&mut self.e_i);
        if tail != Vec3::ZERO {
            e_i.par_iter_mut().zip(&self.e_b).for_each(|(i, e)| *i += *e * tail);
        }
        Ok(e_i)
    }
}

/// Runs the bounces from direct irradiance `e_direct` with per-vertex `albedo` on the CPU.
pub fn gather(links: &Links, albedo: &[Vec3], e_direct: &[Vec3], params: &GatherParams) -> GatherResult {
    drive(&mut CpuBounces::new(links, albedo, e_direct), params).expect("the CPU kernel cannot fail")
}

/// The bounce loop over any kernel: a fixed count in one go, or `auto`
/// bounce by bounce until the newest adds less than the tolerance, then
/// the geometric tail estimate (see the module doc).
pub fn drive(kernel: &mut dyn BounceKernel, params: &GatherParams) -> crate::Result<GatherResult> {
    let start = Instant::now();
    let (fixed, limit) = match params.bounces {
        Bounces::Fixed(k) => (true, k),
        Bounces::Auto => (false, params.max_bounces),
    };
    let mut result = GatherResult::default();
    let mut running = [0f64; 3];
    let mut prev = [0f64; 3];
    let mut q = [0f64; 3];
    let mut pending = if fixed { kernel.run_bounces(limit)? } else { Vec::new() };
    pending.reverse();
    for bounce in 1..=limit {
        let t = match pending.pop() {
            Some(t) => t,
            None => kernel.run_bounces(1)?[0],
        };
        result.bounces = bounce;
        result.bounce_totals.push(Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32));
        let mut newest_rel = 0f64;
        for c in 0..3 {
            running[c] += t[c];
            q[c] = if prev[c] > 0.0 { (t[c] / prev[c]).min(1.0) } else { 0.0 };
            if running[c] > 0.0 {
                newest_rel = newest_rel.max(t[c] / running[c]);
            }
        }
        prev = t;
        if !fixed && bounce >= 2 && newest_rel < params.tolerance as f64 {
            break;
        }
        if !fixed && running == [0.0; 3] {
            break; // nothing lit: every further bounce is zero
        }
    }
    // Geometric tail estimate from the last ratio.
    let mut tail_rel = 0f64;
    let mut factor = [0f32; 3];
    for c in 0..3 {
        if running[c] > 0.0 && q[c] < 1.0 {
            let f = q[c] / (1.0 - q[c]);
            factor[c] = f as f32;
            tail_rel = tail_rel.max(prev[c] * f / running[c]);
        } else if running[c] > 0.0 {
            tail_rel = f64::INFINITY;
        }
    }
    let add_tail = !fixed && result.bounces >= 2;
    result.e_indirect = kernel.finish(if add_tail { Vec3::from(factor) } else { Vec3::ZERO })?;
    result.tail_added = add_tail;
    result.tail_relative = tail_rel as f32;
    result.ms = start.elapsed().as_secs_f64() * 1e3;
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random merged links with groups of 0 to 11 links (every remainder
    /// of the four-way split), some vertices without links.
    fn random_links(n: usize, seed: u64) -> Links {
        crate::links::random_links(n, 12, 0.5, seed)
    }

    #[test]
    fn bounce_equals_f64_sum() {
        let n = 3000;
        let links = random_links(n, 7);
        let b: Vec<Vec3> = (0..n).map(|i| Vec3::new(1.0 + i as f32, 0.5, 1e-3 * i as f32)).collect();
        let mut out = vec![Vec3::NAN; n];
        gather_bounce(&links, &b, &mut out);
        for (v, o) in out.iter().enumerate() {
            let (t, w) = links.group(v);
            let mut want = [0f64; 3];
            for (&t, &w) in t.iter().zip(w) {
                for c in 0..3 {
                    want[c] += b[t as usize][c] as f64 * w.to_f64();
                }
            }
            for c in 0..3 {
                assert!((o[c] as f64 - want[c]).abs() <= 1e-6 * want[c].abs() + 1e-30, "vertex {v}: {o} vs {want:?}");
            }
        }
    }

    /// The SIMD kernel and the portable one give the same bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_kernel_equals_portable_kernel() {
        if !(std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("f16c")) {
            return;
        }
        let n = 2000;
        let links = random_links(n, 9);
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
