//! The asynchronous engine: only what a change invalidates is redone, the
//! caller never waits for a solve, and failures keep the last good result.

use glam::Vec3;
use linkgi::engine::{Change, Engine, EngineParams};
use linkgi::scene::deform::deform_scene;
use linkgi::scene::{builtin, prep, Bounces, Light};
use linkgi::solver::{Compute, SolveParams};
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(120);

fn start(name: &str, rays: u32, delay_ms: u64) -> (Engine, prep::PreparedScene) {
    let mut desc = builtin::builtin(name).unwrap();
    desc.settings.rays_per_vertex = rays;
    let scene = prep::prepare(&desc).unwrap();
    let params = SolveParams::from_settings(&scene.settings);
    let opts = EngineParams { delay: Duration::from_millis(delay_ms), ..Default::default() };
    (Engine::start(scene.clone(), params, Compute::Cpu, opts).expect("the worker starts"), scene)
}

fn first_point(scene: &prep::PreparedScene) -> (Vec3, Vec3) {
    match scene.lights[0] {
        Light::Point { position, intensity } => (position, intensity),
        _ => panic!("first light is not a point light"),
    }
}

#[test]
fn moving_a_light_redoes_light_links_and_gather_only() {
    let (mut e, scene) = start("cornell", 16, 0);
    assert!(e.wait_idle(WAIT));
    let c0 = e.counters();
    assert_eq!((c0.kd_builds, c0.link_builds, c0.light_link_updates, c0.gathers, c0.published), (1, 1, 1, 1, 1));
    let v0 = e.latest().unwrap();
    let (p, i) = first_point(&scene);
    for k in 1..=3 {
        e.send(Change::MoveLight {
            index: 0,
            light: Light::Point { position: p - Vec3::X * 0.1 * k as f32, intensity: i },
        });
        assert!(e.wait_idle(WAIT));
    }
    let c = e.counters();
    assert_eq!(c.kd_builds, 1, "a light move rebuilt the kd-tree");
    assert_eq!(c.link_builds, 1, "a light move rebuilt the links");
    assert_eq!(c.light_link_updates, 4);
    assert_eq!(c.gathers, 4);
    let v = e.latest().unwrap();
    assert_eq!(v.version, 4);
    assert!(v.e_direct != v0.e_direct, "the direct light did not change");
    // A settings change of bounces only is a gather.
    let mut s = scene.settings;
    s.bounces = Bounces::Fixed(1);
    e.send(Change::Settings(s));
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!((c.kd_builds, c.light_link_updates, c.gathers), (1, 4, 5));
    let one = e.latest().unwrap();
    let sum = |v: &[Vec3]| v.iter().map(|x| x.element_sum()).sum::<f32>();
    assert!(sum(&one.e_indirect) < sum(&v.e_indirect), "one bounce is not less than three");
}

#[test]
fn static_scene_never_rebuilds_the_kd_tree() {
    let (mut e, scene) = start("cornell", 16, 0);
    let (p, i) = first_point(&scene);
    e.send(Change::AddLight(Light::Directional {
        direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
        irradiance: Vec3::ONE,
    }));
    e.send(Change::MoveLight { index: 0, light: Light::Point { position: p + Vec3::Z * 0.2, intensity: i } });
    e.send(Change::RemoveLight(1));
    // Moving a static mesh's vertices is refused, not a rebuild.
    let moved: Vec<Vec3> = scene.positions.iter().map(|&q| q + Vec3::Y * 0.01).collect();
    assert!(e.wait_idle(WAIT));
    e.send(Change::Deform { positions: moved });
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!(c.kd_builds, 1);
    assert_eq!(c.link_builds, 1);
    assert!(e.last_error().unwrap().contains("static mesh"), "{:?}", e.last_error());
    assert_eq!(e.latest().unwrap().lights.len(), 1);
}

#[test]
fn deforming_rebuilds_kd_tree_and_links() {
    let (mut e, scene) = start("torso", 4, 100);
    let (pos, _) = deform_scene(&scene, &scene.positions, &scene.normals, 1.0);
    // Sent while the first solve runs: the two deformations coalesce into one rebuild.
    e.send(Change::Deform { positions: pos.clone() });
    e.send(Change::Deform { positions: pos });
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!((c.kd_builds + c.refits, c.link_builds, c.published, c.batches), (2, 2, 2, 2), "{c:?}");
    assert!(c.rebuild_ms > 0.0);
    // A light move afterwards is no rebuild.
    let (p, i) = first_point(&scene);
    e.send(Change::MoveLight { index: 0, light: Light::Point { position: p + Vec3::X * 0.1, intensity: i } });
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!((c.kd_builds + c.refits, c.link_builds, c.light_link_updates), (2, 2, 3), "{c:?}");
}

#[test]
fn the_caller_keeps_running_during_a_slow_solve() {
    let (mut e, scene) = start("cornell", 16, 300);
    // The first solve is slow (300 ms extra); the loop keeps counting frames.
    let mut frames = 0u64;
    let mut frames_without_gi = 0u64;
    while e.latest().is_none() {
        frames += 1;
        frames_without_gi += 1;
        std::thread::sleep(Duration::from_millis(2));
        assert!(frames < 1_000_000);
    }
    assert!(frames_without_gi > 5, "the loop ran only {frames_without_gi} frames while the first solve ran");
    let (p, i) = first_point(&scene);
    e.send(Change::MoveLight { index: 0, light: Light::Point { position: p + Vec3::X * 0.2, intensity: i } });
    let mut frames_during_update = 0u64;
    while e.latest().unwrap().version < 2 {
        frames_during_update += 1;
        // The render loop keeps using version 1 meanwhile.
        assert_eq!(e.latest().unwrap().version, 1);
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(frames_during_update > 5, "only {frames_during_update} frames during the update");
}

#[test]
fn failures_keep_the_last_good_result() {
    let (mut e, scene) = start("cornell", 16, 0);
    assert!(e.wait_idle(WAIT));
    let good = e.latest().unwrap();
    e.send(Change::MoveLight { index: 7, light: scene.lights[0] });
    assert!(e.wait_idle(WAIT));
    assert!(e.last_error().unwrap().contains("move light 7"));
    e.send(Change::Panic);
    assert!(e.wait_idle(WAIT));
    assert!(e.last_error().unwrap().contains("panicked"));
    assert_eq!(e.counters().errors, 2);
    assert_eq!(e.latest().unwrap().version, good.version, "a failed update published a result");
    // The worker still works after a panic (it rebuilds from the last good scene).
    let (p, i) = first_point(&scene);
    e.send(Change::MoveLight { index: 0, light: Light::Point { position: p + Vec3::X * 0.1, intensity: i } });
    assert!(e.wait_idle(WAIT));
    assert_eq!(e.latest().unwrap().version, good.version + 1);
}

/// With `light_preview`, a light move publishes a preview and then the full
/// result, which is bit for bit the result of an engine without previews;
/// moves sent back to back end in one full result that counts them all.
#[test]
fn light_preview_is_followed_by_the_full_result() {
    let mut desc = builtin::builtin("cornell").unwrap();
    desc.settings.rays_per_vertex = 16;
    let scene = prep::prepare(&desc).unwrap();
    // Previews skip the one-ring oversampling, so they exist only with it.
    let mut params = SolveParams::from_settings(&scene.settings);
    params.light.oversample = true;
    let start = |preview: bool| {
        let opts = EngineParams { light_preview: preview, ..Default::default() };
        Engine::start(scene.clone(), params, Compute::Cpu, opts).expect("the worker starts")
    };
    let (mut plain, mut quick) = (start(false), start(true));
    let (p, i) = first_point(&scene);
    let moved =
        |k: f32| Change::MoveLight { index: 0, light: Light::Point { position: p - Vec3::X * 0.1 * k, intensity: i } };
    for e in [&mut plain, &mut quick] {
        assert!(e.wait_idle(WAIT));
        e.send(moved(1.0));
        assert!(e.wait_idle(WAIT));
    }
    let c = quick.counters();
    assert_eq!((c.published, c.previews, c.light_link_updates, c.changes), (3, 1, 3, 1));
    assert_eq!(plain.counters().previews, 0);
    let (a, b) = (plain.latest().unwrap(), quick.latest().unwrap());
    assert!(!b.preview);
    assert_eq!(a.e_direct, b.e_direct);
    assert_eq!(a.e_indirect, b.e_indirect);

    for k in 2..=4 {
        quick.send(moved(k as f32));
    }
    assert!(quick.wait_idle(WAIT));
    let c = quick.counters();
    let last = quick.latest().unwrap();
    assert!(!last.preview && c.changes == 4 && c.previews >= 2, "{c:?}");
    plain.send(moved(4.0));
    assert!(plain.wait_idle(WAIT));
    assert_eq!(plain.latest().unwrap().e_direct, last.e_direct);
}

/// Without one-ring oversampling (the default) a light move's preview
/// would be the full result: the engine publishes the full result alone,
/// tracing the moved light once.
#[test]
fn light_preview_without_oversampling_is_the_full_result() {
    let mut desc = builtin::builtin("cornell").unwrap();
    desc.settings.rays_per_vertex = 16;
    let scene = prep::prepare(&desc).unwrap();
    let params = SolveParams::from_settings(&scene.settings);
    assert!(!params.light.oversample);
    let opts = EngineParams { light_preview: true, ..Default::default() };
    let mut e = Engine::start(scene.clone(), params, Compute::Cpu, opts).expect("the worker starts");
    assert!(e.wait_idle(WAIT));
    let (p, i) = first_point(&scene);
    e.send(Change::MoveLight { index: 0, light: Light::Point { position: p - Vec3::X * 0.1, intensity: i } });
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!((c.published, c.previews, c.changes), (2, 0, 1), "{c:?}");
    assert!(!e.latest().unwrap().preview);
}

/// A preview whose refinement was put off for a queued batch that then
/// fails (a bad light index) or panics is still replaced by a full result,
/// and every change counts as handled, so `wait_idle` returns.
#[test]
fn a_failed_batch_after_a_preview_still_ends_in_a_full_result() {
    let mut desc = builtin::builtin("cornell").unwrap();
    desc.settings.rays_per_vertex = 16;
    let scene = prep::prepare(&desc).unwrap();
    let mut params = SolveParams::from_settings(&scene.settings);
    params.light.oversample = true;
    let (p, i) = first_point(&scene);
    for bad in [Change::RemoveLight(99), Change::Panic] {
        let opts = EngineParams { delay: Duration::from_millis(400), light_preview: true, ..Default::default() };
        let mut e = Engine::start(scene.clone(), params, Compute::Cpu, opts).expect("the worker starts");
        assert!(e.wait_idle(WAIT));
        let moved = |k: f32| Change::MoveLight {
            index: 0,
            light: Light::Point { position: p - Vec3::X * 0.1 * k, intensity: i },
        };
        e.send(moved(1.0));
        // Queued while the first move is handled: its preview is not refined.
        std::thread::sleep(Duration::from_millis(100));
        e.send_batch(vec![moved(2.0), bad.clone()]);
        assert!(e.wait_idle(WAIT), "{:?}", e.counters());
        let deadline = std::time::Instant::now() + WAIT;
        while e.latest().unwrap().preview && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let (c, r) = (e.counters(), e.latest().unwrap());
        assert!(!r.preview, "a preview was left standing: {c:?}");
        assert_eq!((c.changes, c.errors), (3, 1), "{c:?}");
        assert!(e.last_error().is_some());
    }
}

/// A deformation with `deform_preview` publishes a preview, then a full
/// result equal to a fresh solve of the deformed scene; the counters carry
/// the selective update's figures and `wait_idle` waits for the full one.
#[test]
fn deformation_preview_then_selective_full_result() {
    use linkgi::solver::Solver;
    let mut desc = builtin::builtin("torso").unwrap();
    desc.settings.rays_per_vertex = 16;
    let rest = prep::prepare(&desc).unwrap();
    let params = SolveParams::from_settings(&rest.settings);
    let opts = EngineParams { deform_preview: true, ..Default::default() };
    let mut e = Engine::start(rest.clone(), params, Compute::Cpu, opts).expect("the worker starts");
    assert!(e.wait_idle(WAIT));
    let c0 = e.counters();
    assert!(c0.deform.is_none());
    for (k, t) in [0.4f32, 1.1].into_iter().enumerate() {
        let (positions, normals) = deform_scene(&rest, &rest.positions, &rest.normals, t);
        e.send(Change::Deform { positions: positions.clone() });
        assert!(e.wait_idle(WAIT));
        let c = e.counters();
        assert_eq!(c.previews, k as u64 + 1, "one preview per deformation");
        assert_eq!(c.published, c0.published + 2 * (k as u64 + 1));
        let d = c.deform.expect("deformation figures");
        assert!(d.selective && d.links.rays_reshot > 0 && d.links.groups_patched > 0, "{d:?}");
        assert!(d.ray_state_bytes > 0 && d.light_links_recomputed > 0);
        assert!(c.preview_ms > 0.0 && c.preview_ms <= c.update_ms + 1e-9, "{} vs {}", c.preview_ms, c.update_ms);
        let latest = e.latest().unwrap();
        assert!(!latest.preview, "wait_idle returned on a preview");
        let fresh =
            Solver::new(prep::PreparedScene { positions, normals, ..rest.clone() }, params, &|_, _| {}).unwrap();
        let sol = fresh.solve();
        for (a, b) in latest.e_indirect.iter().zip(&sol.e_indirect) {
            assert!((*a - *b).abs().max_element() <= 1e-5 * b.max_element().max(1e-12), "{a} vs {b}");
        }
    }
}

/// A sky set on a scene built without one: its rays beside the links'
/// (refined cells, the near hits' sky samples) were never traced, so the
/// engine traces them once and the result equals a fresh solve with the
/// sky; a second sky (brighter) is gather-only again.
#[test]
fn a_sky_on_a_scene_without_one_traces_its_rays_once() {
    use linkgi::solver::Solver;
    let mut desc = builtin::builtin("window").unwrap();
    desc.settings.rays_per_vertex = 16;
    // Without its portal, so only the sky's appearing asks for rays.
    let mut sky0 = desc.sky.take().expect("window has a sky");
    sky0.portals.clear();
    let scene = prep::prepare(&desc).unwrap();
    // Every near term kept (`pay_share` 0): a solver decides its terms when
    // it is built, by the light it has then (no sky here), and a fresh
    // solve of the edited scene decides by its own.
    let params = SolveParams { pay_share: 0.0, ..SolveParams::from_settings(&scene.settings) };
    let mut e = Engine::start(scene.clone(), params, Compute::Cpu, EngineParams::default()).expect("the worker starts");
    assert!(e.wait_idle(WAIT));
    let c0 = e.counters();
    let fresh = |scene: &prep::PreparedScene| {
        let s = Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
        s.validate().expect("every structure valid");
        assert!(s.near().sky.traced && s.near().sky.cost.rays > 0);
        s.solve()
    };
    let mut edited = scene.clone();
    for intensity in [1.0, 2.0] {
        let mut sky = sky0.clone();
        sky.intensity = intensity;
        e.send(Change::SetSky(Some(sky.clone())));
        edited.sky = Some(sky);
        assert!(e.wait_idle(WAIT));
        let got = e.latest().unwrap();
        let want = fresh(&edited);
        assert!(got.e_sky.iter().any(|k| k.min_element() > 0.0), "the window lets the sky in");
        assert_eq!((got.e_sky.clone(), got.e_indirect.clone()), (want.e_sky, want.e_indirect));
        assert_eq!(e.counters().portal_updates, c0.portal_updates + 1, "traced once, at the first sky");
    }
}

/// Emission edits and sky changes (set, turned, brighter, removed) are
/// gather-only updates: no structure, link or light-link work, and each
/// result equals a fresh solve of the edited scene. A mesh that starts
/// emitting (the lamp's metal with its shade) needs its emitter links
/// traced, once; brightening it again is gather-only. Taking the sky's
/// portal away traces the sky's rays once (the link rays then cover the
/// window's directions too).
#[test]
fn emission_and_sky_edits_are_gather_only() {
    use linkgi::solver::Solver;
    let (mut e, scene) = start("window", 16, 0);
    assert!(e.wait_idle(WAIT));
    let c0 = e.counters();
    let lamp = scene.meshes.iter().position(|m| m.name.contains("lamp")).unwrap();
    let fresh = |scene: &prep::PreparedScene| {
        Solver::new(scene.clone(), SolveParams::from_settings(&scene.settings), &|_, _| {}).unwrap().solve()
    };
    let mut edited = scene.clone();
    // The whole lamp glows blue.
    e.send(Change::SetEmission { mesh: lamp, emission: Vec3::new(0.0, 5.0, 40.0) });
    let r = edited.meshes[lamp].vertices.start as usize..edited.meshes[lamp].vertices.end as usize;
    edited.emission[r].fill(Vec3::new(0.0, 5.0, 40.0));
    assert!(e.wait_idle(WAIT));
    let got = e.latest().unwrap();
    let want = fresh(&edited);
    assert_eq!(got.e_indirect, want.e_indirect);
    assert_eq!(got.emission, edited.emission);
    assert_eq!(e.counters().emitter_link_updates, c0.emitter_link_updates + 1, "the metal started emitting");
    e.send(Change::SetEmission { mesh: lamp, emission: Vec3::new(0.0, 10.0, 80.0) });
    let r = edited.meshes[lamp].vertices.start as usize..edited.meshes[lamp].vertices.end as usize;
    edited.emission[r].fill(Vec3::new(0.0, 10.0, 80.0));
    assert!(e.wait_idle(WAIT));
    let got = e.latest().unwrap();
    let want = fresh(&edited);
    assert_eq!(got.e_indirect, want.e_indirect, "twice as bright, same emitter links");
    // The sky turned and brighter, then gone.
    let mut sky = edited.sky.clone().unwrap();
    sky.rotate_deg = 45.0;
    sky.intensity = 3.0;
    e.send(Change::SetSky(Some(sky.clone())));
    edited.sky = Some(sky);
    assert!(e.wait_idle(WAIT));
    let got = e.latest().unwrap();
    let want = fresh(&edited);
    assert_eq!((got.e_sky.clone(), got.e_indirect.clone()), (want.e_sky, want.e_indirect));
    assert_eq!(e.counters().portal_updates, c0.portal_updates, "the same portal: no rays");
    // The window's portal taken away: the link rays find the sky alone again (rays, once).
    let mut open = edited.sky.clone().unwrap();
    assert_eq!(open.portals.len(), 1);
    open.portals.clear();
    e.send(Change::SetSky(Some(open.clone())));
    edited.sky = Some(open);
    assert!(e.wait_idle(WAIT));
    let got = e.latest().unwrap();
    let want = fresh(&edited);
    assert_eq!((got.e_sky.clone(), got.e_indirect.clone()), (want.e_sky, want.e_indirect));
    assert_eq!(e.counters().portal_updates, c0.portal_updates + 1);
    e.send(Change::SetSky(None));
    assert!(e.wait_idle(WAIT));
    let dark = e.latest().unwrap();
    assert!(dark.e_sky.iter().all(|k| *k == Vec3::ZERO));
    let c = e.counters();
    assert_eq!(
        (c.kd_builds, c.link_builds, c.light_link_updates, c.emitter_link_updates, c.gathers),
        (c0.kd_builds, c0.link_builds, c0.light_link_updates, c0.emitter_link_updates + 1, c0.gathers + 5)
    );
    assert_eq!(c.portal_updates, c0.portal_updates + 1);
    // Bad edits fail and keep the last result.
    e.send(Change::SetEmission { mesh: 99, emission: Vec3::ONE });
    e.send(Change::SetEmission { mesh: 0, emission: Vec3::NAN });
    assert!(e.wait_idle(WAIT));
    assert!(e.counters().errors >= 1);
    assert_eq!(e.latest().unwrap().version, dark.version);
}

/// The viewer's refinement hands each new mesh's solver to the engine
/// (`Change::Adopt`): the result has the refined mesh's vertices, keeps a
/// light moved meanwhile (its light links redone, nothing rebuilt), and
/// equals, bit for bit, a fresh solver of the refined mesh with the moved
/// light.
#[test]
fn an_adopted_refined_solver_keeps_the_edits_and_equals_a_fresh_one() {
    use linkgi::engine::Adopted;
    use linkgi::scene::refine::apriori;
    use linkgi::scene::shapes::MeshBuilder;
    use linkgi::solver::{adaptive, Solver};
    let mut b = MeshBuilder::new();
    let white = b.add_material("white", Vec3::splat(0.7));
    let red = b.add_material("red", Vec3::new(0.7, 0.1, 0.1));
    b.cuboid_open(
        Vec3::splat(-1.0),
        Vec3::splat(1.0),
        [1; 3],
        [Some(red), Some(white), Some(white), Some(white), Some(white), Some(white)],
        true,
    );
    let room = b.finish("room", 30.0);
    let mut desc = builtin::builtin("cornell").unwrap();
    desc.meshes = vec![room];
    desc.sky = None;
    desc.settings.rays_per_vertex = 16;
    let light = |x: f32| Light::Point { position: Vec3::new(x, 0.8, 0.3), intensity: Vec3::splat(2.0) };
    desc.lights = vec![light(-0.6)];
    let plan = adaptive::Plan::of(&desc);
    assert!(plan.refining, "the box is coarse");
    let coarse = prep::prepare(&apriori(&desc, &desc.settings.refine).0).unwrap();
    let params = SolveParams::from_settings(&coarse.settings);
    let mut e = Engine::start(coarse.clone(), params, Compute::Cpu, EngineParams::default()).unwrap();
    assert!(e.wait_idle(WAIT));
    e.send(Change::MoveLight { index: 0, light: light(0.6) });
    assert!(e.wait_idle(WAIT));
    let before = e.counters();
    // Refined for the light where it was, adopted after the move.
    let refined = adaptive::solve(&desc, &Compute::Cpu, &|_, _| {}).unwrap();
    let n = refined.solver.scene().vertex_count();
    assert!(n > coarse.vertex_count(), "refinement added vertices");
    let mut oracle_scene = refined.solver.scene().clone();
    let adopted = Adopted::new(refined.solver);
    e.send(Change::Adopt(adopted.clone()));
    assert!(e.wait_idle(WAIT));
    let c = e.counters();
    assert_eq!((c.kd_builds, c.link_builds), (before.kd_builds, before.link_builds), "nothing rebuilt");
    assert_eq!(c.light_link_updates, before.light_link_updates + 1, "the moved light's links redone");
    let got = e.latest().unwrap();
    assert_eq!(got.e_indirect.len(), n);
    assert_eq!(got.lights, vec![light(0.6)]);
    oracle_scene.lights = vec![light(0.6)];
    let want = Solver::new(oracle_scene, params, &|_, _| {}).unwrap().solve();
    assert!(got.e_direct == want.e_direct, "direct light differs from a fresh solver's");
    assert!(got.e_indirect == want.e_indirect, "indirect light differs from a fresh solver's");
    // A solver is adopted once.
    e.send(Change::Adopt(adopted));
    assert!(e.wait_idle(WAIT));
    assert!(e.last_error().is_some_and(|m| m.contains("adopted already")), "{:?}", e.last_error());
    assert_eq!(e.latest().unwrap().version, got.version, "the last good result stays");
}
