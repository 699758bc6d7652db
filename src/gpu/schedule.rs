//! Link generation on one or more devices (docs/DESIGN.md §5): vertices are cut
//! into batches handed to whichever device is free; a device's next batch
//! is sized from its throughput on its last one (the paper's load
//! balancing), capped by its memory limits. Hits stream back over a
//! crossbeam channel and are merged into links on the CPU (rayon) while the
//! devices trace the next batches. The merge is the CPU path's own
//! ([`crate::links::merge_vertex`]), so both paths give the same links for
//! the same hits.
//!
//! A logical device is one tracer on an adapter; `--devices N` puts N on
//! one adapter so the scheduler can be exercised on one machine, and
//! [`LogicalDevice::delay_per_vertex`] slows one down artificially for tests.

use super::layout::RayVertex;
use super::tracer::GpuTracer;
use crate::error::{Error, Result};
use crate::links::shoot::RaySetup;
use crate::links::{assemble, GroupRun, HitRecord, LinkParams, Links, RayHits};
use crate::scene::prep::PreparedScene;
use rayon::prelude::*;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Scheduler parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduleParams {
    /// Wall time a batch should take on its device, seconds.
    pub target_batch_seconds: f64,
    /// Vertices of every device's first batch (before any speed is known),
    /// and the smallest batch.
    pub first_batch_vertices: usize,
}

impl Default for ScheduleParams {
    fn default() -> Self {
        Self { target_batch_seconds: 0.2, first_batch_vertices: 1024 }
    }
}

/// One scheduling target: a tracer plus an optional artificial delay.
pub struct LogicalDevice {
    /// Name in figures (the adapter's name, with `#i` where one adapter has several logical devices).
    pub label: String,
    /// The device's tracer.
    pub tracer: GpuTracer,
    /// Extra time per traced vertex (tests of the scheduler), zero normally.
    pub delay_per_vertex: Duration,
}

/// What one logical device did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeviceShare {
    /// The device's label (`LogicalDevice::label`).
    pub label: String,
    /// Batches it traced.
    pub batches: usize,
    /// Vertices it traced.
    pub vertices: usize,
    /// Vertex ranges it traced, in the order it took them.
    pub ranges: Vec<(usize, usize)>,
    /// Rays per second over its batches.
    pub rays_per_second: f64,
}

/// Per-vertex shooting data of the whole scene, in the shader's layout.
pub fn ray_vertices(setup: &RaySetup) -> Vec<RayVertex> {
    let all: Vec<u32> = (0..setup.origins.len() as u32).collect();
    super::tracer::ray_vertices_of(&setup.origin_rays(&all))
}

fn merge_batch(
    setup: &RaySetup,
    triangles: &[[u32; 3]],
    near: &Option<crate::links::near::NearRule>,
    first: usize,
    record: bool,
    hits: &mut [HitRecord],
) -> GroupRun {
    let rays = setup.directions.len();
    let weight_per_ray = std::f64::consts::PI / rays as f64;
    const CHUNK: usize = 64;
    let parts: Vec<GroupRun> = hits
        .par_chunks_mut(rays * CHUNK)
        .enumerate()
        .map(|(ci, chunk)| {
            let at = first + ci * CHUNK;
            let run = if record { GroupRun::recording(at) } else { GroupRun::new(at) };
            let mut run = run.with_near(near.clone());
            for (i, vh) in chunk.chunks_mut(rays).enumerate() {
                setup.self_hits(run.first + i, vh);
                run.push_vertex(vh, triangles, weight_per_ray);
            }
            run
        })
        .collect();
    let mut out = if record { GroupRun::recording(first) } else { GroupRun::new(first) };
    for p in parts {
        out.append(p);
    }
    out
}

/// Shoots every vertex's rays on `devices` and builds the merged links;
/// with the near hits where `keep` says, and the per-ray state selective updates read
/// ([`RayHits`], as the CPU's `shoot_links_recording` keeps it).
/// `progress(done, total)` is called as batches are merged.
pub fn shoot_links_gpu(
    scene: &PreparedScene,
    params: &LinkParams,
    sched: &ScheduleParams,
    devices: &mut [LogicalDevice],
    keep: crate::links::Recording,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Links, Option<RayHits>, Vec<DeviceShare>)> {
    let record = keep.ray_hits;
    if devices.is_empty() {
        return Err(Error::Gpu("no device to shoot rays on".into()));
    }
    let start = Instant::now();
    let setup = RaySetup::new(scene, params);
    for d in devices.iter_mut() {
        d.tracer.set_directions(&setup.directions);
    }
    let verts = ray_vertices(&setup);
    let near = keep.near.then(|| crate::links::near::NearRule::new(scene, setup.directions.len() as u32, params)).flatten();
    let n = verts.len();
    let rays = setup.directions.len();
    let cursor = Mutex::new(0usize);
    // Vertices per second of every device on its last batch (0: unknown).
    let speeds = Mutex::new(vec![0f64; devices.len()]);
    let (tx, rx) = crossbeam_channel::bounded::<Result<(usize, usize, Vec<HitRecord>)>>(devices.len());
    let mut shares: Vec<DeviceShare> =
        devices.iter().map(|d| DeviceShare { label: d.label.clone(), ..Default::default() }).collect();
    let mut batches: Vec<GroupRun> = Vec::new();
    // With `record`: each batch's hit ids, by its first vertex.
    let mut batch_ids: Vec<(usize, Vec<u32>)> = Vec::new();
    let mut merged_vertices = 0usize;
    let mut first_error = None;
    std::thread::scope(|s| {
        for (i, (dev, share)) in devices.iter().zip(shares.iter_mut()).enumerate() {
            let (tx, cursor, speeds, verts) = (tx.clone(), &cursor, &speeds, &verts);
            s.spawn(move || {
                let max_vertices = (dev.tracer.max_batch_rays() / rays).max(1);
                let mut traced_rays = 0u64;
                let mut busy = 0f64;
                loop {
                    let want = {
                        let sp = speeds.lock().unwrap_or_else(|p| p.into_inner());
                        let remaining = n - *cursor.lock().unwrap_or_else(|p| p.into_inner());
                        let sum: f64 = sp.iter().sum();
                        let size = if sp[i] > 0.0 {
                            // Its speed times the target time, and never more than its
                            // fair part of what is left, so the slow device does not end last.
                            let by_time = (sp[i] * sched.target_batch_seconds) as usize;
                            let fair = (remaining as f64 * sp[i] / sum.max(1e-9) / 2.0).ceil() as usize;
                            by_time.min(fair)
                        } else {
                            sched.first_batch_vertices
                        };
                        size.max(sched.first_batch_vertices.clamp(1, 64)).min(max_vertices)
                    };
                    let (a, b) = {
                        let mut c = cursor.lock().unwrap_or_else(|p| p.into_inner());
                        let a = *c;
                        *c = (a + want).min(n);
                        (a, *c)
                    };
                    if a >= b {
                        break;
                    }
                    let t = Instant::now();
                    let result = dev.tracer.shoot(&verts[a..b]);
                    if !dev.delay_per_vertex.is_zero() {
                        std::thread::sleep(dev.delay_per_vertex * (b - a) as u32);
                    }
                    let secs = t.elapsed().as_secs_f64();
                    busy += secs;
                    traced_rays += ((b - a) * rays) as u64;
                    speeds.lock().unwrap_or_else(|p| p.into_inner())[i] = (b - a) as f64 / secs.max(1e-6);
                    share.batches += 1;
                    share.vertices += b - a;
                    share.ranges.push((a, b));
                    let failed = result.is_err();
                    if tx.send(result.map(|h| (a, b, h))).is_err() || failed {
                        break;
                    }
                }
                share.rays_per_second = traced_rays as f64 / busy.max(1e-9);
            });
        }
        drop(tx);
        for msg in rx.iter() {
            match msg {
                Ok((a, b, mut hits)) => {
                    if hits.len() != (b - a) * rays {
                        first_error.get_or_insert(Error::Gpu(format!(
                            "batch {a}..{b} returned {} hits, expected {}",
                            hits.len(),
                            (b - a) * rays
                        )));
                        continue;
                    }
                    batches.push(merge_batch(&setup, &scene.triangles, &near, a, record, &mut hits));
                    if record {
                        batch_ids.push((a, hits.iter().map(|h| h.tri).collect()));
                    }
                    merged_vertices += b - a;
                    progress(merged_vertices, n);
                }
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
    });
    if let Some(e) = first_error {
        return Err(e);
    }
    if merged_vertices != n {
        return Err(Error::Gpu(format!("only {merged_vertices} of {n} vertices came back from the devices")));
    }
    let (links, sums) = assemble(n, batches, start.elapsed().as_secs_f64() * 1e3).map_err(Error::Gpu)?;
    let hits = record.then(|| {
        batch_ids.sort_by_key(|b| b.0);
        RayHits { rays_per_vertex: rays, ids: batch_ids.into_iter().flat_map(|b| b.1).collect(), sums }
    });
    Ok((links, hits, shares))
}
