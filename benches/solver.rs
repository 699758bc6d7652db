//! Criterion benchmarks of the CPU stages on built-in scenes: kd-tree and
//! wide-BVH builds, ray shooting through each tracer (link generation,
//! reported as rays/s), shadow rays of the light links through each tracer
//! (rays/s), one gather bounce
//! (reported as bytes/s moved, [`linkgi::bench::bandwidth::gather_bytes`]),
//! in the scene's vertex order and in a Morton order over positions
//! (`gather_bounce_morton_order`: `src/scene/order.rs` and
//! `src/links/packed.rs` quote it 5-10% slower), beside the machine's read
//! bandwidth (a parallel sum over 512 MB), the yardstick of the gather's
//! target (>= 50%); and the link rays traced on one thread through the
//! BVH (single rays in flight, and same-origin packets of 16) and the
//! kd-tree (`single_thread/...`, rays/s: `docs/PERFORMANCE.md`
//! quotes them beside Embree's `rtcIntersect1`).
//!
//! Run: `cargo bench --bench solver` (all), or with a filter, e.g.
//! `cargo bench --bench solver -- conference` or `-- single_thread`.

#[path = "../tests/common/orders.rs"]
mod orders;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::exchange::bounce::gather::gather_bounce_padded;
use linkgi::exchange::{LightLinkParams, LightLinks};
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::links::{shoot_links, LinkParams, RaySetup};
use linkgi::scene::{builtin, prep};
use linkgi::trace::{CpuTracer, Tracer};
use std::time::Duration;

fn stages(c: &mut Criterion) {
    for name in ["tearoom", "conference"] {
        let scene = prep::prepare(&builtin::builtin(name).unwrap()).unwrap();
        let mut g = c.benchmark_group(name);
        g.sample_size(10).measurement_time(Duration::from_secs(20)).warm_up_time(Duration::from_secs(2));
        g.bench_function("kd_build", |b| {
            b.iter(|| KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default()))
        });
        g.bench_function("bvh_build", |b| {
            b.iter(|| Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default()))
        });
        let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
        let params = LinkParams::default();
        g.throughput(Throughput::Elements(scene.vertex_count() as u64 * params.rays_per_vertex as u64));
        for (label, t) in [("bvh", &bvh as &dyn CpuTracer), ("kd", &kd as &dyn CpuTracer)] {
            g.bench_function(format!("shoot_256_rays_per_vertex_{label}"), |b| {
                b.iter(|| shoot_links(&scene, t, &params, &|_, _| {}))
            });
        }
        let shadow = LightLinks::compute(&scene, &bvh, &LightLinkParams::default()).shadow_rays;
        g.throughput(Throughput::Elements(shadow));
        for (label, t) in [("bvh", &bvh as &dyn Tracer), ("kd", &kd as &dyn Tracer)] {
            g.bench_function(format!("light_links_{label}"), |b| {
                b.iter(|| LightLinks::compute(&scene, t, &LightLinkParams::default()))
            });
        }
        let links = shoot_links(&scene, &bvh, &params, &|_, _| {});
        let b0 = vec![glam::Vec4::new(0.1, 0.1, 0.1, 0.0); scene.vertex_count()];
        let mut out = vec![glam::Vec3::ZERO; scene.vertex_count()];
        g.throughput(Throughput::Bytes(linkgi::bench::bandwidth::gather_bytes(&links)));
        g.bench_function("gather_bounce", |b| b.iter(|| gather_bounce_padded(&links, &b0, &mut out)));
        let morton = orders::renumbered(&links, &orders::morton(&scene.positions));
        g.throughput(Throughput::Bytes(linkgi::bench::bandwidth::gather_bytes(&morton)));
        g.bench_function("gather_bounce_morton_order", |b| b.iter(|| gather_bounce_padded(&morton, &b0, &mut out)));
        g.finish();
    }
}

/// The link rays of every 7th vertex (256 a vertex) traced on the calling
/// thread, nearest hit, through the wide BVH and the kd-tree (rays/s).
fn single_thread(c: &mut Criterion) {
    for name in ["tearoom", "conference"] {
        let scene = prep::prepare(&builtin::builtin(name).unwrap()).unwrap();
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
        let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
        let setup = RaySetup::new(&scene, &LinkParams::default());
        let verts: Vec<usize> = (0..scene.vertex_count()).step_by(7).collect();
        let dirs: Vec<Vec<glam::Vec3>> = verts.iter().map(|&v| setup.world_directions(v).collect()).collect();
        let rays: usize = dirs.iter().map(|d| d.len()).sum();
        let mut g = c.benchmark_group(format!("single_thread/{name}"));
        g.sample_size(10).measurement_time(Duration::from_secs(20)).warm_up_time(Duration::from_secs(2));
        g.throughput(Throughput::Elements(rays as u64));
        // Single rays in flight (`Bvh::intersect_origin_single`).
        let mut out = Vec::new();
        g.bench_function("trace_link_rays_bvh", |b| {
            b.iter(|| {
                let mut sum = 0f64;
                for (i, &v) in verts.iter().enumerate() {
                    out.resize(dirs[i].len(), None);
                    bvh.intersect_origin_single(setup.origins[v], v as u32, &dirs[i], &mut out);
                    sum += out.iter().flatten().map(|h| h.t as f64).sum::<f64>();
                }
                sum
            })
        });
        for (label, t) in [("kd", &kd as &dyn CpuTracer)] {
            let mut out = Vec::new();
            g.bench_function(format!("trace_link_rays_{label}"), |b| {
                b.iter(|| {
                    let mut sum = 0f64;
                    for (i, &v) in verts.iter().enumerate() {
                        out.resize(dirs[i].len(), None);
                        t.intersect_origin(setup.origins[v], v as u32, &dirs[i], &mut out);
                        sum += out.iter().flatten().map(|h| h.t as f64).sum::<f64>();
                    }
                    sum
                })
            });
        }
        // The same rays in same-origin packets of 16 (`bvh::packet`, what
        // `intersect_origin` walks with AVX-512).
        let mut out = Vec::new();
        g.bench_function("trace_link_rays_bvh_packets", |b| {
            b.iter(|| {
                let mut sum = 0f64;
                for (i, &v) in verts.iter().enumerate() {
                    out.resize(dirs[i].len(), None);
                    bvh.intersect_packets(setup.origins[v], v as u32, &dirs[i], &mut out);
                    sum += out.iter().flatten().map(|h| h.t as f64).sum::<f64>();
                }
                sum
            })
        });
        g.finish();
    }
}

fn memory(c: &mut Criterion) {
    let data = vec![1u64; 64 << 20];
    let mut g = c.benchmark_group("memory");
    g.sample_size(20);
    g.throughput(Throughput::Bytes((data.len() * 8) as u64));
    g.bench_function("parallel_read_512MB", |b| {
        use rayon::prelude::*;
        b.iter(|| data.par_chunks(1 << 16).map(|c| c.iter().fold(0u64, |a, &x| a.wrapping_add(x))).sum::<u64>())
    });
    g.finish();
}

criterion_group!(benches, memory, stages, single_thread);
criterion_main!(benches);
