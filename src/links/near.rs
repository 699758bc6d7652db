//! Near hits: the link rays that meet a triangle closer than
//! `near_factor` times that triangle's longest edge, kept per vertex as
//! (triangle, barycentrics) so that the first bounce can use the exact
//! direct light at the hit point instead of the one the links interpolate
//! from the triangle's corners ([`crate::exchange::near::light`]).
//!
//! Why: a link carries the radiosity of the hit triangle's corners. Where
//! an object stands close to a large triangle (a plate 3 mm above a table,
//! a cabinet 5 cm from a wall), the corners lie out in the light while the
//! hit point is in the object's shadow, and the link brings light that is
//! not there (`tearoom`: the plates' undersides 2x too bright). Such rays
//! are short compared with the triangle they hit, which is what the
//! criterion selects. Lengths in metres.
//!
//! Recorded while the hits are merged into links ([`super::GroupRun`]),
//! whichever tracer shot them (CPU or GPU), so both give the same records.
//! A selective update ([`super::selective`]) redoes the near hits of every
//! vertex whose group it patched or which had a near hit on a moved
//! triangle, from its rays' hits (one triangle test a ray, no tracing), so
//! they equal a full shoot's. Off above [`NearParams::max_rays`] link rays
//! (their light columns would cost a light move more than the rest of it).

use super::merge::{HitRecord, HIT_BACK, HIT_MISS};
use crate::csr::Csr;
use crate::sampling::stream::{unit, Stream};
use crate::scene::prep::PreparedScene;
use std::sync::Arc;

/// Which link rays count as near.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearParams {
    /// A front hit closer than this times the hit triangle's longest edge
    /// is a near hit (0: none). Measured on `tearoom` (16384-path
    /// reference, 256 rays): 0.25 takes the total error from 3.5% to 2.9%,
    /// 0.5 to 2.7%, 1 to 2.6% (13% of the rays), 3 no further.
    pub factor: f32,
    /// No near hits when vertices x rays per vertex exceed this.
    pub max_rays: u64,
    /// The near hits a vertex keeps, as a share of its link rays: a vertex
    /// with more keeps each with probability `keep / near` and weight
    /// `near / keep` (unbiased; see `NearRule`). Every near hit costs the
    /// near-field terms a few rays (4 toward the emitters, 2 of final
    /// gather), so a vertex amid large triangles, whose rays are mostly
    /// near (Šibenik: 35% of all link rays), paid more for its near field
    /// than for its links. 1 keeps every near hit. Measured in
    /// docs/REAL_SCENES.md.
    pub max_share: f32,
}

impl NearParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: NearParams = Self { factor: 1.0, max_rays: 32_000_000, max_share: 0.125 };
}

impl Default for NearParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Near hits a vertex keeps at least, whatever its share: fewer, weighted
/// by more each, and a vertex's near-field sum swings below zero (at 64
/// rays a vertex and a share of 1/8, 8 near hits: `tests/emission.rs`
/// saw a Cornell box corner's sum clamped).
pub const MIN_KEEP: u32 = 32;

/// Which of a vertex's hits are near and which of those it keeps: the
/// limit distance of each triangle and the number `keep` a vertex keeps on
/// average. A vertex with `near > keep` near hits keeps each with
/// probability `p = keep / near` (a hash of the seed, the vertex, the hit's
/// triangle and its rank among the vertex's hits on that triangle, so one
/// near hit more or less elsewhere, where the CPU and GPU tracers differ,
/// leaves the others' choice as it was) and weights it `1 / p`
/// ([`NearHit::weight`]): the near-field sums stay unbiased.
#[derive(Clone, Debug)]
pub struct NearRule {
    /// Per triangle, the distance under which a hit on it is near, metres.
    pub limits: Arc<[f32]>,
    /// Near hits a vertex keeps on average (at least [`MIN_KEEP`]).
    pub keep: u32,
    /// The seed of the keeping hash.
    pub seed: u64,
}

impl NearRule {
    /// The rule of `scene` for `rays_per_vertex` link rays under `params`,
    /// or `None` when `scene` records no near hits (module doc: too many
    /// rays or a factor of 0).
    pub fn new(scene: &PreparedScene, rays_per_vertex: u32, params: &super::LinkParams) -> Option<NearRule> {
        let limits = near_limits(scene, rays_per_vertex, &params.near)?;
        let share = params.near.max_share.clamp(0.0, 1.0);
        let keep = ((share as f64 * rays_per_vertex as f64).ceil() as u32).max(MIN_KEEP);
        Some(NearRule { limits, keep, seed: params.seed })
    }
}

/// One near hit: the triangle and the barycentrics `(u, v)` of the hit
/// point (corner weights `1 - u - v`, `u`, `v`, as [`super::HitRecord`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearHit {
    /// The triangle hit.
    pub tri: u32,
    /// First barycentric coordinate (weight of the triangle's second corner).
    pub u: f32,
    /// Second barycentric coordinate (weight of the triangle's third corner).
    pub v: f32,
    /// The near hits it stands for (1, or `near / keep` where its vertex
    /// kept a sample of its near hits: [`NearRule`]); the near-field sums
    /// weight it so.
    pub weight: f32,
}

/// Every vertex's near hits (empty: none recorded).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearHits {
    /// Row `v`: vertex `v`'s hits; no rows when none were recorded.
    pub rows: Csr<NearHit>,
}

impl NearHits {
    /// True if no near hit is recorded.
    pub fn is_empty(&self) -> bool {
        self.rows.items.is_empty()
    }

    /// Every vertex's hits, vertex after vertex.
    #[cfg(any(test, feature = "internals"))]
    pub fn hits(&self) -> &[NearHit] {
        &self.rows.items
    }

    /// Consecutive ranges of vertices (of `n`) with at most about
    /// `max_hits` near hits each (a vertex with more gets a range of its
    /// own): the batches in which their shadow rays are traced, so the rays
    /// of the whole scene are never held at once.
    pub fn vertex_batches(&self, n: usize, max_hits: u32) -> Vec<std::ops::Range<usize>> {
        let mut out = Vec::new();
        let mut v0 = 0usize;
        while v0 < n {
            let mut v1 = v0;
            while v1 < n && self.rows.offsets[v1] - self.rows.offsets[v0] < max_hits {
                v1 += 1;
            }
            let v1 = v1.max(v0 + 1);
            out.push(v0..v1);
            v0 = v1;
        }
        out
    }

    /// Vertex `v`'s near hits.
    pub fn of(&self, v: usize) -> &[NearHit] {
        if v < self.rows.rows() {
            self.rows.row(v)
        } else {
            &[]
        }
    }

    /// Checks the CSR offsets against `n` vertices, triangle ids against
    /// `triangles`, the barycentrics (finite, inside the triangle) and the
    /// weights (finite, at least 1).
    #[cfg(any(test, feature = "internals"))]
    pub fn validate(&self, n: usize, triangles: usize) -> Result<(), String> {
        self.rows
            .validate(n, |_, h| {
                let inside = h.weight.is_finite()
                    && h.weight >= 1.0
                    && h.u.is_finite()
                    && h.v.is_finite()
                    && h.u >= -1e-6
                    && h.v >= -1e-6
                    && h.u + h.v <= 1.0 + 1e-6;
                if h.tri as usize >= triangles || !inside {
                    return Err(format!("near hit {h:?} of {triangles} triangles"));
                }
                Ok(())
            })
            .map_err(|e| format!("near hits: {e}"))
    }
}

/// Appends vertex `v`'s near hits among its hit records `hits` (one per
/// ray) to `out`: front hits closer than their triangle's limit, not on
/// one of `v`'s own triangles (such a hit is at the vertex itself); beyond
/// `rule.keep` of them, the sample [`NearRule`] describes.
pub fn push_near(v: usize, hits: &[HitRecord], triangles: &[[u32; 3]], rule: &NearRule, out: &mut Vec<NearHit>) {
    let first = out.len();
    for h in hits {
        let front = h.tri != HIT_MISS && h.tri & HIT_BACK == 0;
        if front && h.t < rule.limits[h.tri as usize] && !triangles[h.tri as usize].contains(&(v as u32)) {
            out.push(NearHit { tri: h.tri, u: h.u, v: h.v, weight: 1.0 });
        }
    }
    let near = out.len() - first;
    if near <= rule.keep as usize {
        return;
    }
    let p = rule.keep as f64 / near as f64;
    let weight = (1.0 / p) as f32;
    let rank = triangle_ranks(&out[first..]);
    let mut kept = first;
    for i in 0..near {
        let h = out[first + i];
        let key = Stream::NEAR_KEEP.hit_key(rule.seed, v, h.tri, rank[i] as usize);
        if (unit(key) as f64) < p {
            out[kept] = NearHit { weight, ..h };
            kept += 1;
        }
    }
    out.truncate(kept);
}

/// Each of one vertex's near hits' rank among its hits on the same
/// triangle, in ray order: with the vertex and the triangle, what a near
/// hit's samples hash from (its keeping here, the near-field terms'
/// samples), so a vertex's hits on other triangles keep their samples
/// where the CPU and GPU tracers give it one near hit more or less.
pub fn triangle_ranks(hits: &[NearHit]) -> Vec<u32> {
    // A stable sort by triangle numbers each triangle's hits in ray order.
    let mut order: Vec<u32> = (0..hits.len() as u32).collect();
    order.sort_by_key(|&i| hits[i as usize].tri);
    let mut rank = vec![0u32; hits.len()];
    for w in 1..order.len() {
        let (a, b) = (order[w - 1] as usize, order[w] as usize);
        if hits[a].tri == hits[b].tri {
            rank[b] = rank[a] + 1;
        }
    }
    rank
}

/// The distance under which a hit on each triangle is near, or `None`
/// when `scene` records no near hits (see the module doc): too many rays
/// or a factor of 0.
fn near_limits(scene: &PreparedScene, rays_per_vertex: u32, params: &NearParams) -> Option<Arc<[f32]>> {
    let rays = scene.vertex_count() as u64 * rays_per_vertex as u64;
    if !(params.factor > 0.0) || rays > params.max_rays {
        return None;
    }
    Some(
        scene
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| scene.positions[i as usize]);
                params.factor * (b - a).length().max((c - b).length()).max((a - c).length())
            })
            .collect(),
    )
}
