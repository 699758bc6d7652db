//! The whole pipeline for one prepared scene: kd-tree, vertex links,
//! light links, bounces, smoothing (docs/DESIGN.md, pipeline), with the figures
//! of every stage, on the CPU or the GPU ([`Compute`]). The kd-tree is
//! always built on the CPU; links, light links and bounces run where
//! `Compute` says, and a GPU failure after setup falls back to the CPU
//! with one line on stderr. Lengths in metres, irradiance in W/m^2, times in ms.

use crate::bvh::{BvhBuildParams, BvhStats};
use crate::exchange::{
    EmitterLinkParams, EmitterLinks, GatherParams, GatherResult, HiddenParams, LightLinkParams, LightLinks, NearLight,
    NoiseCheck, SmoothParams,
};
use crate::gpu::{self, Backend, DeviceShare, GpuDevice, GpuLinks, GpuTracer, LogicalDevice, ScheduleParams};
use crate::kdtree::{KdBuildParams, KdStats, KdTree};
use crate::links::{self, LinkParams, LinkStats, Links};
use crate::scene::prep::PreparedScene;
use crate::scene::{Settings, TracerKind};
use crate::trace::Accel;
use glam::Vec3;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod deform;
mod retrace;
use retrace::{near_emitters, near_gather, sky_rays};
mod solve;
pub use deform::{DeformStats, Preview, PREVIEW_RAYS};
pub use solve::Sources;

/// Where links, light links and bounces are computed.
#[derive(Clone, Debug, Default)]
pub enum Compute {
    #[default]
    Cpu,
    Gpu(GpuCompute),
}

/// The GPU devices of a solve and how to split them.
#[derive(Clone, Debug)]
pub struct GpuCompute {
    pub devices: Vec<Arc<GpuDevice>>,
    /// Logical devices per adapter (`--devices N`: the scheduler splits work between them).
    pub logical_per_device: usize,
    /// Artificial extra time per vertex for each logical device, in order (scheduler tests).
    pub delays: Vec<Duration>,
    pub schedule: ScheduleParams,
}

impl Compute {
    /// Resolves a backend setting. `Auto` with no hardware GPU gives the
    /// CPU path and a one-line note saying so; `Gpu` with no adapter is an error.
    pub fn from_backend(backend: Backend, logical_per_device: usize) -> crate::Result<(Compute, Option<String>)> {
        let devices = gpu::devices_for(backend)?;
        if devices.is_empty() {
            let note = (backend == Backend::Auto).then(|| {
                "no hardware GPU adapter found: using the CPU path (--backend gpu uses software adapters too)"
                    .to_string()
            });
            return Ok((Compute::Cpu, note));
        }
        let schedule = ScheduleParams::default();
        Ok((
            Compute::Gpu(GpuCompute {
                devices,
                logical_per_device: logical_per_device.max(1),
                delays: Vec::new(),
                schedule,
            }),
            None,
        ))
    }

    /// "cpu (threads, processor, BVH node tests)" or the adapters used.
    pub fn describe(&self) -> String {
        match self {
            Compute::Cpu => format!(
                "cpu ({} threads; {}; BVH node tests {:?})",
                rayon::current_num_threads(),
                cpu_model(),
                crate::bvh::Isa::detect()
            ),
            Compute::Gpu(g) => {
                let names: Vec<String> = g.devices.iter().map(|d| d.describe()).collect();
                let split = if g.logical_per_device > 1 {
                    format!(" x{} logical", g.logical_per_device)
                } else {
                    String::new()
                };
                format!("gpu: {}{split}", names.join(", "))
            }
        }
    }
}

/// GPU resources a solver keeps between solves.
pub struct GpuState {
    /// Traces shadow rays when lights move.
    pub tracer: GpuTracer,
    /// Links and albedo on the device.
    pub links: GpuLinks,
    /// How link generation was split between devices.
    pub shares: Vec<DeviceShare>,
}

/// All stage parameters, defaults as listed in docs/DESIGN.md, "Defaults".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveParams {
    /// The CPU structure rays go through (the GPU path always walks its kd-tree).
    pub tracer: TracerKind,
    /// The wide BVH of `tracer = bvh`.
    pub bvh: BvhBuildParams,
    /// kd-tree of `tracer = kd` on the CPU.
    pub kd: KdBuildParams,
    /// kd-tree for the GPU path, whose shader tests one triangle per step
    /// ([`KdBuildParams::for_gpu`]); the hits are the same.
    pub kd_gpu: KdBuildParams,
    pub links: LinkParams,
    pub light: LightLinkParams,
    /// Next-event estimation toward emissive surfaces ([`crate::exchange::emitter_links`]).
    pub emitter: EmitterLinkParams,
    /// The emitters' light at near hits ([`crate::exchange::near_emitters`]).
    pub near_emitter: crate::exchange::NearEmitterParams,
    /// The sky's light at near hits ([`crate::exchange::near_sky`]).
    pub near_sky: crate::exchange::NearSkyParams,
    /// The emitter groups as a control variate of the first bounce
    /// ([`crate::exchange::emitter_cv`]); default on.
    pub emitter_cv: bool,
    /// The later bounces' light at near hits ([`crate::exchange::near_gather`]).
    pub near_gather: crate::exchange::NearGatherParams,
    /// Gradient-corrected radiosity at link hits ([`crate::exchange::reconstruct`]):
    /// removes linear interpolation's dark bias at surfaces' borders; default on.
    pub reconstruct: bool,
    pub gather: GatherParams,
    /// Correction of hidden vertices as link targets ([`crate::exchange::hidden`]).
    pub hidden: HiddenParams,
    /// More rays where a vertex's view of the sky has an edge ([`crate::sky::refine`]).
    pub sky: crate::sky::SkyRefineParams,
    /// Feature angle of smoothing, degrees; 0: off.
    pub smoothing_angle_deg: f32,
    /// The smoothing filter (noise-aware by default, [`mod@crate::exchange::smooth`]).
    pub smoothing: SmoothParams,
}

impl Default for SolveParams {
    fn default() -> Self {
        SolveParams {
            tracer: TracerKind::default(),
            bvh: BvhBuildParams::default(),
            kd: KdBuildParams::default(),
            kd_gpu: KdBuildParams::for_gpu(),
            links: LinkParams::default(),
            light: LightLinkParams::default(),
            emitter: EmitterLinkParams::default(),
            near_emitter: Default::default(),
            near_sky: Default::default(),
            emitter_cv: true,
            near_gather: Default::default(),
            reconstruct: true,
            gather: GatherParams::default(),
            hidden: HiddenParams::default(),
            sky: Default::default(),
            smoothing_angle_deg: 0.0,
            smoothing: SmoothParams::default(),
        }
    }
}

impl SolveParams {
    /// Parameters with the scene's settings applied.
    pub fn from_settings(s: &Settings) -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = s.rays_per_vertex;
        p.links.seed = s.seed;
        p.emitter.seed = s.seed;
        p.near_emitter.seed = s.seed;
        p.near_sky.seed = s.seed;
        p.near_gather.seed = s.seed;
        // Emitters' direct light as many rays as the links (at least 64): its noise falls with theirs.
        p.emitter.samples = s.rays_per_vertex.max(64);
        // Sky portals' rays likewise scale with the links'.
        p.sky.portal = crate::sky::PortalParams::for_link_rays(s.rays_per_vertex);
        p.tracer = s.tracer;
        p.gather.bounces = s.bounces;
        p.smoothing_angle_deg = s.smoothing_angle_deg;
        p
    }
}

/// Figures of one solve.
#[derive(Clone, Debug, Default)]
pub struct SolveStats {
    pub vertices: usize,
    pub triangles: usize,
    pub dropped_triangles: usize,
    /// Build time of the structure the rays went through, ms.
    pub accel_build_ms: f64,
    /// Bytes of that structure.
    pub accel_bytes: usize,
    /// The kd-tree's figures, when rays went through one.
    pub kd: Option<KdStats>,
    /// The BVH's figures, when rays went through one.
    pub bvh: Option<BvhStats>,
    pub links: LinkStats,
    pub shadow_rays: u64,
    pub light_links_ms: f64,
    /// Shadow rays toward emissive surfaces and their time, ms.
    pub emitter_rays: u64,
    pub emitter_links_ms: f64,
    /// Rays of the sky's refined cells and their time, ms.
    pub sky_rays: u64,
    pub sky_ms: f64,
    /// Shadow rays toward the sky's portals and their time, ms.
    pub portal_rays: u64,
    pub portal_ms: f64,
    /// Shadow rays from near hits toward emitters and their time, ms.
    pub near_emitter_rays: u64,
    pub near_emitter_ms: f64,
    /// Shadow rays from near hits toward the sky and their time, ms.
    pub near_sky_rays: u64,
    pub near_sky_ms: f64,
    /// Gather rays from near hits and their time, ms.
    pub near_gather_rays: u64,
    pub near_gather_ms: f64,
    /// Rays of the noise check ([`crate::exchange::noise_check`]) and their time, ms.
    pub noise_check_rays: u64,
    pub noise_check_ms: f64,
    /// Near hits ([`crate::links::near`]) and the shadow rays and time of their light columns, ms.
    pub near_hits: u64,
    pub near_rays: u64,
    pub near_ms: f64,
    pub bounces: u32,
    pub tail_relative: f32,
    pub gather_ms: f64,
    pub smooth_ms: f64,
    /// "cpu (N threads; processor; node tests)" or the adapters.
    pub backend: String,
    /// The tracer the rays went through ("bvh", "kd" or "gpu-kd").
    pub tracer: String,
    /// Build time of the CPU wide BVH, ms (NaN when the solve used no BVH).
    pub bvh_build_ms: f64,
    /// Shadow rays per second of the last light-link computation.
    pub shadow_rays_per_second: f64,
    /// Link generation per logical device (GPU path only).
    pub devices: Vec<DeviceShare>,
    /// Bytes of the per-ray state kept for selective updates (0 without dynamic meshes).
    pub ray_state_bytes: u64,
}

/// Per-vertex results.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    /// Direct irradiance, exact at the vertex (point visibility), W/m^2.
    pub e_direct: Vec<Vec3>,
    /// Irradiance from the sky ([`crate::sky`]), W/m^2: direct light,
    /// reported on its own (zero without a sky or where no ray missed).
    pub e_sky: Vec<Vec3>,
    /// Direct irradiance from emissive surfaces ([`crate::exchange::emitter_links`]),
    /// W/m^2: part of `e_indirect` (light that left a surface), reported apart.
    pub e_emitter: Vec<Vec3>,
    /// The first bounce's correction at near hits ([`crate::exchange::near_field`]),
    /// W/m^2 (negative where the links brought light that is not there):
    /// part of `e_indirect`, reported apart.
    pub e_near: Vec<Vec3>,
    /// The emitter groups' control variate of the first bounce
    /// ([`crate::exchange::emitter_cv`]), W/m^2 (of either sign, zero in
    /// expectation): part of the gathered `E_i`, smoothed with it; empty
    /// without emitter groups.
    pub e_cv: Vec<Vec3>,
    /// The later bounces' correction at near hits
    /// ([`crate::exchange::near_gather`]), W/m^2: part of the gathered
    /// `E_i`, smoothed with it; empty without near hits.
    pub e_near_gather: Vec<Vec3>,
    /// The direct irradiance the bounces started from (the light links'
    /// [`crate::exchange::BounceSource`] plus `e_sky`, `e_emitter`, `e_near` and `e_cv`),
    /// W/m^2. Emitters without emitter links add `M_e / pi` to the first
    /// radiosity ([`crate::exchange::gather::source_radiosity`]).
    pub e_source: Vec<Vec3>,
    /// Indirect irradiance after smoothing (the gathered bounces and
    /// `e_cv` smoothed, plus `e_emitter` and `e_near`, at least 0), W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Indirect irradiance before smoothing (the gathered bounces after the
    /// hidden-vertex correction, plus `e_cv`, `e_emitter` and `e_near`, at least 0;
    /// `gather.e_indirect` is the bounces before the correction), W/m^2.
    pub e_indirect_raw: Vec<Vec3>,
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

/// A scene with its acceleration structure, vertex links and light links built.
pub struct Solver {
    pub scene: PreparedScene,
    pub params: SolveParams,
    /// The CPU structure rays go through: `params.tracer`'s on the CPU path,
    /// the kd-tree the GPU walks on the GPU path.
    pub accel: Accel,
    pub links: Links,
    pub light_links: LightLinks,
    /// Direct light of emissive surfaces by next-event estimation.
    pub emitter_links: EmitterLinks,
    /// The lights' direct light at the links' near hits.
    pub near_light: NearLight,
    /// The emitters' direct light at the links' near hits.
    pub near_emitters: crate::exchange::NearEmitters,
    /// The sky's refined cells ([`crate::sky::refine`]).
    pub sky_refine: crate::sky::SkyRefinement,
    /// Every vertex's rays toward the sky's portals ([`crate::sky::portal`]).
    pub sky_portals: crate::sky::PortalSamples,
    /// The sky's light at the links' near hits ([`crate::exchange::near_sky`]).
    pub near_sky: crate::exchange::NearSky,
    /// The later bounces' light at the links' near hits ([`crate::exchange::near_gather`]).
    pub near_gather: crate::exchange::NearGather,
    /// A second estimate at a sample of vertices, which calibrates the noise estimate ([`crate::exchange::noise_check`]).
    pub noise_check: NoiseCheck,
    /// Present when links, light links and bounces run on a GPU.
    pub gpu: Option<GpuState>,
    pub compute: Compute,
    /// Every link ray's hit id, kept on the CPU path for scenes with
    /// dynamic meshes only (selective updates, [`Solver::deform`]).
    pub ray_hits: Option<links::RayHits>,
    /// The hidden vertices' stand-ins for the current links, computed on
    /// the first solve that needs them (two passes over the links:
    /// 278 ms on conference) and kept; [`Solver::links_changed`] drops them.
    stand_ins_cache: StandInsCache,
    /// The emitter groups' control variate for the current links
    /// ([`Solver::emitter_cv`]); [`Solver::emitters_changed`] drops it.
    emitter_cv_cache: std::sync::Mutex<Option<Arc<crate::exchange::EmitterCv>>>,
    /// The radiosity correction's weights for the current geometry
    /// ([`Solver::reconstruction`]); [`Solver::links_changed`] drops them.
    reconstruction_cache: std::sync::Mutex<Option<Arc<crate::exchange::Reconstruction>>>,
}

/// Hidden vertices and their linkers, with the parameters they were found with.
type StandInsCache = std::sync::Mutex<Option<(HiddenParams, Arc<Vec<crate::exchange::hidden::StandIn>>)>>;

impl Solver {
    /// Builds the acceleration structure (`params.tracer`), the vertex
    /// links (reporting `progress(done, total)` vertices) and the light links.
    pub fn new(scene: PreparedScene, params: SolveParams, progress: &(dyn Fn(usize, usize) + Sync)) -> Solver {
        let accel = Accel::build(params.tracer, &scene.positions, &scene.triangles, &params.bvh, &params.kd);
        Solver::on_cpu(scene, params, accel, progress)
    }

    /// The CPU solver with `accel` built over `scene`: links (with per-ray
    /// state for scenes with dynamic meshes) and light links traced.
    fn on_cpu(
        scene: PreparedScene,
        params: SolveParams,
        accel: Accel,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Solver {
        let record = scene.meshes.iter().any(|m| m.dynamic);
        let (links, ray_hits) = links::shoot_links_recording(&scene, &accel, &params.links, record, progress);
        let light_links = LightLinks::compute(&scene, &accel, &params.light);
        let emitter_links = EmitterLinks::compute(&scene, &accel, &params.emitter).expect("a CPU tracer cannot fail");
        let (sky_refine, sky_portals, near_sky) =
            sky_rays(&scene, &accel, &links, &params).expect("a CPU tracer cannot fail");
        let near_light =
            NearLight::compute(&scene, &links.near, &accel, &params.light).expect("a CPU tracer cannot fail");
        let near_emitters =
            near_emitters(&scene, &links, &emitter_links, &accel, &params).expect("a CPU tracer cannot fail");
        let near_gather = near_gather(&scene, &links, &accel, &params).expect("a CPU tracer cannot fail");
        let noise_check = NoiseCheck::compute(&scene, &accel, &params.links, &params.smoothing.noise);
        Solver {
            scene,
            params,
            accel,
            links,
            light_links,
            emitter_links,
            near_light,
            near_emitters,
            sky_refine,
            sky_portals,
            near_sky,
            near_gather,
            noise_check,
            gpu: None,
            compute: Compute::Cpu,
            ray_hits,
            stand_ins_cache: Default::default(),
            reconstruction_cache: Default::default(),
            emitter_cv_cache: Default::default(),
        }
    }

    /// The solver of `scene`, a deformation of this solver's scene (same
    /// vertices and triangles, new positions), with `params`: on the CPU
    /// path with an unchanged tracer and triangles, the BVH is refitted
    /// ([`crate::bvh::Bvh::update`], which rebuilds when the refit's SAH
    /// cost has grown past `rebuild_factor`), the kd-tree rebuilt, then
    /// links and light links are traced anew. Anything else builds from
    /// scratch ([`Solver::new`]). Returns the solver and whether the BVH
    /// was refitted.
    pub fn deformed(
        self,
        scene: PreparedScene,
        params: SolveParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> (Solver, bool) {
        let same_mesh = self.gpu.is_none()
            && self.scene.triangles == scene.triangles
            && params.tracer == self.params.tracer
            && params.bvh == self.params.bvh
            && params.kd == self.params.kd;
        let Accel::Bvh(mut bvh) = self.accel else {
            return (Solver::new(scene, params, progress), false);
        };
        if !same_mesh {
            return (Solver::new(scene, params, progress), false);
        }
        let refitted = bvh.update(&scene.positions, &scene.triangles) == crate::bvh::refit::Update::Refit;
        (Solver::on_cpu(scene, params, Accel::Bvh(bvh), progress), refitted)
    }

    /// Builds everything on `compute`: the kd-tree on the CPU (with
    /// `params.kd_gpu` for a GPU), then links,
    /// light links (and later the bounces) on the GPU when it is one.
    pub fn new_on(
        scene: PreparedScene,
        params: SolveParams,
        compute: &Compute,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> crate::Result<Solver> {
        let g = match compute {
            Compute::Cpu => return Ok(Solver::new(scene, params, progress)),
            Compute::Gpu(g) => g,
        };
        let kd = KdTree::build(&scene.positions, &scene.triangles, &params.kd_gpu);
        let mut logical = Vec::new();
        for dev in &g.devices {
            for i in 0..g.logical_per_device {
                let label =
                    if g.logical_per_device > 1 { format!("{} #{i}", dev.info.name) } else { dev.info.name.clone() };
                let delay = g.delays.get(logical.len()).copied().unwrap_or_default();
                logical.push(LogicalDevice {
                    label,
                    tracer: GpuTracer::new(dev.clone(), &kd)?,
                    delay_per_vertex: delay,
                });
            }
        }
        let (links, shares) = gpu::shoot_links_gpu(&scene, &params.links, &g.schedule, &mut logical, progress)?;
        let tracer = logical.swap_remove(0).tracer;
        let light_links = LightLinks::compute_with(&scene, &tracer, &params.light)?;
        let emitter_links = EmitterLinks::compute(&scene, &tracer, &params.emitter)?;
        let (sky_refine, sky_portals, near_sky) = sky_rays(&scene, &tracer, &links, &params)?;
        let near_light = NearLight::compute(&scene, &links.near, &tracer, &params.light)?;
        let near_emitters = near_emitters(&scene, &links, &emitter_links, &tracer, &params)?;
        // On the CPU, with the noise check: the GPU tracer shoots whole vertices' ray sets only.
        let near_gather = near_gather(&scene, &links, &kd, &params)?;
        // On the CPU: the GPU tracer shoots whole vertices' ray sets only.
        let noise_check = NoiseCheck::compute(&scene, &kd, &params.links, &params.smoothing.noise);
        let gpu_links = GpuLinks::new(tracer.dev.clone(), &links, &scene.albedo)?;
        let gpu = GpuState { tracer, links: gpu_links, shares };
        Ok(Solver {
            scene,
            params,
            accel: Accel::Kd(kd),
            links,
            light_links,
            emitter_links,
            near_light,
            near_emitters,
            sky_refine,
            sky_portals,
            near_sky,
            near_gather,
            noise_check,
            gpu: Some(gpu),
            compute: compute.clone(),
            ray_hits: None,
            stand_ins_cache: Default::default(),
            reconstruction_cache: Default::default(),
            emitter_cv_cache: Default::default(),
        })
    }

    /// Brings the light links up to date with `scene.lights` (after lights
    /// moved, were added or removed, or changed power): only lights at a new
    /// position or direction are traced ([`LightLinks::update_with`]),
    /// and preview columns are replaced by full ones.
    pub fn update_lights(&mut self) {
        self.refresh_lights(false);
    }

    /// As [`Solver::update_lights`], but lights that need tracing get quick
    /// preview columns ([`LightLinks::preview_with`]). Returns true if this
    /// call traced any (then [`Solver::update_lights`] refines them).
    pub fn preview_lights(&mut self) -> bool {
        self.refresh_lights(true);
        self.light_links.shadow_rays > 0 && self.light_links.coarse.contains(&true)
    }

    fn refresh_lights(&mut self, preview: bool) {
        let update = |l: &mut LightLinks, scene: &PreparedScene, tracer: &dyn crate::trace::Tracer| {
            if preview {
                l.preview_with(scene, tracer, &self.params.light)
            } else {
                l.update_with(scene, tracer, &self.params.light)
            }
        };
        // A preview leaves the near hits' columns as they are: a moved
        // light's is stale, so the preview goes without the near-field
        // correction ([`NearLight::covers`]) and the full update traces it.
        let near = |n: &mut NearLight, scene: &PreparedScene, tracer: &dyn crate::trace::Tracer| {
            if preview {
                return Ok(());
            }
            n.update(scene, &self.links.near, tracer, &self.params.light)
        };
        if let Some(g) = &self.gpu {
            let traced = update(&mut self.light_links, &self.scene, &g.tracer)
                .and_then(|_| near(&mut self.near_light, &self.scene, &g.tracer));
            match traced {
                Ok(_) => return,
                Err(e) => eprintln!("warning: {e}; computing light links on the CPU"),
            }
        }
        update(&mut self.light_links, &self.scene, &self.accel).expect("the CPU tracer cannot fail");
        near(&mut self.near_light, &self.scene, &self.accel).expect("the CPU tracer cannot fail");
    }

    /// Bytes of the per-ray state kept for selective updates ([`Solver::ray_hits`]).
    pub fn ray_state_bytes(&self) -> u64 {
        self.ray_hits.as_ref().map_or(0, |h| h.bytes())
    }

    /// The tracer the rays go through: "bvh", "kd" or "gpu-kd".
    pub fn tracer_name(&self) -> &'static str {
        if self.gpu.is_some() {
            "gpu-kd"
        } else {
            self.accel.kind().name()
        }
    }

    /// Build time of the CPU wide BVH, ms; NaN when this solver has none.
    pub fn bvh_build_ms(&self) -> f64 {
        self.accel.bvh().map_or(f64::NAN, |b| b.stats.build_ms)
    }

    /// Build time of the acceleration structure the rays went through, ms.
    pub fn accel_build_ms(&self) -> f64 {
        self.accel.build_ms()
    }

    /// Figures of the built structures and of `solution`.
    pub fn stats(&self, solution: &Solution, smooth_ms: f64) -> SolveStats {
        SolveStats {
            vertices: self.scene.vertex_count(),
            triangles: self.scene.triangles.len(),
            dropped_triangles: self.scene.dropped_triangles,
            accel_build_ms: self.accel.build_ms(),
            accel_bytes: self.accel.bytes(),
            kd: self.accel.kd().map(|k| k.stats),
            bvh: self.accel.bvh().map(|b| b.stats),
            links: self.links.stats,
            shadow_rays: self.light_links.shadow_rays,
            light_links_ms: self.light_links.ms,
            emitter_rays: self.emitter_links.shadow_rays,
            emitter_links_ms: self.emitter_links.ms,
            sky_rays: self.sky_refine.rays,
            sky_ms: self.sky_refine.ms,
            portal_rays: self.sky_portals.rays,
            portal_ms: self.sky_portals.ms,
            noise_check_rays: self.noise_check.rays,
            noise_check_ms: self.noise_check.ms,
            near_hits: self.links.near.hits.len() as u64,
            near_emitter_rays: self.near_emitters.shadow_rays,
            near_emitter_ms: self.near_emitters.ms,
            near_sky_rays: self.near_sky.shadow_rays,
            near_sky_ms: self.near_sky.ms,
            near_gather_rays: self.near_gather.rays,
            near_gather_ms: self.near_gather.ms,
            near_rays: self.near_light.shadow_rays,
            near_ms: self.near_light.ms,
            bounces: solution.gather.bounces,
            tail_relative: solution.gather.tail_relative,
            gather_ms: solution.gather.ms,
            smooth_ms,
            backend: self.compute.describe(),
            tracer: self.tracer_name().to_string(),
            bvh_build_ms: self.bvh_build_ms(),
            shadow_rays_per_second: self.light_links.shadow_rays as f64 / (self.light_links.ms.max(1e-9) * 1e-3),
            devices: self.gpu.as_ref().map(|g| g.shares.clone()).unwrap_or_default(),
            ray_state_bytes: self.ray_state_bytes(),
        }
    }
}

/// Convenience: build and solve in one call, timing smoothing too.
pub fn solve(scene: PreparedScene, params: SolveParams) -> (Solver, Solution, SolveStats) {
    let solver = Solver::new(scene, params, &|_, _| {});
    let t = Instant::now();
    let solution = solver.solve();
    let total_ms = t.elapsed().as_secs_f64() * 1e3;
    let stats = solver.stats(&solution, (total_ms - solution.gather.ms).max(0.0));
    (solver, solution, stats)
}

/// The processor's name with its family and model numbers (Linux:
/// `/proc/cpuinfo`; a VM's name alone, "AMD EPYC", does not tell Zen 3 from
/// Zen 4), or the architecture where it cannot be read: figures that set
/// our tracer beside another depend on it (AVX-512 or not, above all).
fn cpu_model() -> String {
    let Ok(info) = std::fs::read_to_string("/proc/cpuinfo") else {
        return std::env::consts::ARCH.to_string();
    };
    // The first processor's value of `key`.
    let field = |key: &str| {
        info.lines()
            .find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.split_whitespace().collect::<Vec<_>>().join(" "))
            .filter(|v| !v.is_empty())
    };
    match (field("model name"), field("cpu family"), field("model")) {
        (Some(name), Some(family), Some(model)) => format!("{name}, family {family} model {model}"),
        (Some(name), _, _) => name,
        _ => std::env::consts::ARCH.to_string(),
    }
}
