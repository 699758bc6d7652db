//! Probe: single-thread tracing rate of the link rays of a scene, BVH against kd.
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::kdtree::{Hit, KdBuildParams, KdTree};
use linkgi::links::{LinkParams, RaySetup};
use linkgi::scene::{self, prep};
use linkgi::trace::CpuTracer;
use std::time::Instant;

fn main() {
    let name = std::env::args().nth(1).unwrap_or("tearoom".into());
    let stride: usize = std::env::args().nth(2).map_or(7, |s| s.parse().unwrap());
    let scene = prep::prepare(&scene::load(&name).unwrap()).unwrap();
    let t = Instant::now();
    let env = |k: &str, d: f32| std::env::var(k).ok().map_or(d, |v| v.parse().unwrap());
    let bp = BvhBuildParams {
        max_leaf_triangles: env("LEAF", 8.0) as usize,
        bins: env("BINS", 16.0) as usize,
        traversal_cost: env("TRAV", 1.0),
        ..Default::default()
    };
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &bp);
    let bvh_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let _kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
    let kd_ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "bvh build {bvh_ms:.1} ms sah {:.1} nodes {} leaves {}; kd build {kd_ms:.1} ms",
        bvh.stats.sah_cost, bvh.stats.nodes, bvh.stats.leaves
    );
    let setup = RaySetup::new(&scene, &LinkParams::default());
    let verts: Vec<usize> = (0..scene.vertex_count()).step_by(stride).collect();
    let dirs: Vec<Vec<glam::Vec3>> = verts.iter().map(|&v| setup.world_directions(v).collect()).collect();
    let rays: usize = dirs.iter().map(|d| d.len()).sum();
    let isas = [linkgi::bvh::Isa::Avx512, linkgi::bvh::Isa::Avx2, linkgi::bvh::Isa::Portable];
    let bvhs: Vec<Bvh> = isas
        .iter()
        .map(|&i| {
            let mut b = bvh.clone();
            b.set_isa(i);
            b
        })
        .collect();
    for round in 0..1 {
        let best = isas.iter().position(|i| i.supported()).expect("portable");
        for (label, tr) in [(format!("bvh {:?}", isas[best]), &bvhs[best] as &dyn CpuTracer)] {
            let mut out = vec![None::<Hit>; 256];
            let t = Instant::now();
            let mut sum = 0f64;
            for (i, &v) in verts.iter().enumerate() {
                out.resize(dirs[i].len(), None);
                tr.intersect_origin(setup.origins[v], v as u32, &dirs[i], &mut out);
                sum += out.iter().flatten().map(|h| h.t as f64).sum::<f64>();
            }
            let s = t.elapsed().as_secs_f64();
            println!(
                "round {round} {label}: {:.2} M rays/s single thread ({rays} rays) checksum {sum:.3}",
                rays as f64 / s / 1e6
            );
        }
    }
}
