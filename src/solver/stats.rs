//! What a solve gives back: per-vertex irradiances ([`Solution`]) and the
//! figures of every stage ([`SolveStats`]). Irradiance in W/m^2, times in
//! ms, sizes in bytes.

use crate::bvh::BvhStats;
use crate::exchange::GatherResult;
use crate::gpu::DeviceShare;
use crate::kdtree::KdStats;
use crate::links::LinkStats;
use glam::Vec3;

/// Figures of one solve.
#[derive(Clone, Debug, Default)]
pub struct SolveStats {
    /// Solver vertices.
    pub vertices: usize,
    /// Triangles of the prepared scene.
    pub triangles: usize,
    /// Zero-area triangles dropped while preparing the scene.
    pub dropped_triangles: usize,
    /// Build time of the structure the rays went through, ms.
    pub accel_build_ms: f64,
    /// Bytes of that structure.
    pub accel_bytes: usize,
    /// The kd-tree's figures, when rays went through one.
    pub kd: Option<KdStats>,
    /// The BVH's figures, when rays went through one.
    pub bvh: Option<BvhStats>,
    /// Counters of the link generation.
    pub links: LinkStats,
    /// Shadow rays of the light links.
    pub shadow_rays: u64,
    /// Time of the light links, ms.
    pub light_links_ms: f64,
    /// Shadow rays toward emissive surfaces and their time, ms.
    pub emitter_rays: u64,
    /// Time of the emitter links, ms.
    pub emitter_links_ms: f64,
    /// Rays of the sky's refined cells and their time, ms.
    pub sky_rays: u64,
    /// Time of the sky's refined cells, ms.
    pub sky_ms: f64,
    /// Shadow rays toward the sky's portals and their time, ms.
    pub portal_rays: u64,
    /// Time of the portal rays, ms.
    pub portal_ms: f64,
    /// Shadow rays from near hits toward emitters and their time, ms.
    pub near_emitter_rays: u64,
    /// Time of the near hits' emitter rays, ms.
    pub near_emitter_ms: f64,
    /// Shadow rays from near hits toward the sky and their time, ms.
    pub near_sky_rays: u64,
    /// Time of the near hits' sky rays, ms.
    pub near_sky_ms: f64,
    /// Gather rays from near hits and their time, ms.
    pub near_gather_rays: u64,
    /// Time of the near hits' gather rays, ms.
    pub near_gather_ms: f64,
    /// Rays of the noise check (`crate::exchange::denoise::noise_check`) and their time, ms.
    pub noise_check_rays: u64,
    /// Time of the noise check, ms.
    pub noise_check_ms: f64,
    /// Near hits (`crate::links::near`) and the shadow rays and time of their light columns, ms.
    pub near_hits: u64,
    /// Shadow rays of the near hits' light columns.
    pub near_rays: u64,
    /// Time of the near hits' light columns, ms.
    pub near_ms: f64,
    /// Bounces the gather ran.
    pub bounces: u32,
    /// Estimated remaining tail of the bounce series relative to the total (the largest channel).
    pub tail_relative: f32,
    /// Time of the gather bounces, ms.
    pub gather_ms: f64,
    /// Time of the smoothing, ms.
    pub smooth_ms: f64,
    /// "cpu (N threads; processor; node tests)" or the adapters.
    pub backend: String,
    /// The tracer the rays went through ("bvh", "kd", "gpu-bvh", "gpu-kd" or "gpu-rq").
    pub tracer: String,
    /// Build time of the CPU wide BVH, ms (NaN when the solve used no BVH).
    pub bvh_build_ms: f64,
    /// Shadow rays per second of the last light-link computation.
    pub shadow_rays_per_second: f64,
    /// Link generation per logical device (GPU path only).
    pub devices: Vec<DeviceShare>,
    /// Bytes of the per-ray state kept for selective updates (0 without dynamic meshes).
    pub ray_state_bytes: u64,
    /// Rays traced on the CPU: the link rays where the links were shot on
    /// the CPU, and all rays of every traced part the CPU structure served
    /// (`Traced::cpu_rays`). On the GPU path it counts what the GPU
    /// tracer does not serve yet (0 once it serves every stage).
    pub cpu_traced_rays: u64,
}

impl SolveStats {
    /// Every ray the solution was traced with: the link rays and each
    /// traced part's rays (light links, emitters, sky, portals, the near
    /// fields, the final gather, the noise check).
    pub fn traced_rays(&self) -> u64 {
        self.links.rays
            + self.shadow_rays
            + self.emitter_rays
            + self.near_emitter_rays
            + self.sky_rays
            + self.portal_rays
            + self.near_sky_rays
            + self.near_rays
            + self.near_gather_rays
            + self.noise_check_rays
    }
}

/// Per-vertex results.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    /// Direct irradiance, exact at the vertex (point visibility), W/m^2.
    pub e_direct: Vec<Vec3>,
    /// Irradiance from the sky (`crate::sky`), W/m^2: direct light,
    /// reported on its own (zero without a sky or where no ray missed).
    pub e_sky: Vec<Vec3>,
    /// Direct irradiance from emissive surfaces (`crate::exchange::sources::emitter_links`),
    /// W/m^2: part of `e_indirect` (light that left a surface), reported apart.
    pub e_emitter: Vec<Vec3>,
    /// The first bounce's correction at near hits (`crate::exchange::near::light`),
    /// W/m^2 (negative where the links brought light that is not there):
    /// part of `e_indirect`, reported apart.
    pub e_near: Vec<Vec3>,
    /// The emitter groups' control variate of the first bounce
    /// (`crate::exchange::sources::emitter_cv`), W/m^2 (of either sign, zero in
    /// expectation): part of the gathered `E_i`, smoothed with it; empty
    /// without emitter groups.
    pub e_cv: Vec<Vec3>,
    /// The later bounces' correction at near hits
    /// (`crate::exchange::near::gather`), W/m^2: part of the gathered
    /// `E_i`, smoothed with it; empty without near hits.
    pub e_near_gather: Vec<Vec3>,
    /// The direct irradiance the bounces started from (the light links'
    /// [`crate::exchange::BounceSource`] plus `e_sky`, `e_emitter`, `e_near` and `e_cv`),
    /// W/m^2. Emitters without emitter links add `M_e / pi` to the first
    /// radiosity (`crate::exchange::bounce::gather::source_radiosity`).
    pub e_source: Vec<Vec3>,
    /// The part of `E_i` gathered over the links, before smoothing: the
    /// bounces after the hidden-vertex correction, `e_cv` and
    /// `e_near_gather` (without `e_emitter` and `e_near`), W/m^2: what the
    /// smoothing and the noise estimate read (`super::Solver::smooth`).
    pub e_gathered: Vec<Vec3>,
    /// Indirect irradiance after smoothing (the gathered bounces and
    /// `e_cv` smoothed, plus `e_emitter` and `e_near`, at least 0), W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Indirect irradiance before smoothing (the gathered bounces after the
    /// hidden-vertex correction, plus `e_cv`, `e_emitter` and `e_near`, at least 0;
    /// `gather.e_indirect` is the bounces before the correction), W/m^2.
    pub e_indirect_raw: Vec<Vec3>,
    /// The bounce gather's own result (unsmoothed bounces, bounce count, tail, time).
    pub gather: GatherResult,
    /// False when smoothing was skipped (feature angle 0): `e_indirect` is then `e_indirect_raw`.
    pub smoothed: bool,
}

impl Solution {
    /// Total irradiance `E_d + E_sky + E_i` per vertex (`E_i` includes the emitters' direct light), W/m^2.
    pub fn total(&self) -> Vec<Vec3> {
        (0..self.e_direct.len()).map(|v| self.e_direct[v] + self.e_sky_at(v) + self.e_indirect[v]).collect()
    }

    /// `E_sky` of vertex `v` (zero without a sky), W/m^2.
    pub fn e_sky_at(&self, v: usize) -> Vec3 {
        self.e_sky.get(v).copied().unwrap_or_default()
    }
}
