//! Vertex links (docs/DESIGN.md §3): every vertex shoots the shared direction set
//! turned into its frame; a front-face hit on triangle `(A, B, C)` at
//! barycentrics `(a, b, c)` gives three raw links `w(x, A) += a * pi / n_C`
//! (same for B, C), since with cosine-distributed directions the geometry
//! term cancels against the pdf:
//! `E_i(x) ~ (pi / n_C) * sum_k L(hit_k)`. Links with the same target are
//! merged by adding weights; the result is a CSR matrix of link groups.
//!
//! Back-face hits (blocked, no light) add nothing. Misses add no link; the
//! directions they left in are kept per vertex as its sky visibility
//! ([`Links::sky`], [`crate::sky::visibility`]). Weights are unitless (sr-weighted cosines): `E = W L`, with `L`
//! in W/(m^2 sr) and `E` in W/m^2; a closed scene's rows sum to pi.
//!
//! Storage: a link is an IEEE half-precision weight and its target, coded
//! as the gap to the previous target of its group in a byte stream
//! ([`packed`]; 0.6-0.8 bytes), what both gathers read: about 2.7-2.8 bytes a
//! link ([`Links::gather_bytes`]; u32 targets with the f16 weights took 6).
//! Groups are packed as they are merged ([`assemble::GroupRun`]), so full
//! u32 targets exist only one group at a time. Per target, barycentric weights are summed in fixed point
//! ([`merge::fixed_scale`]: 2^-23 of a ray's weight at 256 rays, so the sum
//! does not depend on ray order); weights are then rounded to f16 in target
//! order with the rounding error carried to the next link (error
//! diffusion), so a group's total stays within half an f16 ulp of its
//! largest link (2^-11 relative) of the exact sum. Scenes with dynamic
//! meshes also keep each link's fixed-point sum and each ray's hit id for
//! selective updates ([`selective`]).

pub mod assemble;
pub mod buried;
pub mod merge;
pub mod near;
pub mod packed;
pub mod reassign;
pub mod selective;
pub mod shoot;
pub mod splice;

use crate::sky::SkyVisibility;
use half::f16;

pub use assemble::{assemble, GroupRun};
pub use merge::RayHits;
pub use merge::{merge_vertex, HitRecord, MergeScratch};
#[cfg(any(test, feature = "internals"))]
pub use merge::{HIT_BACK, HIT_MISS};
pub use near::{NearHit, NearHits, NearParams};
pub use reassign::{reassign_links, Lineage, ReassignStats};
pub use selective::ReshootStats;
pub use shoot::{shoot_links_recording, LinkParams, RaySetup, Recording};
#[cfg(any(test, feature = "internals"))]
pub use shoot::shoot_links;

/// Counters of one link generation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkStats {
    /// Rays shot.
    pub rays: u64,
    /// Rays that met a front face.
    pub front_hits: u64,
    /// Rays blocked by a back face.
    pub back_hits: u64,
    /// Rays that left the scene.
    pub misses: u64,
    /// Links before merging (three per front hit).
    pub raw_links: u64,
    /// Links after merging (one per distinct target of each group).
    pub merged_links: u64,
    /// Raw storage: (u32 target, f32 weight) per raw link.
    pub raw_bytes: u64,
    /// Bytes the gathers read (`Links::gather_bytes`): packed targets,
    /// f16 weights and the row offsets.
    pub merged_bytes: u64,
    /// Time spent shooting and merging, ms.
    pub shoot_ms: f64,
}

impl LinkStats {
    /// Rays traced per second during link generation.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / (self.shoot_ms.max(1e-9) * 1e-3)
    }

    /// Adds `o`'s ray, hit and link counts to these counters (bytes and time are left as they are).
    pub fn add(&mut self, o: &LinkStats) {
        self.rays += o.rays;
        self.front_hits += o.front_hits;
        self.back_hits += o.back_hits;
        self.misses += o.misses;
        self.raw_links += o.raw_links;
        self.merged_links += o.merged_links;
    }
}

/// The link matrix in CSR form: vertex `v`'s link group is links
/// `offsets[v]..offsets[v+1]`: their `weights`, and their targets (strictly
/// increasing) coded in `packed` ([`packed`]; [`Links::group`] decodes).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Links {
    /// Row offsets: vertex `v`'s links are `offsets[v]..offsets[v + 1]` (vertex count plus one entries).
    pub offsets: Vec<u32>,
    /// Link weights (unitless, `E = W L`), in half precision.
    pub weights: Vec<f16>,
    /// The targets as the gathers read them ([`packed`]).
    pub packed: packed::PackedTargets,
    /// Links to the sky: the projection of every vertex's missed ray
    /// directions ([`crate::sky::visibility`]); empty when no ray missed.
    pub sky: SkyVisibility,
    /// Rays that hit close to their triangle ([`near`]); empty when not recorded.
    pub near: near::NearHits,
    /// Counters of the generation that made these links.
    pub stats: LinkStats,
}

impl Links {
    /// Links from CSR arrays (targets of a group strictly increasing),
    /// packed, with `stats.merged_links` and `stats.merged_bytes` set.
    #[cfg(any(test, feature = "internals"))]
    pub fn from_csr(offsets: Vec<u32>, targets: &[u32], weights: Vec<f16>) -> Links {
        let packed = packed::PackedTargets::encode(&offsets, targets);
        let mut links = Links { offsets, weights, packed, ..Default::default() };
        links.set_sizes();
        links
    }

    /// Sets `stats.merged_links` and `stats.merged_bytes` from the arrays.
    pub fn set_sizes(&mut self) {
        self.stats.merged_links = self.weights.len() as u64;
        self.stats.merged_bytes = self.gather_bytes();
    }

    /// Bytes of the links as the gathers read them: the packed targets
    /// with their row starts, 2 per weight, 4 per row offset. The one size
    /// formula (link stats, `linkgi solve`, bench and bandwidth figures).
    pub fn gather_bytes(&self) -> u64 {
        self.packed.bytes() + 2 * self.weights.len() as u64 + 4 * self.offsets.len() as u64
    }

    /// Number of vertices (link groups).
    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Links in all groups.
    pub fn link_count(&self) -> usize {
        self.weights.len()
    }

    /// Vertex `v`'s targets, appended to `out`.
    pub fn targets_into(&self, v: usize, out: &mut Vec<u32>) {
        let count = (self.offsets[v + 1] - self.offsets[v]) as usize;
        self.packed.decode_group(v, count, out);
    }

    /// Every link's target in link order (decoded).
    #[cfg(any(test, feature = "internals"))]
    pub fn targets(&self) -> Vec<u32> {
        let mut out = Vec::with_capacity(self.link_count());
        for v in 0..self.vertex_count() {
            self.targets_into(v, &mut out);
        }
        out
    }

    /// Vertex `v`'s link group: its targets (decoded) and weights.
    pub fn group(&self, v: usize) -> (Vec<u32>, &[f16]) {
        let mut t = Vec::new();
        self.targets_into(v, &mut t);
        (t, self.weights_of(v))
    }

    /// Vertex `v`'s link range `(j0, j1)` and a SIMD decoder of its
    /// targets, when every read of the decoder and every weight of the
    /// range lies inside the arrays; `None` otherwise (the rows near the
    /// stream's end, or links whose arrays do not match), for the scalar
    /// path. What makes the SIMD kernels sound for any `Links`.
    ///
    /// # Safety
    /// SSE2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn simd_group(&self, v: usize) -> Option<(usize, usize, packed::simd::Cursor)> {
        let (j0, j1) = (self.offsets[v] as usize, self.offsets[v + 1] as usize);
        if j0 > j1 || j1 > self.weights.len() {
            return None;
        }
        packed::simd::Cursor::new(&self.packed, v, j1 - j0).map(|c| (j0, j1, c))
    }

    /// Vertex `v`'s weights.
    pub fn weights_of(&self, v: usize) -> &[f16] {
        &self.weights[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// Sum of vertex `v`'s weights (pi for a vertex that sees only front faces).
    pub fn row_sum(&self, v: usize) -> f64 {
        // f16 -> f32 is exact (and a hardware conversion on x86), so this
        // equals summing `to_f64` values.
        self.weights_of(v).iter().map(|w| w.to_f32() as f64).sum()
    }

    /// Checks offsets (monotone, matching lengths), the packed targets (in
    /// range, strictly increasing within a group, so merged; each row's
    /// bytes exactly its links') and weights (finite, positive, rows
    /// summing to at most pi).
    pub fn validate(&self) -> Result<(), String> {
        let n = self.vertex_count();
        if self.offsets.first() != Some(&0) {
            return Err("offsets do not start at 0".into());
        }
        if *self.offsets.last().unwrap() as usize != self.weights.len() {
            return Err("offsets and weights disagree in length".into());
        }
        if let Some(v) = (0..n).find(|&v| self.offsets[v] > self.offsets[v + 1]) {
            return Err(format!("offsets decrease at vertex {v}"));
        }
        self.packed.validate(&self.offsets, n)?;
        for v in 0..n {
            if let Some(bad) = self.weights_of(v).iter().find(|x| !(x.is_finite() && x.to_f32() > 0.0)) {
                return Err(format!("vertex {v}: weight {bad} is not finite and positive"));
            }
            let sum = self.row_sum(v);
            if sum > std::f64::consts::PI * (1.0 + 2e-3) {
                return Err(format!("vertex {v}: weights sum to {sum} > pi"));
            }
        }
        Ok(())
    }
}

/// Random merged links for unit tests: `n` vertices, groups of 0 to
/// `max_group - 1` draws (distinct targets, strictly increasing, so fewer
/// when draws repeat), weights in `[0, max_weight)`.
#[cfg(test)]
pub(crate) fn random_links(n: usize, max_group: usize, max_weight: f32, seed: u64) -> Links {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let (mut offsets, mut targets, mut weights) = (vec![0u32], Vec::new(), Vec::new());
    for _ in 0..n {
        let mut t: Vec<u32> = (0..rng.random_range(0..max_group)).map(|_| rng.random_range(0..n as u32)).collect();
        t.sort_unstable();
        t.dedup();
        weights.extend(t.iter().map(|_| f16::from_f32(rng.random_range(0.0..max_weight))));
        targets.extend(t);
        offsets.push(targets.len() as u32);
    }
    Links::from_csr(offsets, &targets, weights)
}
