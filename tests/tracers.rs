//! The two CPU tracers give the same links: on every built-in scene up to
//! `tearoom`, every vertex's rays are traced through the wide BVH and the
//! kd-tree rope walk; where a ray's hit differs, brute force decides, and
//! the BVH must be the one that agrees with it. Merged link groups of
//! vertices whose rays all agree are equal, and so are the solvers' links
//! when no ray differs. Shadow rays (light links) agree as well.

use linkgi::bvh::{Bvh, BvhBuildParams};
use linkgi::exchange::LightLinks;
use linkgi::kdtree::traverse::brute_force;
use linkgi::links::{RaySetup, HIT_BACK, HIT_MISS};
use linkgi::scene::{builtin, prep, TracerKind};
use linkgi::solver::{SolveParams, Solver};
use linkgi::trace::ray::Ray;

fn agree_on(name: &str) {
    let desc = builtin::builtin(name).expect("built-in");
    let scene = prep::prepare(&desc).expect("prepares");
    let mut params = SolveParams::from_settings(&scene.settings);
    params.tracer = TracerKind::Bvh;
    let bvh_solver = Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
    params.tracer = TracerKind::Kd;
    let kd_solver = Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
    for s in [&bvh_solver, &kd_solver] {
        s.accel().validate().expect("structure valid");
        s.links().validate().expect("links valid");
    }
    let bvh = bvh_solver.accel().bvh().expect("bvh");
    let kd = kd_solver.accel().kd().expect("kd");

    // Ray by ray.
    let setup = RaySetup::new(&scene, &params.links);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let (mut rays, mut differ, mut kd_wrong) = (0usize, 0usize, 0usize);
    let mut vertex_same = vec![true; scene.vertex_count()];
    for v in 0..scene.vertex_count() {
        setup.trace_vertex(bvh, v, &mut a);
        setup.trace_vertex(kd, v, &mut b);
        let dirs: Vec<_> = setup.world_directions(v).collect();
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            rays += 1;
            if (x.tri, x.t.to_bits(), x.u.to_bits(), x.v.to_bits())
                == (y.tri, y.t.to_bits(), y.u.to_bits(), y.v.to_bits())
            {
                continue;
            }
            differ += 1;
            vertex_same[v] = false;
            let ray = Ray { origin: setup.origins[v], dir: dirs[i], tmin: 0.0, tmax: f32::INFINITY, skip: v as u32 };
            let want = brute_force(kd, &ray);
            let bvh_tri = (x.tri != HIT_MISS).then_some(x.tri & !HIT_BACK);
            assert_eq!(bvh_tri, want.map(|h| h.tri), "{name}: vertex {v} ray {i}: the BVH disagrees with brute force");
            kd_wrong += 1;
        }
    }
    eprintln!("{name}: {differ} of {rays} rays differ between BVH and kd ({kd_wrong} where the kd walk is wrong)");
    assert!(differ as f64 <= 1e-5 * rays as f64 + 1.0, "{name}: {differ} of {rays} rays differ");

    // Link groups.
    let (l1, l2) = (&bvh_solver.links(), &kd_solver.links());
    let mut compared = 0;
    for v in 0..scene.vertex_count() {
        if vertex_same[v] {
            assert_eq!(l1.group(v), l2.group(v), "{name}: link group of vertex {v}");
            compared += 1;
        }
    }
    assert!(compared + 2 >= scene.vertex_count(), "{name}: {compared} groups compared");
    if differ == 0 {
        assert_eq!(l1.packed, l2.packed);
        assert_eq!(l1.weights, l2.weights);
    }

    // Shadow rays: the light links' factors agree.
    let c1 = LightLinks::compute(&scene, bvh, &params.light);
    let c2 = LightLinks::compute(&scene, kd, &params.light);
    assert_eq!(c1.shadow_rays, c2.shadow_rays);
    let mut col_differ = 0;
    for (f1, f2) in c1.factors.iter().zip(&c2.factors) {
        col_differ += f1.iter().zip(f2).filter(|(x, y)| x != y).count();
    }
    assert!(col_differ <= 2, "{name}: {col_differ} light-link factors differ");
}

#[test]
fn cornell_and_furnace() {
    agree_on("cornell");
    agree_on("furnace");
}

#[test]
fn colorlamp_and_torso() {
    agree_on("colorlamp");
    agree_on("torso");
}

#[test]
fn tearoom() {
    agree_on("tearoom");
}

/// A BVH built by itself over a scene equals the one a solver builds, and
/// validates (determinism of the build).
#[test]
fn bvh_build_is_deterministic() {
    let scene = prep::prepare(&builtin::builtin("torso").unwrap()).unwrap();
    let a = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
    let b = Bvh::build(&scene.positions, &scene.triangles, &BvhBuildParams::default());
    a.validate().unwrap();
    b.validate().unwrap();
    assert_eq!(a.nodes, b.nodes);
    // Blocks hold NaN in unused lanes (never equal as floats): compare ids and bits.
    assert!(a.blocks.iter().zip(&b.blocks).all(|(x, y)| x.tri == y.tri
        && x.corners == y.corners
        && bytemuck::bytes_of(&x.v) == bytemuck::bytes_of(&y.v)));
}
