//! Selective updates after deformations (`Solver::deform`): the links,
//! light links, per-ray state, near hits' light columns and gather rays
//! and indirect irradiance equal a full solve of
//! the same deformed scene with the same seed, for sequences of deformer
//! times, a large motion through the room and a motion of a hair; scenes
//! without dynamic meshes keep no per-ray state; a preview shows the
//! remade vertices at few rays.

use glam::Vec3;
use linkgi::scene::deform::{deform_scene, moved_normals};
use linkgi::scene::prep::{self, PreparedScene};
use linkgi::scene::{builtin, Bounces};
use linkgi::solver::{DeformStats, SolveParams, Solver};

fn prepared(name: &str, rays: u32) -> PreparedScene {
    let mut desc = builtin::builtin(name).unwrap();
    desc.settings.rays_per_vertex = rays;
    desc.settings.bounces = Bounces::Fixed(3);
    prep::prepare(&desc).unwrap()
}

fn at_time(rest: &PreparedScene, t: f32) -> PreparedScene {
    let (positions, normals) = deform_scene(rest, &rest.positions, &rest.normals, t);
    PreparedScene { positions, normals, ..rest.clone() }
}

/// `scene` with the dynamic meshes' vertices moved by `f`.
fn moved_by(scene: &PreparedScene, f: impl Fn(Vec3) -> Vec3) -> PreparedScene {
    let mut positions = scene.positions.clone();
    for m in scene.meshes.iter().filter(|m| m.dynamic) {
        for p in &mut positions[m.vertices.start as usize..m.vertices.end as usize] {
            *p = f(*p);
        }
    }
    let normals = moved_normals(scene, &scene.positions, &positions, &scene.normals);
    PreparedScene { positions, normals, ..scene.clone() }
}

/// Asserts the selectively updated solver equals a fresh solve of its scene.
fn assert_equals_fresh(updated: &Solver, what: &str) {
    updated.accel().validate().expect("acceleration structure valid");
    updated.links().validate().expect("links valid");
    let fresh = Solver::new(updated.scene().clone(), *updated.params(), &|_, _| {}).unwrap();
    let (a, b) = (&updated.links(), &fresh.links());
    assert_eq!(a.offsets.len(), b.offsets.len());
    for v in 0..a.vertex_count() {
        let (ta, wa) = a.group(v);
        let (tb, wb) = b.group(v);
        assert_eq!(ta, tb, "{what}: vertex {v} links to other targets");
        for (x, y) in wa.iter().zip(wb) {
            let (x, y) = (x.to_f64(), y.to_f64());
            assert!((x - y).abs() <= 1e-6 * y.abs(), "{what}: vertex {v} weight {x} vs {y}");
        }
    }
    assert_eq!(a.stats.front_hits, b.stats.front_hits, "{what}: front hits");
    assert_eq!(a.stats.back_hits, b.stats.back_hits, "{what}: back hits");
    assert_eq!(a.stats.misses, b.stats.misses, "{what}: misses");
    assert_eq!(a.stats.merged_links, b.stats.merged_links, "{what}: merged links");
    assert_eq!(updated.ray_hits(), fresh.ray_hits(), "{what}: per-ray state");
    assert_eq!(a.sky, b.sky, "{what}: sky visibility (miss masks)");
    let (fa, fb) = (&updated.light_links().factors, &fresh.light_links().factors);
    let (pa, pb) = (&updated.light_links().point, &fresh.light_links().point);
    assert_eq!(fa.len(), fb.len());
    assert_eq!(pa.len(), fa.len());
    for (l, (ca, cb)) in fa.iter().zip(fb).chain(pa.iter().zip(pb)).enumerate() {
        for (v, (x, y)) in ca.iter().zip(cb).enumerate() {
            assert!((x - y).abs() <= 1e-6 * y.abs(), "{what}: light {l} vertex {v}: {x} vs {y}");
        }
    }
    assert_eq!(updated.links().near, fresh.links().near, "{what}: near hits");
    assert_eq!(updated.near().light.columns, fresh.near().light.columns, "{what}: near hits' light columns");
    assert_eq!(updated.near().gather.per_hit, fresh.near().gather.per_hit, "{what}: gather rays a near hit");
    assert_eq!(updated.near().gather.hits, fresh.near().gather.hits, "{what}: near hits' gather rays");
    // Every traced part (the sky's, the noise check's, each near term's)
    // against a fresh trace from the updated links.
    assert_eq!(updated.check_traced(), Ok(8), "{what}: the traced parts");
    let (ea, eb) = (&updated.emitter_links(), &fresh.emitter_links());
    ea.validate(updated.scene().vertex_count()).expect("emitter links valid");
    assert_eq!(ea.rows, eb.rows, "{what}: emitter links");
    let (sa, sb) = (updated.solve(), fresh.solve());
    assert_eq!(sa.e_direct, sb.e_direct, "{what}: exact direct light");
    assert_eq!(sa.e_sky, sb.e_sky, "{what}: sky light");
    for (v, (x, y)) in sa.e_indirect.iter().zip(&sb.e_indirect).enumerate() {
        assert!((*x - *y).abs().max_element() <= 1e-5 * y.max_element().max(1e-12), "{what}: E_i at {v}: {x} vs {y}");
    }
}

fn deform(solver: Solver, scene: PreparedScene) -> (Solver, DeformStats) {
    let params = *solver.params();
    solver.deform(scene, params, None, &|_, _| {})
}

#[test]
fn deformer_sequence_on_torso_equals_full_solves() {
    let rest = prepared("torso", 64);
    let mut solver = Solver::new(at_time(&rest, 0.3), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    assert!(solver.ray_state_bytes() > 0, "a scene with a dynamic mesh keeps per-ray state");
    let mut selective_rays = 0;
    for t in [0.45f32, 0.9, 1.7, 3.1] {
        let (next, stats) = deform(solver, at_time(&rest, t));
        assert!(stats.selective, "t = {t}: selective");
        assert!(stats.links.static_rays_reshot < stats.links.static_rays, "t = {t}: {stats:?}");
        selective_rays += stats.links.static_rays_reshot;
        assert_equals_fresh(&next, &format!("torso t = {t}"));
        solver = next;
    }
    assert!(selective_rays > 0, "the room's rays toward the figure were traced again");
}

#[test]
fn deformer_sequence_on_dancer_equals_full_solves() {
    let rest = prepared("dancer", 16);
    let mut solver = Solver::new(at_time(&rest, 0.5), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    for t in [0.8f32, 2.2] {
        let (next, stats) = deform(solver, at_time(&rest, t));
        assert!(stats.selective);
        assert!(stats.static_rays_fraction() < 0.5, "t = {t}: {stats:?}");
        assert!(stats.light_links_recomputed < (next.scene().vertex_count() * next.scene().lights.len()) as u64);
        assert_equals_fresh(&next, &format!("dancer t = {t}"));
        solver = next;
    }
}

#[test]
fn large_motion_through_the_room_equals_a_full_solve() {
    // The figure walks 2.6 m across the room and back, turned: rays whose
    // old hit was on the figure now meet the far wall, rays that passed
    // where the figure now stands meet it.
    let rest = prepared("torso", 16);
    let mut solver = Solver::new(rest.clone(), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    let there = moved_by(&rest, |p| Vec3::new(p.x + 1.3, p.y, p.z - 1.3));
    let (next, stats) = deform(solver, there);
    assert!(stats.selective && stats.links.static_rays_reshot > 0);
    assert_equals_fresh(&next, "moved 1.8 m");
    let q = glam::Quat::from_rotation_y(2.0);
    let back = moved_by(&next.scene(), |p| q * Vec3::new(p.x - 2.6, p.y, p.z + 2.2));
    let (next, _) = deform(next, back);
    assert_equals_fresh(&next, "moved back, turned");
    solver = next;
    drop(solver);
}

#[test]
fn motion_of_a_hair_equals_a_full_solve() {
    let rest = prepared("torso", 16);
    let solver = Solver::new(rest.clone(), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    let hair = moved_by(&rest, |p| p + Vec3::new(3e-6, -2e-6, 1e-6));
    let (next, stats) = deform(solver, hair);
    assert!(stats.selective);
    assert!(stats.static_rays_fraction() < 0.2, "{stats:?}");
    assert_equals_fresh(&next, "moved 4 um");
}

#[test]
fn scenes_without_dynamic_meshes_keep_no_ray_state() {
    let scene = prepared("cornell", 16);
    assert!(scene.meshes.iter().all(|m| !m.dynamic));
    let solver = Solver::new(scene, SolveParams::from_settings(&prepared("cornell", 16).settings), &|_, _| {}).unwrap();
    assert!(solver.ray_hits().is_none());
    assert_eq!(solver.ray_state_bytes(), 0);
    let sol = solver.solve();
    assert_eq!(solver.stats(&sol, 0.0).ray_state_bytes, 0);
}

#[test]
fn preview_shows_remade_vertices_at_few_rays() {
    let rest = prepared("torso", 64);
    let solver = Solver::new(rest.clone(), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    let before = solver.links().clone();
    let moved = at_time(&rest, 0.7);
    let figure = rest.meshes.iter().find(|m| m.dynamic).unwrap().vertices.clone();
    let mut seen = 0;
    let mut preview_direct = Vec::new();
    let mut show = |s: &Solver| {
        seen += 1;
        s.links().validate().expect("spliced preview links are valid");
        // Remade vertices have groups from 16 rays: weights are multiples
        // of pi/16 times barycentrics, so rows sum to at most pi with few links.
        let v = figure.start as usize + 10;
        assert!(s.links().group(v).0.len() <= 3 * 16, "preview group of {} links", s.links().group(v).0.len());
        // A static room vertex keeps its group.
        assert_eq!(s.links().group(0), before.group(0));
        // Preview columns are coarse only where oversampling is on (then the full update refines them).
        assert!(s.light_links().coarse.iter().all(|&c| c == s.params().light.oversample));
        let sol = s.solve();
        assert!(sol.e_indirect.iter().all(|e| e.is_finite()));
        preview_direct = sol.e_direct;
    };
    let params = *solver.params();
    let (next, stats) = solver.deform(moved, params, Some((16, &mut show)), &|_, _| {});
    assert_eq!(seen, 1);
    assert!(stats.preview_ms > 0.0 && stats.preview_ms <= stats.ms);
    assert!(next.light_links().coarse.iter().all(|&c| !c), "the full update replaces the preview columns");
    // The preview's exact direct light at the remade vertices is the full update's.
    let full_direct = next.solve().e_direct;
    for v in figure.start as usize..figure.end as usize {
        assert_eq!(preview_direct[v], full_direct[v], "E_d of remade vertex {v}");
    }
    assert_equals_fresh(&next, "after a preview");
}

/// `linkgi bench` rows carry the deformation figures (`deform_update_ms`,
/// `deform_full_ms`, `deform_static_rays_fraction`) for scenes with
/// deformers and NaN (JSON null) for the others.
#[test]
fn bench_rows_report_deformation_figures() {
    use linkgi::bench::{run_once, BenchRow};
    use linkgi::solver::Compute;
    for (name, deforms) in [("torso", true), ("cornell", false)] {
        let scene = prepared(name, 16);
        let params = SolveParams::from_settings(&scene.settings);
        let (times, sizes, _) = run_once(&scene, &params, &Compute::Cpu).unwrap();
        let row = BenchRow::from_runs(name, &sizes, 16, &[times]);
        let json = serde_json::to_value(&row).unwrap();
        for key in ["deform_update_ms", "deform_full_ms", "deform_preview_ms"] {
            let median = &json[key]["median"];
            if deforms {
                assert!(median.as_f64().is_some_and(|m| m > 0.0), "{name}: {key} = {median}");
            } else {
                assert!(median.is_null(), "{name}: {key} = {median}");
            }
        }
        let fraction = &json["deform_static_rays_fraction"];
        if deforms {
            assert!(fraction.as_f64().is_some_and(|f| (0.0..1.0).contains(&f)), "{fraction}");
            assert!(sizes.ray_state_bytes > 0);
        } else {
            assert!(fraction.is_null(), "{fraction}");
            assert_eq!(sizes.ray_state_bytes, 0);
        }
    }
}

/// The kd-tree tracer (rebuilt on every deformation) and a light that
/// moves in the same update (its column traced anew, the other kept and
/// patched) give a full solve's result too.
#[test]
fn kd_tracer_and_a_light_moved_with_the_deformation() {
    use linkgi::scene::{Light, TracerKind};
    let mut rest = prepared("torso", 16);
    rest.settings.tracer = TracerKind::Kd;
    let params = SolveParams::from_settings(&rest.settings);
    assert_eq!(params.tracer, TracerKind::Kd);
    let solver = Solver::new(rest.clone(), params, &|_, _| {}).unwrap();
    let mut moved = at_time(&rest, 0.6);
    if let Light::Point { position, .. } = &mut moved.lights[0] {
        *position += Vec3::new(-0.3, 0.0, 0.2);
    }
    let (next, stats) = solver.deform(moved, params, None, &|_, _| {});
    assert!(stats.selective && !stats.refitted);
    let n = next.scene().vertex_count() as u64;
    assert!(stats.light_links_recomputed >= n && stats.light_links_recomputed < 2 * n, "{stats:?}");
    assert_equals_fresh(&next, "kd tracer, light 0 moved");
}

/// An open scene: `torso`'s figure standing in `window` (sky through the
/// window, a glowing shade). Deforming it changes which rays leave through
/// the window; the selectively updated miss masks, sky light and links
/// equal a full solve's.
#[test]
fn deforming_in_an_open_scene_updates_the_sky_visibility() {
    let mut desc = builtin::builtin("window").unwrap();
    let torso = builtin::builtin("torso").unwrap();
    let figure = torso.meshes.into_iter().find(|m| m.dynamic).expect("torso's figure");
    desc.meshes.push(figure);
    desc.settings.rays_per_vertex = 64;
    desc.settings.bounces = Bounces::Fixed(3);
    let rest = prep::prepare(&desc).unwrap();
    let mut solver = Solver::new(rest.clone(), SolveParams::from_settings(&rest.settings), &|_, _| {}).unwrap();
    assert!(!solver.links().sky.is_empty());
    let before = solver.links().sky.clone();
    for t in [0.6, 1.7] {
        let (s, stats) = deform(solver, at_time(&rest, t));
        assert!(stats.links.groups_patched > 0);
        assert_equals_fresh(&s, &format!("window with a figure at t = {t}"));
        solver = s;
    }
    assert_ne!(solver.links().sky, before, "the figure's motion changed no miss mask");
}
