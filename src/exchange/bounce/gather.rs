//! Bounce gathering over the link matrix `W` (docs/DESIGN.md §4):
//! `B_0 = rho/pi * E_src + M_e/pi` ([`source_radiosity`]: `E_src` the
//! direct irradiance of lights and sky, `M_e` the emitted exitance, W/m^2),
//! `E^(b) = W B_(b-1)`, `B_b = rho/pi * E^(b)`, `E_i = sum_b E^(b)`. One
//! pass over all links is one bounce. Emission is a source term only: an
//! emitter's own exitance never appears in its `E_i`, the light it sends
//! reaches other vertices through their links. With the radiosity
//! correction on ([`crate::exchange::bounce::reconstruct`]), each bounce after the first
//! gathers `Btilde = R B_(b-1)` instead (the solver corrects `B_0` itself).
//!
//! Bounce count is fixed or `auto`: stop once the newest bounce adds less
//! than `tolerance` of the running total (per channel, over all vertices).
//! The ratio `q` of the last two bounces' totals estimates the remaining
//! geometric tail `E^(b) q / (1 - q)`; in `auto` mode that tail is added to
//! `E_i` (this is exact for the sphere furnace, whose bounces are uniform,
//! and keeps stiff scenes with rho near 1 from stopping short), in fixed
//! mode it is only reported. Irradiances in W/m^2.

use crate::exchange::bounce::operator::radiosity;
pub use crate::exchange::bounce::operator::gather_bounce_padded;
#[cfg(any(test, feature = "internals"))]
pub use crate::exchange::bounce::operator::{gather_bounce, source_radiosity};
use crate::links::Links;
use crate::scene::Bounces;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of the gather.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherParams {
    /// A fixed count, or `auto` (stop by `tolerance`, add the geometric
    /// tail): more bounces cost one pass over the links each.
    pub bounces: Bounces,
    /// `auto`: relative contribution of the newest bounce at which to stop.
    pub tolerance: f32,
    /// `auto`: upper limit on bounces.
    pub max_bounces: u32,
}

impl GatherParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: GatherParams = Self { bounces: Bounces::Auto, tolerance: 1e-4, max_bounces: 100_000 };
}

impl Default for GatherParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Result of a gather.
#[derive(Clone, Debug, Default)]
pub struct GatherResult {
    /// Indirect irradiance per vertex (unsmoothed), W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Bounces run.
    pub bounces: u32,
    /// Sum over vertices of each bounce's irradiance, per channel.
    pub bounce_totals: Vec<Vec3>,
    /// Estimated remaining tail relative to the total (per channel, the largest).
    pub tail_relative: f32,
    /// True if the tail estimate was added to `e_indirect` (auto mode).
    pub tail_added: bool,
    /// Time of the gather, ms.
    pub ms: f64,
}

/// The sum of `e` over all vertices per channel, in f64: chunk sums in
/// parallel, added in chunk order, so the total (and the stopping rule and
/// tail it feeds) does not depend on the thread count.
fn total(e: &[Vec3]) -> [f64; 3] {
    let sum = |a: [f64; 3], v: &Vec3| [a[0] + v.x as f64, a[1] + v.y as f64, a[2] + v.z as f64];
    let chunks: Vec<[f64; 3]> = e.par_chunks(4096).map(|c| c.iter().fold([0f64; 3], sum)).collect();
    chunks.iter().fold([0f64; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
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
    /// Hidden vertices and their linkers ([`crate::exchange::bounce::hidden::stand_ins`]):
    /// from the second bounce on, a hidden vertex's radiosity is
    /// `rho/pi` times its linkers' irradiance of the bounce.
    stand_ins: &'a [crate::exchange::bounce::hidden::StandIn],
    e_i: Vec<Vec3>,
    e_b: Vec<Vec3>,
    /// Radiosity `rho/pi * E` of the newest bounce, padded to 16 bytes.
    b: Vec<Vec4>,
    /// The gradient correction of the radiosity each bounce after the
    /// first gathers ([`crate::exchange::bounce::reconstruct`]; the first bounce's source
    /// comes corrected), and its output.
    reconstruction: Option<&'a crate::exchange::bounce::reconstruct::Reconstruction>,
    corrected: Vec<Vec4>,
    bounces_run: u32,
}

impl<'a> CpuBounces<'a> {
    /// The kernel starting from direct irradiance `e_direct` (no emission).
    #[cfg(any(test, feature = "internals"))]
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
    /// bounce (the module doc of [`crate::exchange::bounce::hidden`]: the same fixed point
    /// as [`crate::exchange::bounce::hidden::correct`] after the bounces, without its extra
    /// passes over the links).
    pub fn with_stand_ins(mut self, stand_ins: &'a [crate::exchange::bounce::hidden::StandIn]) -> Self {
        self.stand_ins = stand_ins;
        self
    }

    /// The kernel gathering, from the second bounce on, the radiosity
    /// corrected by `r` ([`crate::exchange::bounce::reconstruct`]; `None`: as it is). The
    /// starting radiosity is gathered as given.
    pub fn with_reconstruction(mut self, r: Option<&'a crate::exchange::bounce::reconstruct::Reconstruction>) -> Self {
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
                .for_each(|((b, e), r)| *b = radiosity(*r, *e, Vec3::ZERO).extend(0.0));
            for (h, linkers) in self.stand_ins {
                let e = crate::exchange::bounce::hidden::stand_in_irradiance(linkers, |u| self.e_b[u]);
                self.b[*h] = radiosity(self.albedo[*h], e, Vec3::ZERO).extend(0.0);
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
#[cfg(any(test, feature = "internals"))]
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
}
