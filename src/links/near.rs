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
}

impl Default for NearParams {
    fn default() -> Self {
        Self { factor: 1.0, max_rays: 32_000_000 }
    }
}

/// One near hit: the triangle and the barycentrics `(u, v)` of the hit
/// point (corner weights `1 - u - v`, `u`, `v`, as [`super::HitRecord`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NearHit {
    /// The triangle hit.
    pub tri: u32,
    /// First barycentric coordinate (weight of the triangle's second corner).
    pub u: f32,
    /// Second barycentric coordinate (weight of the triangle's third corner).
    pub v: f32,
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
    /// `triangles` and the barycentrics (finite, inside the triangle).
    pub fn validate(&self, n: usize, triangles: usize) -> Result<(), String> {
        self.rows
            .validate(n, |_, h| {
                let inside =
                    h.u.is_finite() && h.v.is_finite() && h.u >= -1e-6 && h.v >= -1e-6 && h.u + h.v <= 1.0 + 1e-6;
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
/// one of `v`'s own triangles (such a hit is at the vertex itself).
pub fn push_near(v: usize, hits: &[HitRecord], triangles: &[[u32; 3]], limits: &[f32], out: &mut Vec<NearHit>) {
    for h in hits {
        let front = h.tri != HIT_MISS && h.tri & HIT_BACK == 0;
        if front && h.t < limits[h.tri as usize] && !triangles[h.tri as usize].contains(&(v as u32)) {
            out.push(NearHit { tri: h.tri, u: h.u, v: h.v });
        }
    }
}

/// The distance under which a hit on each triangle is near, or `None`
/// when `scene` records no near hits (see the module doc): too many rays
/// or a factor of 0.
pub fn near_limits(scene: &PreparedScene, rays_per_vertex: u32, params: &NearParams) -> Option<Arc<[f32]>> {
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
