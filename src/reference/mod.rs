//! Reference solver: an independent Monte Carlo estimate of every vertex's
//! direct and indirect irradiance, to measure the link solver against.
//!
//! What it shares with the link solver: only the ray-intersection code
//! (the wide BVH, [`Bvh`], and its watertight triangle test). It never uses the vertex links, the light links, the
//! direction sets or the gather.
//!
//! Estimator (irradiance in W/m^2, lengths in metres):
//!
//! - `E_d(x) = sum_l I_l * V(x, l) * max(0, n . w_l) / max(r, d_min)^2` for a
//!   point light (`I` in W/sr), `E * V * max(0, -n . dir)` for a directional
//!   one; one shadow ray per light (point visibility, no one-ring
//!   oversampling).
//! - `E_i(x) = integral over the hemisphere of L(y(w)) cos(theta) dw`, with
//!   `L(y) = rho(y) / pi * (E_d(y) + E_i(y))` at the first surface point `y`
//!   seen along `w`. Directions are drawn with pdf `cos(theta) / pi`, so one
//!   path's estimate is `sum_k (prod_{j<=k} rho(y_j)) * E_d(y_k)` along the
//!   path `x -> y_1 -> y_2 ...` (next-event estimation at every `y_k`), ended
//!   by Russian roulette after `rr_start` bounces and cut at `max_depth`.
//!   Emitters add `prod_{j<k} rho(y_j) * M_e(y_k)` (their radiance `M_e/pi`
//!   times pi per cosine-sampled direction) at every `y_k`, the vertex's
//!   own emission included when a ray dives under its own triangle.
//! - Sky: a path that leaves the scene along `w` adds `pi L_sky(w)` times
//!   its throughput. Leaving along the vertex's own first direction is
//!   direct sky light, `E_sky` (reported apart from `E_i`); after a bounce
//!   it is indirect. No next-event estimation toward the sky: unbiased,
//!   noisier for small openings.
//!   The first direction of the samples of a vertex is stratified on a
//!   jittered grid; the rest are independent.
//! - Standard error of `E_i`: with the `k x k` strata, the sample variance
//!   would overstate the estimate's noise (stratification removes the
//!   variance between strata; measured on the Cornell box: 1.57x the
//!   variance seen between two references of 4096 and 65536 paths). The
//!   samples are taken in pairs of neighbouring strata `(2j, 2j+1)` and the
//!   variance of the mean is `sum_j (x_2j - x_2j+1)^2 / m^2` (collapsed
//!   strata: still conservative, by the differences between neighbouring
//!   strata). Without a square sample count, the sample variance.
//! - At a hit point `y` on triangle `f`: albedo is interpolated
//!   barycentrically from the vertices, the normal is `f`'s geometric normal
//!   (the flat triangle is the surface: this conserves energy exactly in a
//!   closed scene), and `E_d(y)` is evaluated at `y` itself. A back face
//!   ends the path (it brings no light).
//! - At the vertex `x` the hemisphere is around the vertex normal. Rays
//!   start `offset * l` (l: mean incident edge length) off the surface along
//!   the normal and, on border and crease vertices, toward the one-ring, so
//!   rays along a crease land on the face group across it. (Until cache
//!   version 4 every vertex moved toward its one-ring; inside a flat
//!   surface that direction is rounding noise, and vertices on the line
//!   where an object stands on the surface started inside the object: the
//!   reference gave them zero.) A direction that dives under one of the vertex's
//!   own triangles (possible on concave vertices, whose normal is an average)
//!   meets that triangle's back right at `x`; it is counted as a hit at `x`
//!   itself (the path continues from `x` with `rho(x)`), not as a back face.
//!
//! Deviations from the link solver, on purpose: no one-ring visibility
//! oversampling, no smoothing, exact `E_d` at hit points rather than
//! interpolated vertex values, and the flat triangles (not the vertex
//! normals) define the surface away from the vertices. These are exactly
//! the approximations whose error the reference exists to measure.
//!
//! Deterministic: vertex `v` draws from a PCG stream seeded with
//! `(seed, v)`, so results do not depend on thread scheduling. Results can
//! be cached on disk ([`cache`]), keyed by a hash of geometry, albedo,
//! lights and parameters.

pub mod cache;
pub mod image;
pub mod path;

use crate::bvh::{Bvh, BvhBuildParams};
use crate::scene::prep::PreparedScene;
use crate::trace::CpuTracer;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of the reference solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceParams {
    /// Paths per vertex (default 4096). Noise of `E_i` falls as `1/sqrt(samples)`.
    pub samples_per_vertex: u32,
    /// Longest path in bounces (default 64); the tail beyond it is lost.
    pub max_depth: u32,
    /// Bounces before Russian roulette starts (default 3).
    pub rr_start: u32,
    /// Smallest survival probability of Russian roulette (default 0.05).
    pub rr_min_survival: f32,
    /// Ray origin offset off the surface, as a fraction of the mean edge length (default 1e-4).
    pub offset: f32,
    /// Smallest light distance used in `1/r^2`, metres (default 1e-4, as the link solver).
    pub min_distance: f32,
    /// Seed of all random streams (default 1).
    pub seed: u64,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        Self {
            samples_per_vertex: 4096,
            max_depth: 64,
            rr_start: 3,
            rr_min_survival: 0.05,
            offset: 1e-4,
            min_distance: 1e-4,
            seed: 1,
        }
    }
}

/// Per-vertex reference irradiances.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reference {
    /// Direct irradiance, W/m^2.
    pub e_direct: Vec<Vec3>,
    /// Indirect irradiance, W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Standard error of each `e_indirect` estimate (paired-strata estimate, see the module doc), W/m^2.
    pub e_indirect_stderr: Vec<Vec3>,
    /// Irradiance from the sky (rays from the vertex that leave the scene), W/m^2.
    pub e_sky: Vec<Vec3>,
    /// Standard error of `e_sky + e_indirect`, the noise of the total, W/m^2.
    pub e_total_stderr: Vec<Vec3>,
    /// The parameters of the computation.
    pub params: ReferenceParams,
    /// Wall-clock time of the computation (0 when loaded from the cache), ms.
    pub ms: f64,
    /// True if the result was read from the disk cache.
    pub from_cache: bool,
}

impl Reference {
    /// Total irradiance `E_d + E_sky + E_i` per vertex, W/m^2.
    pub fn total(&self) -> Vec<Vec3> {
        (0..self.e_direct.len())
            .map(|v| self.e_direct[v] + self.e_sky.get(v).copied().unwrap_or_default() + self.e_indirect[v])
            .collect()
    }
}

/// Computes the reference with a wide BVH built here (the fastest CPU tracer).
pub fn compute(scene: &PreparedScene, params: &ReferenceParams) -> Reference {
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
    compute_with_tree(scene, &bvh, params)
}

/// Computes the reference with `accel`, a CPU tracer built over `scene`.
pub fn compute_with_tree(scene: &PreparedScene, accel: &dyn CpuTracer, params: &ReferenceParams) -> Reference {
    let start = Instant::now();
    let tracer = path::Tracer::new(scene, accel, params);
    let per_vertex: Vec<path::VertexEstimate> =
        (0..scene.vertex_count()).into_par_iter().map(|v| tracer.vertex(v)).collect();
    let mut out = Reference { params: *params, ..Default::default() };
    for e in per_vertex {
        out.e_direct.push(e.e_direct);
        out.e_sky.push(e.e_sky);
        out.e_indirect.push(e.e_indirect);
        out.e_indirect_stderr.push(e.e_indirect_stderr);
        out.e_total_stderr.push(e.e_total_stderr);
    }
    out.ms = start.elapsed().as_secs_f64() * 1e3;
    out
}

/// Like [`compute`], but reads the result from `cache_dir` if it holds one
/// for this scene and these parameters, and writes it there otherwise.
/// A cache that cannot be read or written is ignored (the result is computed).
pub fn compute_cached(scene: &PreparedScene, params: &ReferenceParams, cache_dir: &std::path::Path) -> Reference {
    let key = cache::key(scene, params);
    if let Some(r) = cache::load(cache_dir, key, scene.vertex_count(), params) {
        return r;
    }
    let r = compute(scene, params);
    // A failed write only costs a recomputation next time.
    let _ = cache::store(cache_dir, key, &r);
    r
}
