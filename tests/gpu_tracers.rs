//! Every GPU tracer (the 8-wide BVH walk, the rope kd-tree walk, and
//! hardware ray queries where the adapter has them; CI's lavapipe from
//! Mesa 25 has them) against the CPU's 8-wide BVH: closest hits of
//! arbitrary rays, any-hit visibility of segments, and the vertex ray sets
//! of link shooting, on random and degenerate meshes and on built-in
//! scenes, before and after a deformation's refit. Hits must name the same
//! triangle with the same `t` (to 1e-5, relative); where they differ, brute
//! force decides, and a GPU hit at brute force's distance is a tie (equal
//! `t`, another triangle: the documented rope-walk and ray-query ties). At
//! most 0.1% of rays may differ otherwise (a ray through a shared edge: the
//! shader has no f64 fallback). With no adapter these tests fail when `CI`
//! is set and skip with a message otherwise.

mod common;
#[path = "common/gpu.rs"]
mod gpu_device;

use common::{grid, random_rays, soup};
use glam::Vec3;
use gpu_device::device;
use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::gpu::tracer::{stack_need, BVH_STACK};
use linkgi::gpu::{GpuDevice, GpuTracer, GpuWalk};
use linkgi::kdtree::traverse::brute_force;
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::links::{LinkParams, RaySetup, HIT_BACK, HIT_MISS};
use linkgi::scene::{builtin, prep};
use linkgi::trace::ray::{Hit, Ray};
use linkgi::trace::{CpuTracer, Tracer};
use rand::SeedableRng;
use rand_pcg::Pcg32;
use std::sync::Arc;

type Mesh = (Vec<Vec3>, Vec<[u32; 3]>);

/// The walks this device runs: ray queries must be there in CI.
fn walks(dev: &GpuDevice) -> Vec<GpuWalk> {
    let mut w = vec![GpuWalk::Bvh, GpuWalk::Kd];
    if dev.ray_query() {
        w.push(GpuWalk::RayQuery);
    } else if std::env::var_os("CI").is_some() {
        panic!("{}: no ray queries in CI: .ci/run installs Mesa 25's lavapipe, which has them", dev.describe());
    } else {
        eprintln!("SKIPPED: ray queries ({} has none)", dev.describe());
    }
    w
}

/// The GPU tracer of `walk` over `mesh`.
fn gpu_tracer(dev: &Arc<GpuDevice>, walk: GpuWalk, mesh: &Mesh, bvh: &Bvh, kd: &KdTree) -> GpuTracer {
    match walk {
        GpuWalk::Bvh => GpuTracer::bvh(dev.clone(), bvh),
        GpuWalk::Kd => GpuTracer::kd(dev.clone(), kd),
        GpuWalk::RayQuery => GpuTracer::ray_query(dev.clone(), &mesh.0, &mesh.1),
    }
    .unwrap_or_else(|e| panic!("{}: {e}", walk.name()))
}

/// Compares one answer: `Ok(true)` equal, `Ok(false)` a tie brute force
/// confirms, `Err` a difference.
fn same_hit(gpu: Option<Hit>, cpu: Option<Hit>, brute: impl FnOnce() -> Option<Hit>) -> Result<bool, String> {
    match (gpu, cpu) {
        (None, None) => Ok(true),
        (Some(g), Some(c)) if g.tri == c.tri && g.front == c.front => {
            if (g.t - c.t).abs() <= 1e-5 * c.t.abs().max(1e-3) {
                Ok(true)
            } else {
                Err(format!("t {} vs {}", g.t, c.t))
            }
        }
        (Some(g), _) => match brute() {
            Some(b) if (g.t - b.t).abs() <= 1e-6 * b.t.abs().max(1e-3) => Ok(false),
            b => Err(format!(
                "tri {} at {} vs {:?} (brute force {:?})",
                g.tri,
                g.t,
                cpu.map(|c| c.tri),
                b.map(|b| b.tri)
            )),
        },
        (None, Some(c)) => Err(format!("a miss vs tri {} at {}", c.tri, c.t)),
    }
}

/// Closest hits and visibility of `rays` on every walk against the CPU
/// BVH; returns the hits found.
fn check_rays(dev: &Arc<GpuDevice>, what: &str, mesh: &Mesh, rays: &[Ray]) -> usize {
    let bvh = Bvh::build(&mesh.0, &mesh.1, &BvhBuildParams::default());
    let kd = KdTree::build(&mesh.0, &mesh.1, &KdBuildParams::default());
    let cpu_hits: Vec<Option<Hit>> = rays.iter().map(|r| CpuTracer::intersect(&bvh, r)).collect();
    let cpu_vis: Vec<bool> = rays.iter().map(|r| !CpuTracer::occluded(&bvh, r)).collect();
    for walk in walks(dev) {
        let gpu = gpu_tracer(dev, walk, mesh, &bvh, &kd);
        let hits = gpu.closest_hits(rays).expect("closest hits");
        let vis = gpu.visible(rays).expect("visibility");
        assert_eq!((hits.len(), vis.len()), (rays.len(), rays.len()));
        let (mut ties, mut wrong) = (0, Vec::new());
        for (i, r) in rays.iter().enumerate() {
            match same_hit(hits[i], cpu_hits[i], || brute_force(&kd, r)) {
                Ok(true) => {}
                Ok(false) => ties += 1,
                Err(e) => wrong.push(format!("ray {i}: {e}")),
            }
        }
        let vis_differ = vis.iter().zip(&cpu_vis).filter(|(a, b)| a != b).count();
        eprintln!(
            "{what}, {}: {} rays, {ties} ties, {} differ, visibility differs at {vis_differ}",
            walk.name(),
            rays.len(),
            wrong.len()
        );
        let allowed = 1e-3 * rays.len() as f64 + 1.0;
        assert!(
            wrong.len() as f64 <= allowed,
            "{what}, {}: {} rays differ: {:?}",
            walk.name(),
            wrong.len(),
            &wrong[..wrong.len().min(5)]
        );
        assert!(vis_differ as f64 <= allowed, "{what}, {}: visibility differs at {vis_differ}", walk.name());
    }
    cpu_hits.iter().filter(|h| h.is_some()).count()
}

#[test]
fn random_soup_hits_as_the_cpu_bvh() {
    let Some(dev) = device() else { return };
    let mut rng = Pcg32::seed_from_u64(21);
    let mesh = soup(&mut rng, 3000, 0.05);
    let rays = random_rays(&mut rng, 4000, mesh.0.len() as u32);
    assert!(check_rays(&dev, "soup", &mesh, &rays) > 1000);
}

#[test]
fn grids_and_coincident_triangles_hit_as_the_cpu_bvh() {
    let Some(dev) = device() else { return };
    let mut rng = Pcg32::seed_from_u64(22);
    let mut aa = (Vec::new(), Vec::new());
    for axis in 0..3 {
        grid(24, axis, 0.5, &mut aa.0, &mut aa.1);
    }
    let rays = random_rays(&mut rng, 3000, aa.0.len() as u32);
    assert!(check_rays(&dev, "axis-aligned grids", &aa, &rays) > 600);
    // 40 copies of one triangle: equal distances, ties by id.
    let mut same = (Vec::new(), Vec::new());
    for _ in 0..40 {
        let base = same.0.len() as u32;
        same.0.extend([Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 0.0, 0.5), Vec3::new(0.0, 1.0, 0.5)]);
        same.1.push([base, base + 1, base + 2]);
    }
    let rays = random_rays(&mut rng, 2000, 0);
    assert!(check_rays(&dev, "coincident", &same, &rays) > 100);
}

/// Twists the mesh about the vertical axis through (0.5, *, 0.5).
fn twist(pos: &[Vec3], amount: f32) -> Vec<Vec3> {
    pos.iter()
        .map(|p| {
            let (s, c) = (amount * p.y).sin_cos();
            let (x, z) = (p.x - 0.5, p.z - 0.5);
            Vec3::new(0.5 + c * x - s * z, p.y, 0.5 + s * x + c * z)
        })
        .collect()
}

/// A deformation: the CPU BVH refitted and uploaded, the driver's
/// structure refitted, the kd-tree rebuilt and uploaded; each tracer then
/// answers as the refitted CPU BVH does.
#[test]
fn refitted_tracers_hit_as_the_refitted_cpu_bvh() {
    let Some(dev) = device() else { return };
    let mut rng = Pcg32::seed_from_u64(23);
    let mut mesh = (Vec::new(), Vec::new());
    for axis in 0..3 {
        grid(20, axis, 0.3 + 0.2 * axis as f32, &mut mesh.0, &mut mesh.1);
    }
    let rays = random_rays(&mut rng, 3000, mesh.0.len() as u32);
    let params = BvhBuildParams::default();
    let mut bvh = Bvh::build(&mesh.0, &mesh.1, &params);
    let kd = KdTree::build(&mesh.0, &mesh.1, &KdBuildParams::default());
    let mut tracers: Vec<GpuTracer> = walks(&dev).into_iter().map(|w| gpu_tracer(&dev, w, &mesh, &bvh, &kd)).collect();
    for step in 1..3 {
        let moved = twist(&mesh.0, 0.08 * step as f32);
        bvh.update(&moved, &mesh.1);
        let kd = KdTree::build(&moved, &mesh.1, &KdBuildParams::default());
        let want: Vec<Option<Hit>> = rays.iter().map(|r| CpuTracer::intersect(&bvh, r)).collect();
        for t in &mut tracers {
            t.update(Some(&bvh), Some(&kd), &moved).expect("update");
            let got = t.closest_hits(&rays).expect("closest hits");
            let wrong = got
                .iter()
                .zip(&want)
                .zip(&rays)
                .filter(|((g, c), r)| same_hit(**g, **c, || brute_force(&kd, r)).is_err())
                .count();
            eprintln!("twist {step}, {}: {wrong} of {} rays differ", Tracer::name(t), rays.len());
            assert!(wrong as f64 <= 1e-3 * rays.len() as f64 + 1.0, "{}: {wrong} rays differ", Tracer::name(t));
            // Not vacuous: the twisted grids are still hit.
            assert!(got.iter().filter(|h| h.is_some()).count() > 300);
        }
    }
}

/// The vertex ray sets of link shooting on built-in scenes, through the
/// tracers' `origin_rays` (the links' records: self hits by the wedge rule).
fn vertex_rays_agree(name: &str) {
    let Some(dev) = device() else { return };
    let desc = builtin::builtin(name).expect("built-in");
    let scene = prep::prepare(&desc).expect("prepares");
    let mesh = (scene.positions.clone(), scene.triangles.clone());
    let bvh = Bvh::build(&mesh.0, &mesh.1, &BvhBuildParams::default());
    let need = stack_need(&bvh);
    eprintln!("{name}: the BVH walk needs {need} of {BVH_STACK} stack entries");
    assert!(need <= BVH_STACK);
    let kd = KdTree::build(&mesh.0, &mesh.1, &KdBuildParams::default());
    let setup = RaySetup::new(&scene, &LinkParams { rays_per_vertex: 64, ..LinkParams::default() });
    // Every third vertex keeps the test short on lavapipe.
    let vertices: Vec<u32> = (0..scene.vertex_count() as u32).step_by(3).collect();
    let mut want = Vec::new();
    let mut one = Vec::new();
    for &v in &vertices {
        setup.trace_vertex(&bvh, v as usize, &mut one);
        want.extend_from_slice(&one);
    }
    for walk in walks(&dev) {
        let gpu = gpu_tracer(&dev, walk, &mesh, &bvh, &kd);
        let got = setup.trace_vertices(&gpu, &vertices).expect("vertex rays");
        assert_eq!(got.len(), want.len());
        let differ = got
            .iter()
            .zip(&want)
            .filter(|(g, c)| g.tri != c.tri || (c.tri != HIT_MISS && (g.t - c.t).abs() > 1e-5 * c.t.abs().max(1e-3)))
            .count();
        let hits = want.iter().filter(|c| c.tri != HIT_MISS && c.tri & HIT_BACK == 0).count();
        eprintln!("{name}, {}: {differ} of {} vertex rays differ ({hits} front hits)", walk.name(), want.len());
        assert!(
            differ as f64 <= 1e-3 * want.len() as f64,
            "{name}, {}: {differ} of {} differ",
            walk.name(),
            want.len()
        );
    }
}

#[test]
fn vertex_rays_agree_cornell() {
    vertex_rays_agree("cornell");
}

#[test]
fn vertex_rays_agree_tearoom() {
    vertex_rays_agree("tearoom");
}

/// Every built-in scene's BVH fits the GPU walk's stack (a tree that did
/// not would be refused with an error, and the solver would fall back).
#[test]
fn every_builtin_bvh_fits_the_gpu_stack() {
    for name in builtin::NAMES {
        let scene = prep::prepare(&builtin::builtin(name).expect("built-in")).expect("prepares");
        let bvh = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
        let need = stack_need(&bvh);
        eprintln!(
            "{name}: {} triangles, depth {}, {need} of {BVH_STACK} stack entries",
            scene.triangles.len(),
            bvh.stats.max_depth
        );
        assert!(need <= BVH_STACK, "{name}: the GPU walk would need {need} stack entries");
    }
}
