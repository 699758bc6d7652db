//! Results on the caller's own vertices (`MeshRange::input_vertex`,
//! `PreparedScene::on_input`): preparation welds, splits at creases,
//! drops degenerate triangles and renumbers, and every input position
//! still finds the solver vertex that carries its value; refinement keeps
//! the input positions first, so they stay addressable.

mod common;

use glam::Vec3;
use linkgi::scene::prep::{self, NO_VERTEX};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{Bounces, Light, MeshDesc};

/// A flat-shaded cube of 8 shared positions (every corner split three
/// ways at the 90 degree creases), faces outward, one position used only by
/// a degenerate triangle, one unused.
fn cube_with_extras() -> MeshDesc {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    let mut mesh = b.finish("cube", 30.0);
    mesh.positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { 0.0 } else { 2.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let centre = Vec3::new(0.0, 1.0, 0.0);
    for quad in [[0u32, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]] {
        for t in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
            let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
            let out = (b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) > 0.0;
            mesh.triangles.push(if out { t } else { [t[0], t[2], t[1]] });
            mesh.triangle_material.push(m);
        }
    }
    let n = mesh.positions.len() as u32;
    mesh.positions.push(Vec3::new(0.5, 1.0, 0.3)); // n: a degenerate triangle's only
    mesh.positions.push(Vec3::new(0.1, 0.1, 0.1)); // n + 1: unused
    mesh.triangles.push([0, n, n]);
    mesh.triangle_material.push(m);
    mesh
}

#[test]
fn each_input_position_maps_to_its_solver_vertex() {
    let mesh = cube_with_extras();
    let desc = common::scene_desc(
        "cube",
        vec![mesh.clone()],
        vec![Light::Point { position: Vec3::new(3.0, 4.0, 2.0), intensity: Vec3::splat(3.0) }],
        None,
        64,
        Bounces::Fixed(2),
    );
    let scene = prep::prepare(&desc).unwrap();
    assert_eq!(scene.dropped_triangles, 1);
    let map = &scene.meshes[0].input_vertex;
    assert_eq!(map.len(), mesh.positions.len());
    let n = mesh.positions.len() - 2;
    assert_eq!((map[n], map[n + 1]), (NO_VERTEX, NO_VERTEX), "degenerate-only and unused positions");
    assert_eq!(scene.vertex_count(), 3 * n, "each corner split three ways at the creases");
    for (i, &v) in map[..n].iter().enumerate() {
        assert_ne!(v, NO_VERTEX, "position {i}");
        assert_eq!(scene.positions[v as usize], mesh.positions[i], "position {i}");
        // The side of its first triangle: the solver vertex's normal is that face's.
        let t = mesh.triangles.iter().find(|t| t.contains(&(i as u32))).unwrap();
        let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
        let face = (b - a).cross(c - a).normalize();
        assert!(
            scene.normals[v as usize].dot(face) > 0.999,
            "position {i}: normal {} vs face {face}",
            scene.normals[v as usize]
        );
    }
    // Results read on the input positions.
    let (solver, sol) = common::solve(&desc);
    let on = solver.scene().on_input(0, &sol.e_direct);
    assert_eq!(on.len(), mesh.positions.len());
    for (i, e) in on.iter().enumerate() {
        match map[i] {
            NO_VERTEX => assert!(e.is_none()),
            v => assert_eq!(*e, Some(sol.e_direct[v as usize])),
        }
    }
    assert!(solver.scene().on_input(1, &sol.e_direct).is_empty());
    // Into the caller's buffer: the same values, unused positions untouched.
    let mut buf = vec![Vec3::splat(-1.0); mesh.positions.len()];
    assert_eq!(solver.scene().on_input_into(0, &sol.e_direct, &mut buf), n);
    for (i, e) in on.iter().enumerate() {
        assert_eq!(buf[i], e.unwrap_or(Vec3::splat(-1.0)));
    }
    assert_eq!(solver.scene().on_input_into(0, &sol.e_direct, &mut buf[1..]), 0);
}

/// A grid whose triangles come scrambled: preparation renumbers its
/// vertices breadth-first (`scene::order`), and the map follows.
#[test]
fn the_map_survives_renumbering() {
    let mut b = MeshBuilder::new();
    let m = b.add_material("grey", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-2.0, 0.0, 2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -4.0), 40, 40, m);
    let mut mesh = b.finish("grid", 30.0);
    // A fixed shuffle of the triangles (and their materials).
    let k = mesh.triangles.len();
    let order: Vec<usize> = (0..k).map(|i| (i * 7919) % k).collect();
    mesh.triangles = order.iter().map(|&i| mesh.triangles[i]).collect();
    let desc = common::scene_desc("grid", vec![mesh.clone()], vec![], None, 16, Bounces::Fixed(1));
    let scene = prep::prepare(&desc).unwrap();
    let map = &scene.meshes[0].input_vertex;
    let renumbered = map.iter().enumerate().filter(|(i, &v)| v as usize != *i).count();
    assert!(renumbered > 0, "the scrambled grid is renumbered");
    for (i, &v) in map.iter().enumerate() {
        assert_eq!(scene.positions[v as usize], mesh.positions[i], "position {i} -> vertex {v}");
    }
}

/// Refined a priori, a coarse mesh keeps its input positions first: they
/// map to solver vertices at the same places.
#[test]
fn input_positions_stay_addressable_after_refinement() {
    let mesh = cube_with_extras();
    let desc = common::scene_desc("cube", vec![mesh.clone()], vec![], None, 16, Bounces::Fixed(1));
    let (refined, stats) = linkgi::scene::refine::apriori(&desc, &desc.settings.refine);
    assert!(stats[0].positions_after > stats[0].positions_before);
    let scene = prep::prepare(&refined).unwrap();
    let map = &scene.meshes[0].input_vertex;
    let n = mesh.positions.len() - 2;
    for i in 0..n {
        assert_eq!(scene.positions[map[i] as usize], mesh.positions[i], "input position {i}");
    }
    assert_eq!((map[n], map[n + 1]), (NO_VERTEX, NO_VERTEX));
}

/// A deformation given in the caller's vertex order
/// (`PreparedScene::positions_from_input`) is the deformation in solver
/// order: the same positions for every solver vertex (crease copies
/// included), and the engine publishes the same result for either.
#[test]
fn a_deformation_in_input_order_equals_it_in_solver_order() {
    use linkgi::engine::{Change, Engine, EngineParams};
    use linkgi::solver::{Compute, SolveParams};
    let mut cube = cube_with_extras();
    cube.dynamic = true;
    let mut b = MeshBuilder::new();
    let m = b.add_material("floor", Vec3::splat(0.6));
    b.quad_grid(Vec3::new(-3.0, -0.5, 3.0), Vec3::new(6.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -6.0), 12, 12, m);
    let floor = b.finish("floor", 30.0);
    let desc = common::scene_desc(
        "moving cube",
        vec![floor, cube.clone()],
        vec![Light::Point { position: Vec3::new(2.0, 4.0, 1.0), intensity: Vec3::splat(20.0) }],
        None,
        64,
        Bounces::Fixed(2),
    );
    let scene = prep::prepare(&desc).unwrap();
    // A twist about y and a lift, as a function of the point.
    let f = |p: Vec3| {
        let (s, c) = (0.3 * p.y).sin_cos();
        Vec3::new(c * p.x - s * p.z, p.y + 0.25, s * p.x + c * p.z)
    };
    let input: Vec<Vec3> = cube.positions.iter().map(|&p| f(p)).collect();
    let from_input = scene.positions_from_input(1, &input).expect("mesh 1, all its positions");
    let range = scene.meshes[1].vertices.clone();
    let solver_order: Vec<Vec3> =
        scene.positions.iter().enumerate().map(|(v, &p)| if range.contains(&(v as u32)) { f(p) } else { p }).collect();
    assert_eq!(from_input, solver_order);
    assert!(scene.positions_from_input(1, &input[1..]).is_none() && scene.positions_from_input(2, &input).is_none());

    let run = |positions: Vec<Vec3>| {
        let params = SolveParams::from_settings(&scene.settings);
        let mut e =
            Engine::start(scene.clone(), params, Compute::Cpu, EngineParams::default()).expect("the worker starts");
        e.send(Change::Deform { positions });
        assert!(e.wait_idle(std::time::Duration::from_secs(120)));
        e.latest().unwrap()
    };
    let (a, b) = (run(from_input), run(solver_order));
    assert!(a.version >= 2 && b.version >= 2, "the deformation was applied: versions {} and {}", a.version, b.version);
    assert_eq!(a.e_indirect, b.e_indirect);
    assert_eq!(a.e_direct, b.e_direct);
    assert!(a.e_direct.iter().any(|e| e.x > 0.0));
}
