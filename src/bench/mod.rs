//! Benchmark of the pipeline (CPU, GPU or both), laid out like the paper's two tables
//! (docs/DESIGN.md, "The paper's figures"): sizes (vertices, tree nodes, links raw
//! and merged in millions, their storage in MB) and times (kd build, link
//! shooting with its ray rate, light links with their shadow-ray rate, three
//! bounces, and the time to the first complete solution from the prepared
//! scene). Times are in ms (first solution also in s), rates in k rays/s;
//! each is the median of several runs after a warm-up, with min and max.
//!
//! [`run_scene`] measures, [`markdown`] formats (with the paper's rows next
//! to ours), [`Stat`] does the statistics; all are free of I/O so they can
//! be tested on synthetic data.
//!
//! Where the Embree 3 peer program is built ([`peer`]), each CPU row also
//! carries Embree's ray rates and build time on the same mesh and rays,
//! measured right after our runs, and the report sets them beside ours.

pub mod bandwidth;
pub mod memory;
pub mod paper;
pub mod peer;
pub mod report;
pub mod scale;
pub mod scenes;

pub use paper::paper_rows;
pub use peer::PeerFigures;
pub use report::markdown;

use crate::scene::{prep, Bounces, SceneDesc};
use crate::solver::{Compute, SolveParams, Solver};
use serde::Serialize;
use std::time::Instant;

/// Which ray-shooting backend to benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Backend {
    /// The CPU path only.
    Cpu,
    /// The GPU path only (an error where no GPU adapter exists).
    Gpu,
    /// The CPU path, then the GPU path.
    Both,
}

impl std::str::FromStr for Backend {
    type Err = crate::Error;
    fn from_str(s: &str) -> crate::Result<Backend> {
        match s.to_ascii_lowercase().as_str() {
            "cpu" => Ok(Backend::Cpu),
            "gpu" => Ok(Backend::Gpu),
            "both" => Ok(Backend::Both),
            _ => Err(crate::Error::Setting(format!("backend '{s}': expected cpu, gpu or both"))),
        }
    }
}

impl Backend {
    /// The compute paths to benchmark, each with its label ("CPU", "GPU");
    /// an error naming the problem when a GPU is asked for and none exists
    /// (any adapter counts, software ones too).
    pub fn computes(self) -> crate::Result<Vec<(String, Compute)>> {
        let mut out = Vec::new();
        if matches!(self, Backend::Cpu | Backend::Both) {
            out.push(("CPU".to_string(), Compute::Cpu));
        }
        if matches!(self, Backend::Gpu | Backend::Both) {
            let (c, _) = Compute::from_backend(crate::gpu::Backend::Gpu, 1)?;
            out.push(("GPU".to_string(), c));
        }
        Ok(out)
    }
}

/// Parameters of a benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BenchParams {
    /// Rays per vertex (default 256, as the paper).
    pub rays_per_vertex: u32,
    /// Measured runs per scene (default 5); the median is reported.
    pub runs: u32,
    /// Unmeasured runs before them (default 1).
    pub warmup: u32,
    /// Bounces timed (default 3, as the paper).
    pub bounces: u32,
    /// Frames rendered (640 x 480, combined view, offscreen including
    /// read-back) to measure render fps after the runs; 0 skips it (default 10).
    pub render_frames: u32,
}

impl Default for BenchParams {
    fn default() -> Self {
        Self { rays_per_vertex: 256, runs: 5, warmup: 1, bounces: 3, render_frames: 10 }
    }
}

/// Median, min and max of a set of measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stat {
    /// The median (the mean of the middle two for an even count).
    pub median: f64,
    /// The smallest value.
    pub min: f64,
    /// The largest value.
    pub max: f64,
}

impl Stat {
    /// Statistics of `xs` (the median of an even count is the mean of the
    /// middle two; non-finite values are ignored; empty gives NaN).
    pub fn of(xs: &[f64]) -> Stat {
        let mut v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return Stat { median: f64::NAN, min: f64::NAN, max: f64::NAN };
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) };
        Stat { median, min: v[0], max: v[n - 1] }
    }
}

/// Times of one run, ms (rates in rays/s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RunTimes {
    /// Building the acceleration structure (kd-tree or BVH, as the tracer uses), ms.
    pub kd_ms: f64,
    /// Shooting the link rays and merging them into links, ms.
    pub links_ms: f64,
    /// Link rays traced per second during link shooting.
    pub rays_per_s: f64,
    /// The light links of all lights, ms.
    pub light_links_ms: f64,
    /// The light links' shadow rays over their time, rays/s.
    pub shadow_rays_per_s: f64,
    /// The near hits' light columns, all lights ([`crate::exchange::near::light`]), ms.
    pub near_ms: f64,
    /// The emitter links ([`crate::exchange::sources::emitter_links`]), ms.
    pub emitter_links_ms: f64,
    /// Their shadow rays over the whole stage's time (form factors,
    /// sampling and tracing), rays/s; NaN without emitter links.
    pub emitter_shadow_rays_per_s: f64,
    /// The same rays over the tracer's time alone, rays/s.
    pub emitter_trace_rays_per_s: f64,
    /// The gather bounces of the first solution, ms.
    pub bounces_ms: f64,
    /// From the prepared scene to smoothed `E_i`: kd + links + light links
    /// (near hits' and emitters' included) + bounces + smoothing.
    pub first_solution_ms: f64,
    /// Light 0 moved by 5 cm (directional: turned by about 3 degrees): a
    /// preview of its light links plus bounces and smoothing
    /// ([`Solver::preview_lights`]); NaN without lights.
    pub light_preview_ms: f64,
    /// The same move, full: that light's light links plus bounces and
    /// smoothing (`Solver::update_lights`); NaN without lights.
    pub light_move_ms: f64,
    /// The sky turned by 30 degrees (a gather-only update: `E_sky` from the
    /// kept miss masks, bounces, smoothing), ms; NaN without a sky.
    pub sky_turn_ms: f64,
    /// Scenes with deformers, on either path ([`time_deformation`]): the selective
    /// update from the rest pose to [`DEFORM_TIME_S`] with bounces and
    /// smoothing, ms; NaN otherwise.
    pub deform_update_ms: f64,
    /// The full update after the same deformation (BVH refit, every link
    /// ray and light link traced again) with bounces and smoothing, ms.
    pub deform_full_ms: f64,
    /// Time to the preview's smoothed `E_i` of a selective update ([`crate::solver::PREVIEW_RAYS`] rays), ms.
    pub deform_preview_ms: f64,
    /// Share of the static vertices' rays the selective update traced again.
    pub deform_static_rays_fraction: f64,
}

/// One scene's figures (sizes from the last run; times over all measured runs).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct BenchRow {
    /// The scene's name.
    pub scene: String,
    /// "CPU" or "GPU".
    pub backend: String,
    /// The adapter(s) or CPU threads used.
    pub device: String,
    /// Solver vertices of the prepared scene.
    pub vertices: usize,
    /// Triangles of the prepared scene.
    pub triangles: usize,
    /// Nodes of the tracer's tree (kd-tree or BVH).
    pub kd_nodes: usize,
    /// Links before merging (three per front hit).
    pub links_raw: u64,
    /// Links after merging.
    pub links_merged: u64,
    /// Raw link storage, MB (u32 target and f32 weight per raw link).
    pub mb_raw: f64,
    /// Merged link storage as the gathers read it, MB.
    pub mb_merged: f64,
    /// Rays shot per vertex.
    pub rays_per_vertex: u32,
    /// Measured runs the statistics cover.
    pub runs: u32,
    /// Building the acceleration structure, ms.
    pub kd_ms: Stat,
    /// Shooting and merging the links, ms.
    pub links_ms: Stat,
    /// Link rays per second, thousands.
    pub k_rays_per_s: Stat,
    /// The light links of all lights, ms.
    pub light_links_ms: Stat,
    /// The light links' shadow rays per second, thousands.
    pub k_shadow_rays_per_s: Stat,
    /// Near hits ([`crate::links::near`]) and the time of their light columns, ms.
    pub near_hits: u64,
    /// The near hits' light columns, all lights, ms.
    pub near_ms: Stat,
    /// Emitter links, ms (NaN without emitters).
    pub emitter_links_ms: Stat,
    /// Their shadow rays per second over the whole stage, and over the
    /// tracer's time alone, k rays/s (NaN without emitters): beside
    /// `k_shadow_rays_per_s`, the light links' rate in the same runs.
    pub k_emitter_shadow_rays_per_s: Stat,
    /// The emitter links' shadow rays per second over the tracer's time alone, thousands (NaN without emitters).
    pub k_emitter_trace_rays_per_s: Stat,
    /// The gather bounces of the first solution, ms (`bounces` of them).
    pub bounces_ms: Stat,
    /// From the prepared scene to the first smoothed solution, ms.
    pub first_solution_ms: Stat,
    /// Light 0 moved a little: the preview with bounces and smoothing, ms (NaN without lights).
    pub light_preview_ms: Stat,
    /// The same light move, full update with bounces and smoothing, ms (NaN without lights).
    pub light_move_ms: Stat,
    /// Scenes with a sky: turning it by 30 degrees (gather only), ms.
    pub sky_turn_ms: Stat,
    /// Scenes with deformers (either path): selective update after a deformation
    /// with bounces and smoothing, ms ([`time_deformation`]); NaN otherwise.
    pub deform_update_ms: Stat,
    /// The full update after the same deformation, ms.
    pub deform_full_ms: Stat,
    /// Time to the preview of a selective update, ms.
    pub deform_preview_ms: Stat,
    /// Share of static vertices' rays the selective update traced again (median).
    pub deform_static_rays_fraction: f64,
    /// Per-ray state kept for selective updates, MB (0 without dynamic meshes).
    pub ray_state_mb: f64,
    /// Offscreen frames per second of the renderer with the solved GI (NaN: not measured).
    pub render_fps: f64,
    /// The renderer used (`"gpu: <adapter>"` or `"cpu fallback"`).
    pub renderer: String,
    /// Peak resident memory of the measured runs, MB (NaN where the OS does not tell).
    pub peak_mb: f64,
    /// Bounces per run (`bounces_ms` covers all of them).
    pub bounces: u32,
    /// Bytes one gather bounce moves at least ([`bandwidth::gather_bytes`]).
    pub gather_bytes: u64,
    /// This machine's read bandwidth ([`bandwidth::read_bandwidth_gbps`]), GB/s; NaN: not measured.
    pub read_gbps: f64,
    /// Embree 3 on the same mesh and rays, run right after our measured runs
    /// ([`peer`]); CPU rows only, `None` when the peer program is not found.
    pub peer: Option<PeerFigures>,
    /// Link rays traced per second with nothing else (no merging into
    /// links), best of `runs` passes over every vertex's rays, the figure
    /// set beside Embree's trace-only rate; CPU rows only (NaN otherwise).
    pub trace_k_rays_per_s: f64,
    /// The tracer of the row ("bvh" or "kd" on the CPU; "gpu-bvh", "gpu-kd" or "gpu-rq" on the GPU).
    pub tracer: String,
}

impl BenchRow {
    /// The row of `runs` (times) with the sizes of the scene.
    pub fn from_runs(scene: &str, sizes: &Sizes, rays_per_vertex: u32, runs: &[RunTimes]) -> BenchRow {
        let st = |f: fn(&RunTimes) -> f64| Stat::of(&runs.iter().map(f).collect::<Vec<_>>());
        BenchRow {
            scene: scene.to_string(),
            backend: "CPU".to_string(),
            device: String::new(),
            vertices: sizes.vertices,
            triangles: sizes.triangles,
            kd_nodes: sizes.kd_nodes,
            links_raw: sizes.links_raw,
            links_merged: sizes.links_merged,
            mb_raw: sizes.bytes_raw as f64 / 1e6,
            mb_merged: sizes.bytes_merged as f64 / 1e6,
            rays_per_vertex,
            runs: runs.len() as u32,
            kd_ms: st(|r| r.kd_ms),
            links_ms: st(|r| r.links_ms),
            k_rays_per_s: st(|r| r.rays_per_s / 1e3),
            light_links_ms: st(|r| r.light_links_ms),
            k_shadow_rays_per_s: st(|r| r.shadow_rays_per_s / 1e3),
            near_hits: sizes.near_hits,
            near_ms: st(|r| r.near_ms),
            emitter_links_ms: st(|r| r.emitter_links_ms),
            k_emitter_shadow_rays_per_s: st(|r| r.emitter_shadow_rays_per_s / 1e3),
            k_emitter_trace_rays_per_s: st(|r| r.emitter_trace_rays_per_s / 1e3),
            bounces_ms: st(|r| r.bounces_ms),
            first_solution_ms: st(|r| r.first_solution_ms),
            light_preview_ms: st(|r| r.light_preview_ms),
            light_move_ms: st(|r| r.light_move_ms),
            sky_turn_ms: st(|r| r.sky_turn_ms),
            deform_update_ms: st(|r| r.deform_update_ms),
            deform_full_ms: st(|r| r.deform_full_ms),
            deform_preview_ms: st(|r| r.deform_preview_ms),
            deform_static_rays_fraction: st(|r| r.deform_static_rays_fraction).median,
            ray_state_mb: sizes.ray_state_bytes as f64 / 1e6,
            render_fps: f64::NAN,
            renderer: String::new(),
            peak_mb: f64::NAN,
            bounces: 3,
            gather_bytes: sizes.gather_bytes,
            read_gbps: f64::NAN,
            peer: None,
            trace_k_rays_per_s: f64::NAN,
            tracer: String::new(),
        }
    }
}

/// Sizes of the built structures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sizes {
    /// Solver vertices.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Nodes of the tracer's tree (kd-tree or BVH).
    pub kd_nodes: usize,
    /// Links before merging (three per front hit).
    pub links_raw: u64,
    /// Links after merging.
    pub links_merged: u64,
    /// Raw link storage, bytes (u32 target and f32 weight per raw link).
    pub bytes_raw: u64,
    /// Merged link storage as the gathers read it, bytes.
    pub bytes_merged: u64,
    /// Bytes one gather bounce moves at least.
    pub gather_bytes: u64,
    /// Bytes of the per-ray state of selective updates (0 without dynamic meshes).
    pub ray_state_bytes: u64,
    /// Link rays recorded as near hits ([`crate::links::near`]).
    pub near_hits: u64,
    /// The tracer the rays went through ([`Solver::tracer_name`]).
    pub tracer: &'static str,
}

/// Moves light 0 a little and times the preview and the full update, each
/// with its gather and smoothing, ms; NaN without lights.
fn time_light_move(solver: &mut Solver) -> (f64, f64) {
    let mut lights = solver.scene().lights.clone();
    let Some(light) = lights.first_mut() else {
        return (f64::NAN, f64::NAN);
    };
    match light {
        crate::scene::Light::Point { position, .. } => *position += glam::Vec3::new(0.05, 0.0, 0.0),
        crate::scene::Light::Directional { direction, .. } => {
            *direction = (*direction + direction.any_orthonormal_vector() * 0.05).normalize()
        }
    }
    let t = Instant::now();
    solver.preview_lights(lights.clone());
    let _ = solver.solve_quick();
    let preview = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    solver.set_lights(lights);
    let _ = solver.solve();
    (preview, t.elapsed().as_secs_f64() * 1e3)
}

/// Turns the sky by 30 degrees and times the gather-only update (sky
/// light from the miss masks, bounces, smoothing), ms; NaN without a sky.
fn time_sky_turn(solver: &mut Solver) -> f64 {
    let Some(mut sky) = solver.scene().sky.clone() else { return f64::NAN };
    sky.rotate_deg += 30.0;
    let t = Instant::now();
    solver.set_sky(Some(sky));
    let _ = solver.solve();
    t.elapsed().as_secs_f64() * 1e3
}

/// Deformer time of the deformed pose the deformation benchmark moves to,
/// from the rest pose (one update at 4 updates per second of animation).
pub const DEFORM_TIME_S: f32 = 0.25;

/// Deformation figures of one run ([`time_deformation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeformTimes {
    /// Selective update with bounces and smoothing, ms.
    pub update_ms: f64,
    /// Full update after the same deformation with bounces and smoothing, ms.
    pub full_ms: f64,
    /// From the start of a selective update to its preview's smoothed `E_i`, ms.
    pub preview_ms: f64,
    /// Share of the static vertices' rays the selective update traced again.
    pub static_rays_fraction: f64,
}

/// Times deformation updates. The solver (at rest, on
/// either path) is moved to [`DEFORM_TIME_S`] by a full update, back by a
/// selective one with a preview (timing the preview), and to
/// [`DEFORM_TIME_S`] again by a selective one (timed); each time with
/// bounces and smoothing. `None` without deformers.
pub fn time_deformation(solver: Solver) -> (Solver, Option<DeformTimes>) {
    use crate::scene::deform::{deform_scene, has_deformers};
    if !has_deformers(solver.scene()) {
        return (solver, None);
    }
    let rest = solver.scene().clone();
    let (positions, normals) = deform_scene(&rest, &rest.positions, &rest.normals, DEFORM_TIME_S);
    let moved = prep::PreparedScene { positions, normals, ..rest.clone() };
    let params = *solver.params();
    let t = Instant::now();
    let (solver, _) = solver.deformed(moved.clone(), params, &|_, _| {});
    let _ = solver.solve();
    let full_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let mut preview_ms = f64::NAN;
    let mut show = |s: &Solver| {
        let _ = s.solve_quick();
        preview_ms = t.elapsed().as_secs_f64() * 1e3;
    };
    let (solver, _) = solver.deform(rest, params, Some((crate::solver::PREVIEW_RAYS, &mut show)), &|_, _| {});
    let t = Instant::now();
    let (solver, stats) = solver.deform(moved, params, None, &|_, _| {});
    let _ = solver.solve();
    let update_ms = t.elapsed().as_secs_f64() * 1e3;
    let static_rays_fraction = stats.static_rays_fraction();
    (solver, Some(DeformTimes { update_ms, full_ms, preview_ms, static_rays_fraction }))
}

/// One complete build and solve of `scene`, timed.
pub fn run_once(
    scene: &prep::PreparedScene,
    params: &SolveParams,
    compute: &Compute,
) -> crate::Result<(RunTimes, Sizes, Vec<glam::Vec3>)> {
    let t0 = Instant::now();
    let mut solver = Solver::new_on(scene.clone(), *params, compute, &|_, _| {})?;
    let solution = solver.solve();
    let first_solution_ms = t0.elapsed().as_secs_f64() * 1e3;
    // Read before the light move below replaces them.
    let (light_links_ms, shadow_rays) = (solver.light_links().ms, solver.light_links().shadow_rays);
    let near_ms = crate::exchange::near::NearTerm::cost(&solver.near().light).ms;
    let em = solver.emitter_links();
    let (emitter_links_ms, emitter_shadow_rays_per_s, emitter_trace_rays_per_s) = if em.is_active() {
        let rays = em.shadow_rays as f64;
        (em.ms, rays / (em.ms.max(1e-9) * 1e-3), rays / (em.trace_ms.max(1e-9) * 1e-3))
    } else {
        (f64::NAN, f64::NAN, f64::NAN)
    };
    let (light_preview_ms, light_move_ms) = time_light_move(&mut solver);
    let sky_turn_ms = time_sky_turn(&mut solver);
    let l = solver.links().stats;
    let sizes = Sizes {
        tracer: solver.tracer_name(),
        vertices: solver.scene().vertex_count(),
        triangles: solver.scene().triangles.len(),
        kd_nodes: solver
            .accel()
            .kd()
            .map_or_else(|| solver.accel().bvh().map_or(0, |b| b.stats.nodes), |k| k.stats.nodes),
        links_raw: l.raw_links,
        links_merged: l.merged_links,
        bytes_raw: l.raw_bytes,
        bytes_merged: l.merged_bytes,
        gather_bytes: bandwidth::gather_bytes(solver.links()),
        ray_state_bytes: solver.ray_state_bytes(),
        near_hits: solver.links().near.rows.items.len() as u64,
    };
    let accel_build_ms = solver.accel_build_ms();
    let (_, deform) = time_deformation(solver);
    let nan = f64::NAN;
    let d = deform.unwrap_or(DeformTimes { update_ms: nan, full_ms: nan, preview_ms: nan, static_rays_fraction: nan });
    let times = RunTimes {
        kd_ms: accel_build_ms,
        links_ms: l.shoot_ms,
        rays_per_s: l.rays_per_second(),
        light_links_ms,
        shadow_rays_per_s: shadow_rays as f64 / (light_links_ms.max(1e-9) * 1e-3),
        near_ms,
        emitter_links_ms,
        emitter_shadow_rays_per_s,
        emitter_trace_rays_per_s,
        bounces_ms: solution.gather.ms,
        first_solution_ms,
        light_preview_ms,
        light_move_ms,
        sky_turn_ms,
        deform_update_ms: d.update_ms,
        deform_full_ms: d.full_ms,
        deform_preview_ms: d.preview_ms,
        deform_static_rays_fraction: d.static_rays_fraction,
    };
    Ok((times, sizes, solution.e_indirect))
}

/// Link rays per second of the CPU tracer `params.tracer` names, tracing
/// every vertex's rays (self hits of diving rays included, as the link
/// stage does) without merging them into links; best of `passes`.
pub fn trace_rate(scene: &prep::PreparedScene, params: &SolveParams, passes: u32) -> f64 {
    use rayon::prelude::*;
    let accel = crate::trace::Accel::build(params.tracer, &scene.positions, &scene.triangles, &params.bvh, &params.kd);
    let setup = crate::links::RaySetup::new(scene, &params.links);
    let n = scene.vertex_count();
    let mut best = 0f64;
    for _ in 0..passes.max(1) {
        let t = Instant::now();
        let rays: usize = (0..n)
            .into_par_iter()
            .chunks(32)
            .map(|vs| {
                let (mut hits, mut scratch) = (Vec::new(), crate::links::shoot::TraceScratch::default());
                let mut rays = 0;
                for v in vs {
                    setup.trace_vertex_with(&accel, v, &mut scratch, &mut hits);
                    rays += hits.len();
                }
                rays
            })
            .sum();
        best = best.max(rays as f64 / t.elapsed().as_secs_f64().max(1e-9));
    }
    best
}

/// Frames per second of `frames` offscreen renders (with read-back) of
/// `scene` with `e_indirect`, lights standing still: after the warm-up
/// frame the shadow maps are reused, as while orbiting in the viewer.
fn render_fps(
    desc: &SceneDesc,
    scene: &prep::PreparedScene,
    e_indirect: &[glam::Vec3],
    frames: u32,
) -> crate::Result<(f64, String)> {
    let renderer = crate::render::Renderer::open(crate::gpu::Backend::Auto);
    let camera = crate::render::framing::camera_or_framed(desc.camera, scene, None).0;
    let frame = crate::render::Frame::of(scene, e_indirect, camera);
    let params = crate::render::RenderParams::default();
    renderer.render(&frame, &params)?; // warm-up: pipelines, shadow maps
    let t = Instant::now();
    for _ in 0..frames {
        renderer.render(&frame, &params)?;
    }
    Ok((frames as f64 / t.elapsed().as_secs_f64().max(1e-9), renderer.describe()))
}

/// Benchmarks one scene: `warmup` unmeasured runs, then `runs` measured
/// ones, calling `progress()` after each run.
pub fn run_scene(
    desc: &SceneDesc,
    params: &BenchParams,
    (label, compute): &(String, Compute),
    progress: &dyn Fn(),
) -> crate::Result<BenchRow> {
    let mut desc = desc.clone();
    desc.settings.rays_per_vertex = params.rays_per_vertex;
    desc.settings.bounces = Bounces::Fixed(params.bounces);
    let scene = prep::prepare(&desc)?;
    let solve_params = SolveParams::from_settings(&scene.settings);
    for _ in 0..params.warmup {
        run_once(&scene, &solve_params, compute)?;
        progress();
    }
    let peak_resets = memory::reset_peak();
    let mut runs = Vec::new();
    let mut sizes = Sizes::default();
    let mut e_indirect = Vec::new();
    for _ in 0..params.runs.max(1) {
        let (t, s, e) = run_once(&scene, &solve_params, compute)?;
        runs.push(t);
        sizes = s;
        e_indirect = e;
        progress();
    }
    let peak = memory::peak_bytes().filter(|_| peak_resets);
    let mut row = BenchRow::from_runs(&desc.name, &sizes, params.rays_per_vertex, &runs);
    row.peak_mb = peak.map_or(f64::NAN, |b| b as f64 / 1e6);
    row.bounces = params.bounces;
    row.backend = label.clone();
    row.device = compute.describe();
    if params.render_frames > 0 {
        let (fps, renderer) = render_fps(&desc, &scene, &e_indirect, params.render_frames)?;
        row.render_fps = fps;
        row.renderer = renderer;
    }
    row.tracer = sizes.tracer.to_string();
    // Embree on the same mesh and workload, in this same run (CPU rows: the
    // peer traces on the CPU with as many threads as our pool).
    if label == "CPU" {
        row.trace_k_rays_per_s = trace_rate(&scene, &solve_params, params.runs.max(1)) / 1e3;
        if let Some(exe) = peer::find() {
            let threads = rayon::current_num_threads();
            // A peer that fails costs its table row, not the measured runs.
            match peer::run(&exe, &scene, params.rays_per_vertex, params.runs.max(1), threads) {
                Ok(f) => row.peer = Some(f),
                Err(e) => log::warn!("Embree peer on {}: {e}; its figures are left out", desc.name),
            }
        }
    }
    Ok(row)
}
