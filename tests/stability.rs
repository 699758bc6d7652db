//! Stability suite: extreme albedo, scale, light placement, intensities and
//! degenerate geometry. Every case asserts finite, non-negative results
//! (tests/common) and a bound that could fail: energy conservation, exact
//! scaling laws, or a known answer.

mod common;

use glam::Vec3;
use linkgi::exchange::bounce::gather::gather_bounce;
use linkgi::scene::{builtin, prep, shapes::MeshBuilder, Bounces, Light, Material, MeshDesc, SceneDesc, Settings};
use linkgi::solver::{Solution, SolveParams, Solver};

fn area_weighted_mean(s: &prep::PreparedScene, e: &[Vec3]) -> Vec3 {
    // Each vertex stands for a third of the area of its triangles.
    let mut sum = Vec3::ZERO;
    let mut area = 0.0;
    for t in &s.triangles {
        let [a, b, c] = t.map(|i| s.positions[i as usize]);
        let ar = 0.5 * (b - a).cross(c - a).length();
        for &i in t {
            sum += e[i as usize] * (ar / 3.0);
        }
        area += ar;
    }
    sum / area
}

/// Left eigenvector `s` (sum 1) of the link operator `P = W / pi` and its
/// eigenvalue `lambda` (1 when every ray lands), by power iteration.
fn stationary(links: &linkgi::links::Links) -> (Vec<f64>, f64) {
    let n = links.vertex_count();
    let mut s = vec![1.0 / n as f64; n];
    let mut lambda = 1.0;
    for _ in 0..500 {
        let mut next = vec![0f64; n];
        for (v, sv) in s.iter().enumerate() {
            let (t, w) = links.group(v);
            for (&t, &w) in t.iter().zip(w) {
                next[t as usize] += sv * w.to_f64() / std::f64::consts::PI;
            }
        }
        lambda = next.iter().sum::<f64>();
        s = next.into_iter().map(|x| x / lambda).collect();
    }
    (s, lambda)
}

/// In a closed scene of uniform albedo rho, the discrete system conserves
/// energy in the weights `s` of the link operator's stationary state:
/// `s . (E_d + E_i) = s . E_d / (1 - rho lambda)` exactly, with
/// `lambda <= 1` (no energy created; 1 when no ray escapes). Checks that
/// auto bounces (with the estimated tail) reach that within 1%, and that the
/// area-weighted total stays below `E_d / (1 - rho)` (area mean of `E_d`).
fn assert_closed_energy(solver: &Solver, sol: &Solution, rho: f32, what: &str) {
    let (s, lambda) = stationary(&solver.links());
    let dot = |e: &[Vec3]| -> f64 { e.iter().zip(&s).map(|(e, s)| e.x as f64 * s).sum() };
    let (sd, si) = (dot(&sol.e_direct), dot(&sol.e_indirect_raw));
    let expect = sd / (1.0 - rho as f64 * lambda);
    let ed = area_weighted_mean(&solver.scene(), &sol.e_direct).x;
    let ei = area_weighted_mean(&solver.scene(), &sol.e_indirect_raw).x;
    let bound = ed / (1.0 - rho);
    eprintln!(
        "{what}: lambda {lambda:.6}, s.E {:.4} expected {expect:.4}; area mean E_d + E_i {:.4}, E_d/(1-rho) {bound:.4}, {} bounces",
        sd + si,
        ed + ei,
        sol.gather.bounces
    );
    assert!(lambda <= 1.0 + 1e-3, "{what}: link operator gains energy, lambda {lambda}");
    assert!(((sd + si) / expect - 1.0).abs() < 0.01, "{what}: s.E = {} expected {expect}", sd + si);
    assert!(ed + ei <= bound * 1.02, "{what}: E_d + E_i = {} exceeds E_d/(1-rho) = {bound}", ed + ei);
}

/// Every vertex: `E_i <= rho_max / (1 - rho_max) * max E_d` (links carry at
/// most the cosine-weighted hemisphere, row sums <= pi), and row sums <= pi.
fn assert_open_energy(solver: &Solver, sol: &Solution, what: &str) {
    let rho = solver.scene().albedo.iter().map(|a| a.max_element()).fold(0.0, f32::max);
    let max_d = sol.e_direct.iter().map(|e| e.max_element()).fold(0.0, f32::max);
    let max_i = sol.e_indirect_raw.iter().map(|e| e.max_element()).fold(0.0, f32::max);
    let bound = rho / (1.0 - rho) * max_d;
    assert!(max_i <= bound * 1.001 + f32::MIN_POSITIVE, "{what}: max E_i {max_i} exceeds {bound}");
    for v in 0..solver.links().vertex_count() {
        let s = solver.links().row_sum(v);
        assert!(s <= std::f64::consts::PI * 1.002, "{what}: vertex {v} link row sum {s} > pi");
    }
}

#[test]
fn stiff_albedo_furnace_and_closed_room() {
    for rho in [0.99f32, 0.999] {
        let desc =
            common::with_settings(builtin::furnace(rho, 2, Vec3::new(0.3, -0.2, 0.1), 1.0), 64, Bounces::Auto, 30.0);
        let (solver, sol) = common::solve(&desc);
        assert_closed_energy(&solver, &sol, rho, &format!("furnace rho {rho}"));
        // The link operator's own balance holds for the plain gather; the
        // radiosity correction (`exchange::bounce::reconstruct`) changes the
        // operator, checked below against the continuous balance.
        let desc = common::with_settings(builtin::closed_room(6, rho), 64, Bounces::Auto, 30.0);
        let scene = prep::prepare(&desc).expect("scene prepares");
        let mut plain = SolveParams::from_settings(&scene.settings);
        plain.terms.reconstruct = false;
        let (solver, sol) = common::solve_with(scene, plain);
        assert_closed_energy(&solver, &sol, rho, &format!("closed room rho {rho}"));
        assert!(sol.gather.bounces < 100_000, "auto bounces hit the limit");
        let (corrected_solver, corrected) = common::solve(&desc);
        assert!(corrected.gather.bounces < 100_000, "auto bounces hit the limit");
        closer_to_the_closed_balance(&solver, &sol, &corrected_solver, &corrected, rho);
    }
}

/// In a closed room of uniform albedo every watt is absorbed in the end:
/// the area mean of `E_d + E_i` is exactly `mean E_d / (1 - rho)`. Linear
/// interpolation at the link hits reads the walls' radiosity low toward
/// the corners, so the plain links fall short (measured at rho 0.99: 48.8
/// against 51.7, 5.4% low; 487.9 against 516.8 at 0.999); the gradient
/// correction must not pass the balance (no energy created) and must close
/// at least three quarters of the gap (measured 51.38 and 513.8: 89% and
/// 90%).
fn closer_to_the_closed_balance(plain: &Solver, a: &Solution, corrected: &Solver, b: &Solution, rho: f32) {
    let total = |s: &Solver, x: &Solution| {
        (area_weighted_mean(&s.scene(), &x.e_direct).x + area_weighted_mean(&s.scene(), &x.e_indirect_raw).x) as f64
    };
    let bound = area_weighted_mean(&plain.scene(), &a.e_direct).x as f64 / (1.0 - rho as f64);
    let (ta, tb) = (total(plain, a), total(corrected, b));
    eprintln!("closed room rho {rho}: area mean E_d + E_i {ta:.4} plain, {tb:.4} corrected, balance {bound:.4}");
    assert!(b.e_indirect_raw.iter().all(|e| e.is_finite() && e.min_element() >= 0.0));
    assert!(tb <= bound * 1.002, "rho {rho}: the correction creates energy: {tb} against {bound}");
    assert!(bound - tb < 0.25 * (bound - ta), "rho {rho}: {tb} closes too little of the gap from {ta} to {bound}");
}

fn scaled(desc: &SceneDesc, s: f32) -> SceneDesc {
    let mut d = desc.clone();
    for m in &mut d.meshes {
        for p in &mut m.positions {
            *p *= s;
        }
    }
    for l in &mut d.lights {
        if let Light::Point { position, .. } = l {
            *position *= s;
        }
    }
    d
}

/// Irradiance from a point light falls as 1/r^2 and links are scale free:
/// the scene at scale s has `E(s) s^2 = E(1)`.
#[test]
fn scale_invariance() {
    let base = common::with_settings(builtin::closed_room(5, 0.6), 64, Bounces::Fixed(3), 30.0);
    let (_, ref_sol) = common::solve(&base);
    for s in [1e-4f32, 1e4] {
        let (_, sol) = common::solve(&scaled(&base, s));
        let mut worst = 0f32;
        for (a, b) in sol.e_indirect.iter().zip(&ref_sol.e_indirect).chain(sol.e_direct.iter().zip(&ref_sol.e_direct)) {
            let rel = ((*a * s * s - *b).abs() / b.max(Vec3::splat(1e-30))).max_element();
            worst = worst.max(rel);
        }
        eprintln!("scale {s}: worst relative difference {worst:.2e}");
        assert!(worst < 1e-3, "scale {s}: relative difference {worst}");
    }
}

fn with_light(mut desc: SceneDesc, light: Light) -> SceneDesc {
    desc.lights = vec![light];
    desc
}

/// A light 1e-6 m above the floor and one exactly on a floor vertex: finite
/// everywhere, energy bounded; the vertex under the first is clamped at
/// `I / (min_distance l)^2` (documented in exchange::sources::light_links), the one
/// under the second has the light in its tangent plane and gets nothing.
#[test]
fn light_touching_a_surface() {
    let room = common::with_settings(builtin::closed_room(4, 0.5), 64, Bounces::Fixed(3), 0.0);
    let scene = prep::prepare(&room).unwrap();
    // A floor vertex (y = 0, normal +y) away from the walls.
    let v = (0..scene.vertex_count())
        .find(|&v| {
            scene.positions[v].y == 0.0
                && scene.normals[v].y > 0.99
                && scene.positions[v].x.abs() < 0.9
                && scene.positions[v].z.abs() < 0.9
        })
        .expect("an inner floor vertex");
    let p = scene.positions[v];
    for (what, pos) in [("1e-6 above", p + Vec3::Y * 1e-6), ("on the vertex", p)] {
        let desc = with_light(room.clone(), Light::Point { position: pos, intensity: Vec3::ONE });
        let (solver, sol) = common::solve(&desc);
        let ed = sol.e_direct[v].x;
        eprintln!("light {what}: E_d at the vertex {ed:.3e}, mean E_i {:.3e}", common::mean(&sol.e_indirect).x);
        if pos == p {
            assert_eq!(ed, 0.0, "a light in the tangent plane lights nothing");
            let floor_lit = (0..sol.e_direct.len())
                .filter(|&u| solver.scene().normals[u].y > 0.99 && sol.e_direct[u].x > 0.0)
                .count();
            assert_eq!(floor_lit, 0, "the light lies in the floor's plane");
            assert!(sol.e_direct.iter().any(|e| e.x > 0.0), "the walls are lit");
        } else {
            assert!(ed > 0.0, "{what}: the vertex under the light gets nothing");
        }
        let d = solver.params().light.min_distance * solver.scene().mean_edge_length(v);
        assert!(ed <= 1.0 / (d * d) * 1.0001, "{what}: E_d {ed} above the clamp {}", 1.0 / (d * d));
        assert_open_energy(&solver, &sol, what);
    }
}

/// E is linear in the intensity: 1e-12 and 1e12 W/sr give 1e-12 and 1e12
/// times the result at 1 W/sr (no underflow, no overflow).
#[test]
fn extreme_intensities_scale_linearly() {
    let base = common::with_settings(builtin::closed_room(4, 0.7), 64, Bounces::Auto, 30.0);
    let (_, one) = common::solve(&base);
    for k in [1e-12f32, 1e12] {
        let mut desc = base.clone();
        for l in &mut desc.lights {
            if let Light::Point { intensity, .. } = l {
                *intensity *= k;
            }
        }
        let (_, sol) = common::solve(&desc);
        assert_eq!(sol.gather.bounces, one.gather.bounces, "intensity {k}: bounce count changed");
        let mut worst = 0f32;
        for (a, b) in sol.e_indirect.iter().zip(&one.e_indirect).chain(sol.e_direct.iter().zip(&one.e_direct)) {
            worst = worst.max(((*a / k - *b).abs() / b.max(Vec3::splat(1e-30))).max_element());
        }
        eprintln!("intensity {k:e}: worst relative deviation from linear {worst:.2e}");
        assert!(worst < 1e-5, "intensity {k}: deviation {worst}");
    }
}

fn grey(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        triangle_material: vec![0; triangles.len()],
        positions,
        triangles,
        materials: vec![Material { name: "grey".into(), albedo: Vec3::splat(0.8), emission: Vec3::ZERO }],
        vertex_albedo: None,
        vertex_emission: None,
        textures: None,
        crease_angle_deg: 60.0,
        transform: Default::default(),
        dynamic: false,
        deform: Vec::new(),
        source: None,
    }
}

fn custom(meshes: Vec<MeshDesc>, lights: Vec<Light>) -> SceneDesc {
    SceneDesc {
        name: "custom".into(),
        settings: Settings {
            rays_per_vertex: 64,
            bounces: Bounces::Fixed(3),
            smoothing_angle_deg: 30.0,
            seed: 1,
            ..Default::default()
        },
        camera: None,
        meshes,
        lights,
        sky: None,
        warnings: vec![],
        notes: vec![],
    }
}

fn above(p: Vec3) -> Vec<Light> {
    vec![Light::Point { position: p, intensity: Vec3::ONE }]
}

/// A floor of two triangles (normal +y) plus `extra` triangles on the same
/// positions list.
fn floor_with(extra_pos: &[Vec3], extra_tris: &[[u32; 3]]) -> MeshDesc {
    let mut p = vec![
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
    ];
    let mut t = vec![[0, 1, 2], [0, 2, 3]];
    let base = p.len() as u32;
    p.extend_from_slice(extra_pos);
    t.extend(extra_tris.iter().map(|tri| tri.map(|i| i + base)));
    grey("floor", p, t)
}

/// Solves and checks the open-scene energy bound.
fn solve_open(desc: &SceneDesc, what: &str) -> (Solver, Solution) {
    let (solver, sol) = common::solve(desc);
    assert_open_energy(&solver, &sol, what);
    (solver, sol)
}

const LIGHT: Vec3 = Vec3::new(0.1, 1.0, 0.2);

/// A 1 m long, 1e-5 m wide sliver facing the floor, and one facing up.
fn sliver_scene() -> SceneDesc {
    custom(
        vec![floor_with(
            &[
                Vec3::new(-0.5, 0.2, 0.0),
                Vec3::new(0.5, 0.2, 0.0),
                Vec3::new(0.0, 0.2, 1e-5),
                Vec3::new(0.0, 0.3, 1e-5),
            ],
            &[[0, 1, 2], [0, 3, 1]],
        )],
        above(LIGHT),
    )
}

/// A floor with a zero-area triangle and one with a repeated corner.
fn zero_area_scene() -> SceneDesc {
    custom(
        vec![floor_with(
            &[Vec3::new(-0.5, 0.2, 0.0), Vec3::new(0.5, 0.2, 0.0), Vec3::new(0.0, 0.2, 0.0)],
            &[[0, 1, 2], [0, 0, 1]],
        )],
        above(LIGHT),
    )
}

/// The floor with two fins on its diagonal: four triangles share the edge.
fn fins() -> MeshDesc {
    let mut m = floor_with(&[], &[]);
    let top = m.positions.len() as u32;
    m.positions.extend([Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.3, 0.5, -0.3)]);
    m.triangles.extend([[0, 2, top], [2, 0, top + 1]]);
    m.triangle_material.extend([0, 0]);
    m
}

#[test]
fn sliver_triangles() {
    let desc = sliver_scene();
    let (solver, sol) = solve_open(&desc, "sliver");
    assert_eq!(solver.scene().dropped_triangles, 0, "slivers have area and are kept");
    // The floor sees the sliver's underside (lit by nothing but the floor): E_i > 0 somewhere.
    assert!(sol.e_indirect_raw.iter().any(|e| e.x > 0.0));
}

#[test]
fn zero_area_triangles_are_dropped() {
    let desc = zero_area_scene();
    let (solver, sol) = solve_open(&desc, "zero-area");
    assert_eq!(solver.scene().triangles.len(), 2, "only the floor remains");
    assert!(solver.scene().dropped_triangles >= 1);
    // A flat floor alone: nothing to bounce from.
    assert!(sol.e_indirect.iter().all(|e| *e == Vec3::ZERO));
}

#[test]
fn duplicated_vertices_weld_to_the_same_answer() {
    let plain = custom(vec![floor_with(&[], &[])], above(LIGHT));
    // The second floor triangle uses copies of corners 0 and 2.
    let mut dup = plain.clone();
    let m = &mut dup.meshes[0];
    m.positions.push(m.positions[0]);
    m.positions.push(m.positions[2]);
    m.triangles[1] = [4, 5, 3];
    let (a_solver, a) = solve_open(&plain, "plain");
    let (b_solver, b) = solve_open(&dup, "duplicated");
    assert_eq!(a_solver.scene().vertex_count(), b_solver.scene().vertex_count(), "duplicates are welded");
    for (x, y) in a.e_direct.iter().zip(&b.e_direct) {
        assert!((*x - *y).abs().max_element() <= 1e-6 * y.max_element());
    }
}

#[test]
fn non_manifold_edge() {
    let (solver, sol) = solve_open(&custom(vec![fins()], above(LIGHT)), "non-manifold");
    assert_eq!(solver.scene().triangles.len(), 4);
    // The fins and the floor light each other.
    assert!(sol.e_indirect_raw.iter().filter(|e| e.x > 0.0).count() >= 3);
}

/// One triangle under a light: `E_d = I cos / r^2` at each corner (nothing
/// occludes), `E_i = 0` (nothing to bounce from).
#[test]
fn single_triangle() {
    let desc = custom(vec![grey("tri", vec![Vec3::ZERO, Vec3::Z, Vec3::X], vec![[0, 1, 2]])], above(LIGHT));
    let (solver, sol) = solve_open(&desc, "single triangle");
    for v in 0..solver.scene().vertex_count() {
        let d = LIGHT - solver.scene().positions[v];
        let g = d.y / d.length().powi(3);
        assert!((sol.e_direct[v].x / g - 1.0).abs() < 1e-5, "vertex {v}: E_d {} expected {g}", sol.e_direct[v].x);
        assert_eq!(sol.e_indirect[v], Vec3::ZERO);
    }
}

#[test]
fn no_lights_gives_zero() {
    let (_, sol) = common::solve(&with_light(
        builtin::closed_room(3, 0.8),
        Light::Point { position: Vec3::ONE, intensity: Vec3::ZERO },
    ));
    assert!(sol.e_direct.iter().chain(&sol.e_indirect).all(|e| *e == Vec3::ZERO));
    let mut desc = builtin::closed_room(3, 0.8);
    desc.lights.clear();
    desc.settings.bounces = Bounces::Auto;
    let (_, sol) = common::solve(&desc);
    assert!(sol.e_direct.iter().chain(&sol.e_indirect).all(|e| *e == Vec3::ZERO));
}

/// A box open at the top with outward faces, lit from outside: it is
/// convex, so no outer face sees another and E_i is exactly zero; rays that
/// enter the opening meet back faces and bring nothing.
#[test]
fn open_box_seen_from_outside() {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.8));
    let s = Some(m);
    b.cuboid_open(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5), [4; 3], [s, s, s, None, s, s], false);
    let desc = custom(vec![b.finish("open box", 30.0)], above(Vec3::new(1.5, 2.0, 1.0)));
    let (_, sol) = solve_open(&desc, "open box");
    assert!(sol.e_direct.iter().any(|e| e.x > 0.0), "some outer face is lit");
    let max_i = sol.e_indirect_raw.iter().map(|e| e.max_element()).fold(0.0, f32::max);
    assert_eq!(max_i, 0.0, "a convex outward box cannot light itself");
}

/// The gather's per-vertex sum over thousands of links (f32) agrees with
/// an f64 sum of the same weights within 1e-5 relative. Synthetic links:
/// vertex 0 links to 5000 others with f16 weights summing to about pi,
/// radiosities spread over six orders of magnitude.
#[test]
fn f32_accumulation_over_thousands_of_links() {
    use half::f16;
    let n = 5001usize;
    let m = n - 1;
    let mut offsets = vec![0, m as u32];
    offsets.extend(std::iter::repeat_n(m as u32, n - 1));
    let targets: Vec<u32> = (1..n as u32).collect();
    // Weights varying by a factor of 100, summing to about pi.
    let raw: Vec<f64> = (0..m).map(|i| 1.0 + 99.0 * ((i * 2654435761usize) % 1000) as f64 / 1000.0).collect();
    let total: f64 = raw.iter().sum();
    let weights = raw.iter().map(|w| f16::from_f64(w / total * std::f64::consts::PI)).collect();
    let links = linkgi::links::Links::from_csr(offsets, &targets, weights);
    links.validate().expect("valid links");
    let b: Vec<Vec3> =
        (0..n).map(|i| Vec3::splat(10f32.powf(((i * 7919) % 1000) as f32 / 1000.0 * 6.0 - 3.0))).collect();
    let mut out = vec![Vec3::ZERO; n];
    gather_bounce(&links, &b, &mut out);
    let (t, w) = links.group(0);
    let exact: f64 = t.iter().zip(w).map(|(&t, &w)| w.to_f64() * b[t as usize].x as f64).sum();
    let rel = (out[0].x as f64 / exact - 1.0).abs();
    eprintln!("{m} links: f32 vs f64 relative difference {rel:.2e}");
    assert!(rel < 1e-5, "f32 accumulation off by {rel}");
    assert!(out[1..].iter().all(|e| *e == Vec3::ZERO));
}

/// The suite's coarse and degenerate cases with refinement on (`refine =
/// "auto"`, through `solver::adaptive`, error-driven rounds carrying their
/// rays): a closed room of one quad a wall at stiff albedo keeps the
/// closed balance of its (refined) link operator and never passes
/// `E_d / (1 - rho)`; slivers, dropped and non-manifold triangles stay
/// within the open-scene bound; a lone triangle reads `I cos / r^2` at
/// every refined vertex; a convex open box still cannot light itself.
#[test]
fn coarse_and_degenerate_cases_with_refinement_on() {
    use linkgi::solver::{adaptive, Compute};
    let refined = |desc: &SceneDesc, what: &str| {
        let r = adaptive::solve(desc, &Compute::Cpu, &|_, _| {}).expect("solves");
        r.solver.validate().expect("every structure and table valid");
        for v in r.solution.e_direct.iter().chain(&r.solution.e_indirect).chain(&r.solution.e_indirect_raw) {
            assert!(v.is_finite() && v.min_element() >= 0.0, "{what}: {v}");
        }
        let verts: Vec<usize> = r.rounds.iter().map(|r| r.vertices).collect();
        eprintln!("{what}: vertices per round {verts:?}");
        r
    };
    for rho in [0.99f32, 0.999] {
        let mut desc = common::with_settings(builtin::closed_room(1, rho), 64, Bounces::Auto, 30.0);
        desc.settings.terms.reconstruct = false;
        assert!(adaptive::Plan::of(&desc).refining, "a room of one quad a wall is coarse");
        let r = refined(&desc, "closed room");
        assert!(r.solver.scene().vertex_count() > 100, "refined");
        assert_closed_energy(&r.solver, &r.solution, rho, &format!("refined closed room rho {rho}"));
    }
    let (sliver, zero_area) = (sliver_scene(), zero_area_scene());
    for (what, desc) in
        [("sliver", sliver), ("zero-area", zero_area), ("non-manifold", custom(vec![fins()], above(LIGHT)))]
    {
        let r = refined(&desc, what);
        assert!(r.solver.scene().vertex_count() > 20, "{what}: refined");
        assert_open_energy(&r.solver, &r.solution, what);
    }
    let lone = custom(vec![grey("tri", vec![Vec3::ZERO, Vec3::Z, Vec3::X], vec![[0, 1, 2]])], above(LIGHT));
    let r = refined(&lone, "single triangle");
    assert!(r.solver.scene().vertex_count() > 3, "refined");
    for v in 0..r.solver.scene().vertex_count() {
        let d = LIGHT - r.solver.scene().positions[v];
        let g = d.y / d.length().powi(3);
        assert!((r.solution.e_direct[v].x / g - 1.0).abs() < 1e-5, "vertex {v}: E_d {}", r.solution.e_direct[v].x);
        assert_eq!(r.solution.e_indirect[v], Vec3::ZERO);
    }
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.8));
    let s = Some(m);
    b.cuboid_open(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5), [1; 3], [s, s, s, None, s, s], false);
    let r = refined(&custom(vec![b.finish("open box", 30.0)], above(Vec3::new(1.5, 2.0, 1.0))), "open box");
    let max_i = r.solution.e_indirect_raw.iter().map(|e| e.max_element()).fold(0.0, f32::max);
    assert_eq!(max_i, 0.0, "a convex outward box cannot light itself, refined or not");
}
