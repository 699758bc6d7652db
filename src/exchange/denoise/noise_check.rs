//! Noise check: the scene's own calibration of the noise estimate
//! ([`crate::exchange::denoise::noise`]), from a second, independent estimate of `E_i` at a
//! sample of vertices.
//!
//! The noise model turns the independent-ray variance `var_iid(x)` of a
//! vertex's `E_i` into the variance its stratified rays actually leave by
//! one ratio, `scale * (reference_rays / n)^exponent`, calibrated on the
//! Cornell box and the tearoom. Other scenes differ, and so do parts of
//! one scene. With two seeds, the actual over independent-ray variance at
//! 64 / 256 / 1024 rays is 0.59 / 0.28 / - on cornell, 0.37 / 0.12 / - on
//! the tearoom and 0.28 / 0.11 / 0.059 on `window` (the model: 0.57 / 0.20
//! / 0.071); in the sphere furnace with the light 0.29 m from the wall
//! (256 rays) the vertices within 0.5 m of the light keep 0.64 of the
//! independent-ray variance, those beyond 0.75 m 0.05-0.09. A smoothing that believes the noise larger than it is
//! averages away signal; one that believes it smaller leaves noise.
//!
//! The check shoots, at `m` sampled vertices, the same number of rays as
//! the links with another seed (another jitter of the direction sets and
//! other rotations: an independent draw of the same estimator) and merges
//! them like the links ([`crate::links::merge_vertex`]). With the current
//! radiosity `B` (the one the noise estimate uses), each sampled vertex
//! `s` has two independent estimates `W(s) B` and `W'(s) B` of the same
//! gathered `E_i`, so `a_s = |W(s) B - W'(s) B|^2 / 2` has the expectation
//! of its actual variance (channels summed). The ratio at sampled vertex
//! `i` is a kernel average over the sample,
//!
//! ```text
//! ratio_i = sum_j k_ij a_j / sum_j k_ij var_iid(s_j),   k_ij = exp(-|p_i - p_j|^2 / h_i^2)
//! ```
//!
//! with `h_i` the distance from `s_i` to its `k`-th nearest sampled vertex
//! (`k = 24` of `m = 512` by default; `k = 0`: the whole sample, one ratio
//! for the scene), and every vertex takes the ratio of the sampled vertex
//! of its index stratum (below). The kernel is continuous in the positions
//! and the strata are indices, so a scaled or rounded scene gets the same
//! ratios: nearest-neighbour sets broke ties differently at scale 1e-4 on
//! the closed room's regular grid and moved `E_i` by 1.5e-3, the kernel
//! by 1.3e-5 (`tests/stability.rs::scale_invariance`). The ratio replaces
//! the model's in every solve, for the radiosity of that solve (a moved
//! light changes it). Both estimates see the same `B`, so the difference
//! is the vertex's own rays alone: the noise the smoothing can remove.
//! Against that variance over all vertices (the links of two seeds
//! gathering one `B`) the estimate reads 0.73 / 0.93 on cornell and
//! 0.63 / 0.66 on `window` at 64 / 256 rays, the model 1.01 / 0.76 and
//! 2.27 / 1.87 (`tests/accuracy.rs`; the sample tends to miss the few
//! vertices of largest variance, so it reads low).
//!
//! Measured (total relative RMSE against the reference, noise removed,
//! auto bounces, default smoothing, seed 1; `cargo test --release --test measured -- --ignored
//! noise_check_lowers_window_error` checks window against `--off
//! noise_check` (the model): 5.15 -> 4.05% at 64 rays, 1.79 -> 1.73% at 256 now; the
//! model's ratio and per-vertex variance -> the check and the variance
//! averaged over the ring, [`crate::solver::Solver::noise_variance`]):
//!
//! | rays | 64 | 256 | 1024 |
//! |---|---|---|---|
//! | cornell (65536 paths) | 4.67 -> 4.83% | 2.30 -> 2.19% | 0.94 -> 0.95% |
//! | tearoom (16384) | 5.00 -> 4.86% | 2.59 -> 2.58% | 1.99 -> 1.97% |
//! | window (16384) | 6.87 -> 5.49% | 3.37 -> 3.00% | 1.98 -> 1.96% |
//!
//! and the furnace's worst vertex (rho 0.5, the light 0.29 m from the
//! wall, 256 rays) 4.2% -> 4.3%; with one ratio for the scene it read
//! 5.04%, over the 5% bound (the ratio near the light is 7-13 times that
//! elsewhere). One ratio for the scene gave cornell 4.78 / 2.22 /
//! 0.96%, tearoom 4.84 / 2.53 / 1.98%, window 5.77 / 3.09 / 1.97%; `k =
//! 48`: 4.80 / 2.20%, 4.86 / 2.56%, 5.52 / 3.01% at 64 / 256 rays.
//! A per-vertex estimate from each vertex's own rays by collapsed strata
//! (neighbouring strata paired, `(X_a - X_b)^2`, `cargo test --release --test measured -- --ignored
//! paired_strata_noise_smooths_worse_than_the_check`) overestimates 2-3x
//! (5.9x now) and smoothed worse than the check (window 64 rays 6.4%,
//! tearoom 5.1%; window now 5.66% against the check's 4.05%).
//!
//! Cost: `m` vertices' rays once per link build (3.9% of the tearoom's
//! rays, 0.28% of conference's), `m^2` kernel weights (1 MB), and per solve a
//! pass over the sample's links and one over the kernel. The
//! sample: for `i < m`, one vertex in `[floor(i n / m), floor((i + 1) n /
//! m))` picked by a hash of the seed (spread over the scene and its
//! meshes, the same for the same seed); every vertex when `n <= m`.

use crate::csr::{Csr, RowBuilder};
use crate::exchange::denoise::noise::{iid_variance, vertex_moments, NoiseParams};
use crate::links::{merge_vertex, LinkParams, Links, MergeScratch, RaySetup};
use crate::sampling::stream::Stream;
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::{Vec3, Vec4};
use half::f16;
use rayon::prelude::*;
use std::time::Instant;

/// A second link group at each sampled vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NoiseCheck {
    /// The sampled vertices, ascending (empty: no check, the model's ratio).
    pub vertices: Vec<u32>,
    /// Row `i`: the second group of `vertices[i]`, `(target, weight)`
    /// links (weights unitless, as [`Links::weights`]).
    pub groups: Csr<(u32, f16)>,
    /// Rays the links had per vertex when the check was shot.
    pub rays_per_vertex: u32,
    /// Vertices in all: sampled vertex `i` stands for the vertices of its
    /// stratum, `[floor(i n / m), floor((i + 1) n / m))`.
    pub scene_vertices: usize,
    /// Kernel weights between sampled vertices (module doc), row `i` over
    /// all `m`: `kernel[i * m..(i + 1) * m]`; empty: one ratio for the scene.
    pub kernel: Vec<f32>,
    /// Rays shot, `k*k` a sampled vertex (those diving under the vertex's
    /// own triangles included, as [`crate::links::LinkStats::rays`] counts them).
    pub rays: u64,
    /// Time spent, ms.
    pub ms: f64,
}

/// `m` vertices of `n` spread by index (see the module doc), ascending.
pub fn sample_vertices(n: usize, m: usize, seed: u64) -> Vec<u32> {
    if m == 0 || n == 0 {
        return Vec::new();
    }
    if n <= m {
        return (0..n as u32).collect();
    }
    let lo = |i: usize| (i as u64 * n as u64 / m as u64) as u32;
    (0..m)
        .map(|i| {
            let h = Stream::NOISE_CHECK.hash(seed, &[i as u64]);
            let width = u64::from(lo(i + 1) - lo(i));
            lo(i) + (((h >> 32) * width) >> 32) as u32
        })
        .collect()
}

/// Gaussian kernel weights between the points `at`: row `i` is
/// `exp(-|p_i - p_j|^2 / h_i^2)` with `h_i` the distance from `p_i` to its
/// `k`-th nearest point (itself included), so about `k` points carry a
/// row. Continuous in the positions (no ties to break: a scaled or
/// rounded scene gives nearly the same weights).
fn kernel_weights(at: &[Vec3], k: usize) -> Vec<f32> {
    let m = at.len();
    let k = k.clamp(1, m);
    at.par_iter()
        .flat_map_iter(|p| {
            let d2: Vec<f32> = at.iter().map(|q| p.distance_squared(*q)).collect();
            let mut sorted = d2.clone();
            sorted.select_nth_unstable_by(k - 1, f32::total_cmp);
            let h2 = sorted[k - 1];
            d2.into_iter().map(move |d| if h2 > 0.0 { (-d / h2).exp() } else { f32::from(d == 0.0) })
        })
        .collect()
}

/// The stratum of vertex `v` of `n` split into `m <= n` strata
/// `[floor(i n / m), floor((i + 1) n / m))`: `ceil((v + 1) m / n) - 1`.
fn stratum(v: usize, n: usize, m: usize) -> usize {
    (((v as u64 + 1) * m as u64 - 1) / n as u64) as usize
}

impl NoiseCheck {
    /// Shoots the check's rays at `params.check_vertices` vertices of
    /// `scene` with `tracer` as one batch (the links' ray setup,
    /// [`RaySetup::trace_vertices`], with the check's seed).
    pub fn compute(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        link: &LinkParams,
        params: &NoiseParams,
    ) -> crate::Result<NoiseCheck> {
        let start = Instant::now();
        let vertices = sample_vertices(scene.vertex_count(), params.check_vertices as usize, link.seed);
        if vertices.is_empty() {
            return Ok(NoiseCheck::default());
        }
        let setup = RaySetup::new(scene, &LinkParams { seed: Stream::NOISE_CHECK.seed(link.seed), ..*link });
        let n_rays = setup.directions.len();
        let weight_per_ray = std::f64::consts::PI / n_rays as f64;
        let records = setup.trace_vertices(tracer, &vertices)?;
        // Per sampled vertex: its merged group.
        let groups: Vec<(Vec<u32>, Vec<f16>)> = records
            .par_chunks(n_rays.max(1))
            .map_init(MergeScratch::default, |merge, records| {
                let (mut targets, mut weights) = (Vec::new(), Vec::new());
                merge_vertex(records, &scene.triangles, weight_per_ray, merge, &mut targets, &mut weights);
                (targets, weights)
            })
            .collect();
        let rays = (vertices.len() * n_rays) as u64;
        let mut out = NoiseCheck {
            vertices,
            rays_per_vertex: n_rays as u32,
            rays,
            scene_vertices: scene.vertex_count(),
            ..Default::default()
        };
        let mut rows = RowBuilder::new();
        for (targets, weights) in groups {
            rows.extend(targets.into_iter().zip(weights));
            rows.end_row();
        }
        out.groups = rows.finish();
        if params.check_neighbours > 0 {
            let at: Vec<Vec3> = out.vertices.iter().map(|&v| scene.positions[v as usize]).collect();
            out.kernel = kernel_weights(&at, params.check_neighbours as usize);
        }
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(out)
    }

    /// True when no vertex is sampled.
    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// Per sampled vertex: half the squared difference of its two
    /// estimates and its independent-ray variance ([`iid_variance`]),
    /// channels summed, for radiosity moments `b`
    /// ([`crate::exchange::denoise::noise::radiosity_moments`]); `None` without a check or
    /// when the check was shot at another ray count than `links`'.
    fn sample_terms(&self, links: &Links, b: &[[Vec4; 2]], rays_per_vertex: u32) -> Option<Vec<(f64, f64)>> {
        if self.is_empty() || self.rays_per_vertex != rays_per_vertex {
            return None;
        }
        Some(
            self.vertices
                .par_iter()
                .enumerate()
                .map(|(i, &v)| {
                    let (e, m2) = vertex_moments(links, b, v as usize);
                    let e2: Vec3 =
                        self.groups.row(i).iter().map(|&(t, w)| b[t as usize][0].truncate() * w.to_f32()).sum();
                    let iid = iid_variance(e, m2, rays_per_vertex).element_sum();
                    (0.5 * (e - e2).length_squared() as f64, iid as f64)
                })
                .collect(),
        )
    }

    /// The ratio over the whole sample: summed actual over summed
    /// independent-ray variance; `None` when the sample has none.
    fn whole_sample(terms: &[(f64, f64)]) -> Option<f32> {
        let (actual, iid) = terms.iter().fold((0.0, 0.0), |a, t| (a.0 + t.0, a.1 + t.1));
        (iid > 0.0 && actual.is_finite()).then(|| (actual / iid) as f32)
    }

    /// The measured ratio of actual to independent-ray variance over the
    /// whole sample (module doc); `None` as [`Self::ratios`].
    pub fn ratio(&self, links: &Links, b: &[[Vec4; 2]], rays_per_vertex: u32) -> Option<f32> {
        Self::whole_sample(&self.sample_terms(links, b, rays_per_vertex)?)
    }

    /// The measured ratio at every vertex: that of the sampled vertex of
    /// its stratum, over the kernel around it (module doc; the whole
    /// sample's where the kernel sees no variance); `None` without a check,
    /// when it was shot at another ray count than `links`', or when the
    /// sample has no variance at all.
    pub fn ratios(&self, links: &Links, b: &[[Vec4; 2]], rays_per_vertex: u32) -> Option<Vec<f32>> {
        let terms = self.sample_terms(links, b, rays_per_vertex)?;
        let global = Self::whole_sample(&terms)?;
        let (n, m) = (self.scene_vertices, self.vertices.len());
        if self.kernel.is_empty() {
            return Some(vec![global; n]);
        }
        let per_sample: Vec<f32> = self
            .kernel
            .par_chunks(m)
            .map(|row| {
                let (a, i) =
                    row.iter().zip(&terms).fold((0.0, 0.0), |s, (&w, t)| (s.0 + w as f64 * t.0, s.1 + w as f64 * t.1));
                if i > 0.0 {
                    (a / i) as f32
                } else {
                    global
                }
            })
            .collect();
        Some((0..n).into_par_iter().map(|v| per_sample[stratum(v, n, m)]).collect())
    }

    /// Checks the structure against a scene of `n` vertices: sample ids
    /// ascending and in range, CSR offsets, targets in range, weights
    /// finite and positive, every group's weights summing to at most pi.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.is_empty() {
            return Ok(());
        }
        if self.vertices.windows(2).any(|w| w[0] >= w[1]) || self.vertices.iter().any(|&v| v as usize >= n) {
            return Err(format!("noise check: sampled vertices not ascending or out of range ({n} vertices)"));
        }
        if self.groups.rows() != self.vertices.len() {
            return Err(format!("noise check: {} groups for {} vertices", self.groups.rows(), self.vertices.len()));
        }
        self.groups
            .validate(self.vertices.len(), |_, &(t, w)| {
                if t as usize >= n {
                    return Err(format!("target {t} out of range ({n} vertices)"));
                }
                if !(w.to_f32().is_finite() && w.to_f32() > 0.0) {
                    return Err(format!("weight {w} not finite and positive"));
                }
                Ok(())
            })
            .map_err(|e| format!("noise check: {e}"))?;
        let m = self.vertices.len();
        if self.scene_vertices != n {
            return Err(format!("noise check: made for {} vertices, not {n}", self.scene_vertices));
        }
        if !self.kernel.is_empty() && self.kernel.len() != m * m {
            return Err(format!("noise check: {} kernel weights for {m} samples", self.kernel.len()));
        }
        if let Some(w) = self.kernel.iter().find(|w| !(w.is_finite() && (0.0..=1.0).contains(*w))) {
            return Err(format!("noise check: kernel weight {w} not in [0, 1]"));
        }
        for i in 0..m {
            let sum: f32 = self.groups.row(i).iter().map(|w| w.1.to_f32()).sum();
            if sum > std::f32::consts::PI * 1.01 {
                return Err(format!("noise check: vertex {}'s weights sum to {sum} > pi", self.vertices[i]));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sample is spread over the index range, ascending, deterministic, and all vertices when few.
    #[test]
    fn sample_spreads_over_the_vertices() {
        let s = sample_vertices(10_000, 512, 7);
        assert_eq!(s.len(), 512);
        assert!(s.windows(2).all(|w| w[0] < w[1]));
        for (i, &v) in s.iter().enumerate() {
            assert!(v >= (i * 10_000 / 512) as u32 && v < ((i + 1) * 10_000 / 512) as u32, "sample {i}: {v}");
        }
        for (n, seed) in [(3304, 1), (3304, 2), (513, 3), (1025, 4)] {
            let s = sample_vertices(n, 512, seed);
            assert!(
                s.windows(2).all(|w| w[0] < w[1]) && s.iter().all(|&v| (v as usize) < n),
                "{n} vertices, seed {seed}"
            );
        }
        assert_eq!(s, sample_vertices(10_000, 512, 7));
        assert_ne!(s, sample_vertices(10_000, 512, 8));
        assert_eq!(sample_vertices(300, 512, 7), (0..300).collect::<Vec<u32>>());
        assert!(sample_vertices(300, 0, 7).is_empty());
        // Each sampled vertex lies in its own stratum, and strata tile the vertices.
        for (n, m) in [(3304, 512), (513, 512), (10_000, 7), (5, 5)] {
            for (i, &v) in sample_vertices(n, m, 9).iter().enumerate() {
                assert_eq!(stratum(v as usize, n, m), i, "{n} vertices, {m} strata");
            }
            let strata: Vec<usize> = (0..n).map(|v| stratum(v, n, m)).collect();
            assert!(strata.windows(2).all(|w| w[1] == w[0] || w[1] == w[0] + 1) && strata[n - 1] == m - 1);
        }
    }
}
