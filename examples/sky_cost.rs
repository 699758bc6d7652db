//! Cost of a sky change (a gather-only update): `E_sky` from the miss masks
//! and the whole solve, on `window` and on a worst case where every ray
//! misses (an open plane of N x N quads): `cargo run --release --example sky_cost -- 300`.
use glam::Vec3;
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, prep, Bounces, Camera, SceneDesc, Settings};
use linkgi::sky::Sky;
use linkgi::solver::{SolveParams, Solver};
use std::time::Instant;

fn time(desc: &SceneDesc, label: &str) {
    let scene = prep::prepare(desc).unwrap();
    let mut solver = Solver::new(scene, SolveParams::from_settings(&desc.settings), &|_, _| {});
    let mut sky = solver.scene.sky.clone().unwrap();
    let (mut e_ms, mut s_ms) = (f64::MAX, f64::MAX);
    for k in 0..5 {
        sky.rotate_deg = 10.0 * k as f32;
        solver.scene.sky = Some(sky.clone());
        let t = Instant::now();
        let e = solver.e_sky();
        e_ms = e_ms.min(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let _ = solver.solve();
        s_ms = s_ms.min(t.elapsed().as_secs_f64() * 1e3);
        std::hint::black_box(e);
    }
    println!(
        "{label}: {} vertices, {} missed rays, sky masks {:.2} MB: E_sky {e_ms:.1} ms, whole solve {s_ms:.1} ms",
        solver.scene.vertex_count(),
        solver.links.sky.missed_rays(),
        solver.links.sky.bytes() as f64 / 1e6
    );
}

fn main() {
    let n: u32 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(300);
    let mut w = builtin::builtin("window").unwrap();
    w.settings.rays_per_vertex = 256;
    time(&w, "window");
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), n, n, m);
    let mut sky = Sky::gradient(Vec3::new(4.0, 5.0, 7.0), Vec3::splat(4.0), Vec3::ONE);
    sky.rotate_deg = 0.0;
    let plane = SceneDesc {
        name: "plane".into(),
        settings: Settings { rays_per_vertex: 256, bounces: Bounces::Fixed(3), ..Default::default() },
        camera: Camera::default(),
        meshes: vec![b.finish("plane", 30.0)],
        lights: vec![],
        sky: Some(sky),
        warnings: vec![],
    };
    time(&plane, "open plane (every ray misses), gradient sky");
    // The same plane under a 1024 x 512 image sky.
    let (w, h) = (1024, 512);
    let pixels = (0..h)
        .flat_map(|j| (0..w).map(move |i| linkgi::sky::envmap::pixel_direction(i, j, w, h)))
        .map(|d| Vec3::new(1.0 + d.x.max(0.0), 1.0 + d.y.abs(), 2.0 - d.z))
        .collect();
    let mut img = plane;
    img.sky = Some(Sky::image("synthetic.exr".into(), linkgi::sky::EnvMap::new(w, h, pixels).unwrap()));
    time(&img, "open plane (every ray misses), 1024 x 512 image sky");
}
