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
    let solver = Solver::new(scene, params, &|_, _| {}).unwrap();
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

/// A regular grid of `n x n` quads on a plane of constant `axis`
/// coordinate `at`, sharing vertices (a flat, regular mesh).
pub fn grid(n: u32, axis: usize, at: f32, pos: &mut Vec<Vec3>, tris: &mut Vec<[u32; 3]>) {
    let base = pos.len() as u32;
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    for i in 0..=n {
        for j in 0..=n {
            let mut p = Vec3::ZERO;
            p[axis] = at;
            p[a] = i as f32 / n as f32;
            p[b] = j as f32 / n as f32;
            pos.push(p);
        }
    }
    let id = |i: u32, j: u32| base + i * (n + 1) + j;
    for i in 0..n {
        for j in 0..n {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
}

/// Random rays over the unit cube: every 7th axis-parallel, every 3rd a
/// segment, every 4th with a positive `tmin`, every 5th skipping a vertex
/// below `skip_max`.
pub fn random_rays(rng: &mut rand_pcg::Pcg32, count: usize, skip_max: u32) -> Vec<linkgi::trace::ray::Ray> {
    use rand::Rng;
    (0..count)
        .map(|i| {
            let origin = rvec(rng, -0.2, 1.2);
            let dir = if i % 7 == 0 {
                // Axis-parallel directions (zero components).
                let mut d = Vec3::ZERO;
                d[i % 3] = if i % 2 == 0 { 1.0 } else { -1.0 };
                d
            } else {
                rvec(rng, -1.0, 1.0).normalize()
            };
            let mut r = linkgi::trace::ray::Ray::new(origin, dir);
            if i % 3 == 0 {
                r.tmax = rng.random_range(0.1..2.0);
            }
            if i % 4 == 0 {
                r.tmin = rng.random_range(0.0..0.3);
            }
            if i % 5 == 0 && skip_max > 0 {
                r.skip = rng.random_range(0..skip_max);
            }
            r
        })
        .collect()
}

/// Loads a scene file with `settings` as its `[settings]` table over a
/// 4 m square (`q.obj`), written to the temporary folder `dir`.
pub fn load_with_settings(dir: &str, settings: &str) -> linkgi::Result<SceneDesc> {
    let dir = std::env::temp_dir().join(format!("{dir}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("q.obj"), "v 0 0 0\nv 4 0 0\nv 4 0 4\nv 0 0 4\nf 1 3 2\nf 1 4 3\n").unwrap();
    let p = dir.join("s.toml");
    std::fs::write(&p, format!("[settings]\n{settings}\n[[mesh]]\nobj = \"q.obj\"\n")).unwrap();
    linkgi::scene::load(p.to_str().unwrap())
}
