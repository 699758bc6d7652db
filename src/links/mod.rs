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
//! Storage: a link is a `u32` target plus an IEEE half-precision weight
//! (6 bytes). Per target, barycentric weights are summed in fixed point
//! ([`merge::fixed_scale`]: 2^-23 of a ray's weight at 256 rays, so the sum
//! does not depend on ray order); weights are then rounded to f16 in target
//! order with the rounding error carried to the next link (error
//! diffusion), so a group's total stays within half an f16 ulp of its
//! largest link (2^-11 relative) of the exact sum. Scenes with dynamic
//! meshes also keep each link's fixed-point sum and each ray's hit id for
//! selective updates ([`selective`]).

pub mod assemble;
pub mod merge;
pub mod near;
pub mod selective;
pub mod shoot;

use crate::sky::SkyVisibility;
use half::f16;

pub use assemble::{assemble, merged_bytes, CsrBuilder, GroupRun};
pub use merge::{merge_vertex, HitRecord, MergeScratch, HIT_BACK, HIT_MISS};
pub use near::{NearHit, NearHits, NearParams};
pub use selective::{RayHits, ReshootStats};
pub use shoot::{shoot_links, shoot_links_recording, LinkParams, RaySetup, TraceScratch, Wedge};

/// Counters of one link generation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkStats {
    pub rays: u64,
    /// Rays that met a front face.
    pub front_hits: u64,
    /// Rays blocked by a back face.
    pub back_hits: u64,
    /// Rays that left the scene.
    pub misses: u64,
    /// Links before merging (three per front hit).
    pub raw_links: u64,
    pub merged_links: u64,
    /// Raw storage: (u32 target, f32 weight) per raw link.
    pub raw_bytes: u64,
    /// Merged storage: 6 bytes per link plus a u32 offset per vertex.
    pub merged_bytes: u64,
    pub shoot_ms: f64,
}

impl LinkStats {
    /// Rays traced per second during link generation.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / (self.shoot_ms.max(1e-9) * 1e-3)
    }

    pub fn add(&mut self, o: &LinkStats) {
        self.rays += o.rays;
        self.front_hits += o.front_hits;
        self.back_hits += o.back_hits;
        self.misses += o.misses;
        self.raw_links += o.raw_links;
        self.merged_links += o.merged_links;
    }
}

/// The link matrix in CSR form: vertex `v`'s link group is
/// `targets[offsets[v]..offsets[v+1]]` with the matching `weights`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Links {
    pub offsets: Vec<u32>,
    pub targets: Vec<u32>,
    pub weights: Vec<f16>,
    /// Links to the sky: the projection of every vertex's missed ray
    /// directions ([`crate::sky::visibility`]); empty when no ray missed.
    pub sky: SkyVisibility,
    /// Rays that hit close to their triangle ([`near`]); empty when not recorded.
    pub near: near::NearHits,
    pub stats: LinkStats,
}

impl Links {
    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Vertex `v`'s link group.
    pub fn group(&self, v: usize) -> (&[u32], &[f16]) {
        let r = self.offsets[v] as usize..self.offsets[v + 1] as usize;
        (&self.targets[r.clone()], &self.weights[r])
    }

    /// Sum of vertex `v`'s weights (pi for a vertex that sees only front faces).
    pub fn row_sum(&self, v: usize) -> f64 {
        // f16 -> f32 is exact (and a hardware conversion on x86), so this
        // equals summing `to_f64` values.
        self.group(v).1.iter().map(|w| w.to_f32() as f64).sum()
    }

    /// Checks offsets (monotone, matching lengths), targets (in range,
    /// strictly increasing within a group, so merged) and weights (finite,
    /// positive, rows summing to at most pi).
    pub fn validate(&self) -> Result<(), String> {
        let n = self.vertex_count();
        if self.offsets.first() != Some(&0) {
            return Err("offsets do not start at 0".into());
        }
        if *self.offsets.last().unwrap() as usize != self.targets.len() || self.targets.len() != self.weights.len() {
            return Err("offsets, targets and weights disagree in length".into());
        }
        for v in 0..n {
            if self.offsets[v] > self.offsets[v + 1] {
                return Err(format!("offsets decrease at vertex {v}"));
            }
            let (t, w) = self.group(v);
            if let Some(bad) = t.iter().find(|&&x| x as usize >= n) {
                return Err(format!("vertex {v} links to {bad}, but there are {n} vertices"));
            }
            if t.windows(2).any(|p| p[0] >= p[1]) {
                return Err(format!("vertex {v}: targets not strictly increasing (unmerged)"));
            }
            if let Some(bad) = w.iter().find(|x| !(x.is_finite() && x.to_f32() > 0.0)) {
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
