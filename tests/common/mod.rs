//! Shared helpers of the integration tests.
#![allow(dead_code)]

use glam::Vec3;
use linkgi::scene::{prep, Bounces, SceneDesc};
use linkgi::solver::{Solution, SolveParams, Solver};

/// Prepares and solves `desc` with its own settings; validates the tree and links.
pub fn solve(desc: &SceneDesc) -> (Solver, Solution) {
    let scene = prep::prepare(desc).expect("scene prepares");
    let params = SolveParams::from_settings(&scene.settings);
    solve_with(scene, params)
}

pub fn solve_with(scene: prep::PreparedScene, params: SolveParams) -> (Solver, Solution) {
    let solver = Solver::new(scene, params, &|_, _| {});
    solver.validate().expect("every structure and table valid");
    let sol = solver.solve();
    for v in sol.e_direct.iter().chain(&sol.e_indirect).chain(&sol.e_indirect_raw) {
        assert!(v.is_finite(), "non-finite irradiance {v}");
        assert!(v.min_element() >= 0.0, "negative irradiance {v}");
    }
    (solver, sol)
}

/// A scene of `meshes` and `lights` (optional sky) with `rays` per vertex,
/// `bounces` and smoothing off, no camera (renders frame it).
pub fn scene_desc(
    name: &str,
    meshes: Vec<linkgi::scene::MeshDesc>,
    lights: Vec<linkgi::scene::Light>,
    sky: Option<linkgi::sky::Sky>,
    rays: u32,
    bounces: Bounces,
) -> SceneDesc {
    SceneDesc {
        name: name.into(),
        settings: linkgi::scene::Settings {
            rays_per_vertex: rays,
            bounces,
            smoothing_angle_deg: 0.0,
            ..Default::default()
        },
        camera: None,
        meshes,
        lights,
        sky,
        warnings: vec![],
        notes: vec![],
    }
}

pub fn with_settings(mut desc: SceneDesc, rays: u32, bounces: Bounces, smoothing: f32) -> SceneDesc {
    desc.settings.rays_per_vertex = rays;
    desc.settings.bounces = bounces;
    desc.settings.smoothing_angle_deg = smoothing;
    desc
}

pub fn mean(v: &[Vec3]) -> Vec3 {
    v.iter().copied().sum::<Vec3>() / v.len() as f32
}

/// Total area of the scene's triangles, m^2.
pub fn mesh_area(s: &prep::PreparedScene) -> f32 {
    s.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| s.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// A random point in `[lo, hi)^3`.
pub fn rvec(rng: &mut rand_pcg::Pcg32, lo: f32, hi: f32) -> Vec3 {
    use rand::Rng;
    Vec3::new(rng.random_range(lo..hi), rng.random_range(lo..hi), rng.random_range(lo..hi))
}

/// Random triangle soup: `n` triangles of size ~`size` in a unit cube.
pub fn soup(rng: &mut rand_pcg::Pcg32, n: usize, size: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut pos = Vec::new();
    let mut tris = Vec::new();
    for i in 0..n as u32 {
        let c = rvec(rng, 0.0, 1.0);
        pos.extend([c + rvec(rng, -size, size), c + rvec(rng, -size, size), c + rvec(rng, -size, size)]);
        tris.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    (pos, tris)
}
