//! Criterion benchmarks of the updates an interactive user makes, on the
//! CPU, each with the solve that follows it (bounces, noise estimate,
//! smoothing):
//!
//! - `light_move/conference`: the first light moved 5 cm (its light links
//!   and near-hit column traced again) and solved; the solve alone; the
//!   noise estimate alone (`docs/DESIGN.md` quotes the move's solve, 415 ->
//!   180 ms, and the noise pass, 146 -> 51 ms).
//! - `sky_change/...`: the sky turned by 10 degrees, a gather-only update:
//!   `E_sky` from the kept miss masks and the whole solve, on `window` and
//!   on a worst case where every ray misses (an open plane of 300 x 300
//!   quads) under a gradient and a 1024 x 512 image sky.
//! - `deform/dancer`: the figure deformed to t = 0.25 s and back, a
//!   selective update (only the rays the motion can have changed traced
//!   again) against a full one (BVH refit, every ray traced again), each
//!   with its solve.
//!
//! - `refine_round/mcguire`: the links of one error-driven refinement
//!   round of McGuire's Cornell box (`../shared/scenes/`; skipped where it
//!   is absent), a priori refined to 1,744 triangles, then a third of its
//!   edges split (by a hash of their ends: one, two and three marks a
//!   triangle): carried (`links::reassign`: kept vertices' hits re-assigned
//!   to the pieces, the other rays traced) against every ray traced. Both
//!   give the same links (checked once before timing).
//!
//! `linkgi bench` reports the same updates once per run beside the
//! paper's tables. Run: `cargo bench --bench updates` or with a filter,
//! e.g. `cargo bench --bench updates -- sky_change`.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use linkgi::scene::deform::deform_scene;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, prep, Bounces, Light, SceneDesc, Settings};
use linkgi::sky::Sky;
use linkgi::solver::{SolveParams, Solver};
use std::time::{Duration, Instant};

fn solver_of(desc: &SceneDesc) -> Solver {
    let scene = prep::prepare(desc).unwrap();
    let params = SolveParams::from_settings(&scene.settings);
    Solver::new(scene, params, &|_, _| {}).unwrap()
}

fn light_move(c: &mut Criterion) {
    let mut solver = solver_of(&builtin::builtin("conference").unwrap());
    let _ = solver.solve();
    let mut g = c.benchmark_group("light_move/conference");
    g.sample_size(10).measurement_time(Duration::from_secs(20)).warm_up_time(Duration::from_secs(2));
    let mut step = 0.05f32;
    g.bench_function("move_and_solve", |b| {
        b.iter(|| {
            let mut lights = solver.scene().lights.clone();
            if let Some(Light::Point { position, .. }) = lights.first_mut() {
                position.x += step;
            }
            step = -step;
            solver.set_lights(lights);
            solver.solve()
        })
    });
    g.bench_function("solve", |b| b.iter(|| solver.solve()));
    let sol = solver.solve();
    g.bench_function("noise_variance", |b| b.iter(|| solver.noise_variance(&sol.e_source, &sol.e_gathered)));
    g.finish();
}

/// An open plane of `n x n` quads under `sky`: every link ray misses.
fn open_plane(n: u32, sky: Sky) -> SceneDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), n, n, m);
    SceneDesc {
        name: "open plane".into(),
        settings: Settings { rays_per_vertex: 256, bounces: Bounces::Fixed(3), ..Default::default() },
        camera: None,
        meshes: vec![b.finish("plane", 30.0)],
        lights: vec![],
        sky: Some(sky),
        warnings: vec![],
        notes: vec![],
    }
}

fn sky_change(c: &mut Criterion) {
    let mut window = builtin::builtin("window").unwrap();
    window.settings.rays_per_vertex = 256;
    let gradient = Sky::gradient(Vec3::new(4.0, 5.0, 7.0), Vec3::splat(4.0), Vec3::ONE);
    let (w, h) = (1024, 512);
    let pixels = (0..h)
        .flat_map(|j| (0..w).map(move |i| linkgi::sky::envmap::pixel_direction(i, j, w, h)))
        .map(|d| Vec3::new(1.0 + d.x.max(0.0), 1.0 + d.y.abs(), 2.0 - d.z))
        .collect();
    let image = Sky::image("synthetic.exr".into(), linkgi::sky::EnvMap::new(w, h, pixels).unwrap());
    for (label, desc) in [
        ("window", window),
        ("open_plane_gradient", open_plane(300, gradient)),
        ("open_plane_image", open_plane(300, image)),
    ] {
        let mut solver = solver_of(&desc);
        let mut g = c.benchmark_group(format!("sky_change/{label}"));
        g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
        let turn = |s: &mut Solver| {
            if let Some(mut sky) = s.scene().sky.clone() {
                sky.rotate_deg = (sky.rotate_deg + 10.0) % 360.0;
                s.set_sky(Some(sky));
            }
        };
        g.bench_function("e_sky", |b| {
            b.iter(|| {
                turn(&mut solver);
                solver.e_sky()
            })
        });
        g.bench_function("turn_and_solve", |b| {
            b.iter(|| {
                turn(&mut solver);
                solver.solve()
            })
        });
        g.finish();
    }
}

fn deform(c: &mut Criterion) {
    let rest = prep::prepare(&builtin::builtin("dancer").unwrap()).unwrap();
    let at = |t: f32| {
        let (positions, normals) = deform_scene(&rest, &rest.positions, &rest.normals, t);
        prep::PreparedScene { positions, normals, ..rest.clone() }
    };
    let poses = [at(0.0), at(linkgi::bench::DEFORM_TIME_S)];
    let params = SolveParams::from_settings(&rest.settings);
    let mut solver = Some(Solver::new(poses[0].clone(), params, &|_, _| {}).unwrap());
    let mut g = c.benchmark_group("deform/dancer");
    g.sample_size(10).measurement_time(Duration::from_secs(30)).warm_up_time(Duration::from_secs(2));
    // Back and forth between the poses; the scenes are cloned outside the timing.
    let mut k = 0;
    for (label, selective) in [("selective_and_solve", true), ("full_and_solve", false)] {
        g.bench_function(label, |b| {
            b.iter_custom(|iters| {
                let mut spent = Duration::ZERO;
                for _ in 0..iters {
                    k += 1;
                    let pose = poses[k % 2].clone();
                    let s = solver.take().unwrap();
                    let t = Instant::now();
                    let s = if selective {
                        s.deform(pose, params, None, &|_, _| {}).0
                    } else {
                        s.deformed(pose, params, &|_, _| {}).0
                    };
                    let _ = s.solve();
                    spent += t.elapsed();
                    solver = Some(s);
                }
                spent
            })
        });
    }
    g.finish();
}

fn refine_round(c: &mut Criterion) {
    use linkgi::links::{reassign_links, shoot_links_recording, Lineage, Recording};
    const KEEP: Recording = Recording { near: true, ray_hits: true };
    use linkgi::scene::refine::{apriori, split_world_edges, world_edge};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/scenes/cornell-mcguire/CornellBox-Original.obj");
    let Ok(desc) = linkgi::scene::load(path) else {
        eprintln!("refine_round: {path} not found, skipped");
        return;
    };
    let (desc0, _) = apriori(&desc, &desc.settings.refine);
    let scene0 = prep::prepare(&desc0).unwrap();
    let params = SolveParams::from_settings(&scene0.settings).links;
    let bvh0 = linkgi::bvh::Bvh::build(&scene0.positions, &scene0.triangles, &Default::default());
    let (_, hits0) = shoot_links_recording(&scene0, &bvh0, &params, KEEP, &|_, _| {});
    let hits0 = hits0.unwrap();
    let mut marks = std::collections::HashSet::new();
    for m in &desc0.meshes {
        let world = |i: u32| m.transform.matrix().transform_point3(m.positions[i as usize]);
        for t in &m.triangles {
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                if (a.wrapping_mul(2654435761) ^ b.wrapping_mul(40503)) % 3 == 0 {
                    marks.insert(world_edge(world(a), world(b)));
                }
            }
        }
    }
    let (desc1, parents) = split_world_edges(&desc0, &marks);
    let mut scene1 = prep::prepare(&desc1).unwrap();
    let lineage = Lineage::new(&scene0, &mut scene1, &parents, params.nudge);
    let bvh1 = linkgi::bvh::Bvh::build(&scene1.positions, &scene1.triangles, &Default::default());
    let carried = reassign_links(&scene0, &hits0, &scene1, &lineage, &bvh1, &params, true, &|_, _| {});
    let traced = shoot_links_recording(&scene1, &bvh1, &params, KEEP, &|_, _| {});
    assert!(carried.0.offsets == traced.0.offsets && carried.0.weights == traced.0.weights, "carried != traced");
    eprintln!(
        "refine_round: {} -> {} vertices, {} kept; {} rays carried, {} traced",
        scene0.vertex_count(),
        scene1.vertex_count(),
        lineage.kept_count(),
        carried.2.rays_carried,
        carried.2.rays_traced
    );
    let mut g = c.benchmark_group("refine_round/mcguire");
    g.sample_size(20).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(2));
    g.bench_function("carried", |b| {
        b.iter(|| reassign_links(&scene0, &hits0, &scene1, &lineage, &bvh1, &params, true, &|_, _| {}))
    });
    g.bench_function("traced", |b| b.iter(|| shoot_links_recording(&scene1, &bvh1, &params, KEEP, &|_, _| {})));
    g.finish();
}

criterion_group!(benches, light_move, sky_change, deform, refine_round);
criterion_main!(benches);
