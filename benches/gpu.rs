//! Criterion benchmarks of the GPU stages (any adapter; lavapipe counts):
//! for each GPU tracer (BVH walk, kd-tree walk, ray queries where the
//! adapter has them), ray shooting of one scene's links and closest hits
//! of the same rays as an arbitrary batch (reported as rays/s; each
//! iteration reads the hits back, so it waits for the device), and one
//! gather bounce on the device (links/s; each iteration waits for the
//! bounce totals).
//! Prints a line and measures nothing when no adapter exists.
//!
//! Run: `cargo bench --bench gpu` or `cargo bench --bench gpu -- tearoom`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::exchange::bounce::gather::BounceKernel;
use linkgi::gpu::{self, schedule, GpuLinks, GpuTracer, GpuWalk};
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::links::{shoot_links, LinkParams, RaySetup};
use linkgi::scene::{builtin, prep};
use linkgi::trace::ray::Ray;
use linkgi::trace::Accel;
use std::time::Duration;

fn stages(c: &mut Criterion) {
    let Some(dev) = gpu::open_all().into_iter().next() else {
        eprintln!("no graphics adapter: GPU benchmarks skipped");
        return;
    };
    eprintln!("GPU benchmarks on {}", dev.describe());
    for name in ["tearoom", "conference"] {
        let scene = prep::prepare(&builtin::builtin(name).unwrap()).unwrap();
        let mut g = c.benchmark_group(format!("gpu/{name}"));
        g.sample_size(10).measurement_time(Duration::from_secs(20)).warm_up_time(Duration::from_secs(2));
        let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::for_gpu());
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
        let params = LinkParams::default();
        let setup = RaySetup::new(&scene, &params);
        let verts = schedule::ray_vertices(&setup);
        let mut walks = vec![GpuWalk::Bvh, GpuWalk::Kd];
        if dev.ray_query() {
            walks.push(GpuWalk::RayQuery);
        }
        for walk in walks {
            let accel = if walk == GpuWalk::Kd { Accel::Kd(kd.clone()) } else { Accel::Bvh(bvh.clone()) };
            let Ok(mut tracer) = GpuTracer::of(dev.clone(), walk, &accel, &scene.positions, &scene.triangles) else {
                eprintln!("{}: no tracer on {}", walk.name(), dev.describe());
                continue;
            };
            tracer.set_directions(&setup.directions);
            let batch = (tracer.max_batch_rays() / setup.directions.len()).min(verts.len()).min(4096);
            let rays = (batch * setup.directions.len()) as u64;
            g.throughput(Throughput::Elements(rays));
            g.bench_function(format!("{}/shoot_256_rays_per_vertex_batch", walk.name()), |b| {
                b.iter(|| tracer.shoot(&verts[..batch]).unwrap())
            });
            // The same rays as one arbitrary batch (segments [0, 3e38]).
            let arbitrary: Vec<Ray> = (0..batch)
                .flat_map(|v| {
                    let o = setup.origins[v];
                    setup
                        .world_directions(v)
                        .map(move |d| Ray { origin: o, dir: d, tmin: 0.0, tmax: 3.0e38, skip: v as u32 })
                        .collect::<Vec<_>>()
                })
                .collect();
            g.bench_function(format!("{}/closest_hits_batch", walk.name()), |b| {
                b.iter(|| linkgi::trace::Tracer::closest_hits(&tracer, &arbitrary).unwrap())
            });
            g.bench_function(format!("{}/visibility_batch", walk.name()), |b| {
                b.iter(|| linkgi::trace::Tracer::visible(&tracer, &arbitrary).unwrap())
            });
        }
        let links = shoot_links(&scene, &kd, &params, &|_, _| {});
        let gl = GpuLinks::new(dev.clone(), &links, &scene.albedo).unwrap();
        let e_d = vec![glam::Vec3::splat(1.0); scene.vertex_count()];
        let mut kernel = gl.kernel(&e_d, &scene.albedo).unwrap();
        g.throughput(Throughput::Elements(links.link_count() as u64));
        g.bench_function("gather_bounce", |b| b.iter(|| kernel.run_bounces(1).unwrap()));
        g.finish();
    }
}

criterion_group!(benches, stages);
criterion_main!(benches);
