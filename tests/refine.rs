//! Refinement of coarse meshes (`scene::refine`, `solver::adaptive`): the
//! built-ins refine nothing; a coarse closed box refined a priori and by
//! error stays a furnace; on a coarse Cornell-like box the error-driven
//! rounds find the shadows and bring the picture to the image reference;
//! the budget holds; the settings load and save.

mod common;

use glam::Vec3;
use linkgi::bvh::Bvh;
use linkgi::reference::image::{render, score, ImageScore};
use linkgi::reference::ReferenceParams;
use linkgi::render::cpu::render_cpu;
use linkgi::render::{Frame, RenderParams};
use linkgi::scene::refine::{self, RefineMode, RefineSettings};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{builtin, Bounces, Camera, SceneDesc};
use linkgi::solver::adaptive::{self, Plan, Refined};
use linkgi::solver::Compute;

fn solve(desc: &SceneDesc) -> Refined {
    let r = adaptive::solve(desc, &Compute::Cpu, &|_, _| {}).expect("solves");
    r.solver.validate().expect("every structure valid");
    for e in r.solution.e_indirect.iter().chain(&r.solution.e_direct) {
        assert!(e.is_finite() && e.min_element() >= 0.0, "{e}");
    }
    r
}

/// Every built-in is fine enough: no mesh is coarse, nothing is refined,
/// so their answers (and golden hashes) are those of before.
#[test]
fn the_built_ins_refine_nothing() {
    for name in builtin::NAMES {
        let desc = builtin::builtin(name).unwrap();
        assert_eq!(desc.settings.refine.mode, RefineMode::Auto, "{name}: auto by default");
        let plan = Plan::of(&desc);
        assert!(!plan.refining && !plan.coarse.contains(&true), "{name}: {plan:?}");
        let (same, stats) = refine::apriori(&desc, &desc.settings.refine);
        for (a, b) in same.meshes.iter().zip(&desc.meshes) {
            assert_eq!((&a.positions, &a.triangles), (&b.positions, &b.triangles), "{name}");
        }
        assert!(stats.iter().all(|s| s.passes == 0), "{name}");
    }
}

/// A coarse closed polyhedron (an icosphere of 80 triangles, edges of
/// 0.6 m) glowing uniformly inside (albedo `rho`, exitance `M`): refined to
/// 8% of its diagonal and then by error, every vertex reads
/// `E = M / (1 - rho)`, exact for any closed enclosure, as the fine
/// furnace sphere does (`tests/emission.rs`), stiff albedo included. The
/// light is uniform, so the error-driven rounds split nothing.
/// (A glowing box of twelve triangles is no such test: its corner and
/// edge vertices meet the emitters' near-hit term at the creases, off by
/// up to 6x with or without refinement; see the closing note of issue 31.)
#[test]
fn a_coarse_glowing_box_refined_stays_a_furnace() {
    let m_e = Vec3::new(2.0, 1.0, 0.5);
    for rho in [0.5f32, 0.95] {
        let mut b = MeshBuilder::new();
        let m = b.add_material("grey", Vec3::splat(rho));
        b.icosphere(Vec3::ZERO, 1.0, 1, m, true);
        let mut mesh = b.finish("polyhedron", 30.0);
        mesh.materials[0].emission = m_e;
        let desc = common::scene_desc("glowing box", vec![mesh], vec![], None, 256, Bounces::Auto);
        let plan = Plan::of(&desc);
        assert!(plan.refining, "80 triangles with edges of 0.6 m are coarse");
        let r = solve(&desc);
        let expect = m_e / (1.0 - rho);
        let errs: Vec<f32> =
            r.solution.e_indirect.iter().map(|e| (*e / expect - Vec3::ONE).abs().max_element()).collect();
        let mean = (common::mean(&r.solution.e_indirect) / expect - Vec3::ONE).abs().max_element();
        let max = errs.iter().cloned().fold(0.0, f32::max);
        let v = r.solver.scene().vertex_count();
        eprintln!("rho {rho}: {v} vertices, rounds {}, mean err {mean:.4}, max {max:.4}", r.rounds.len());
        assert!(v > 200, "refined a priori: {v} vertices");
        assert_eq!(r.rounds.len(), 1, "uniform light: nothing to split by error");
        assert!(mean < 0.01 && max < 0.03, "rho {rho}: mean {mean}, max {max}");
    }
}

/// A Cornell-like box made as a CAD export would be: every wall one quad,
/// a ceiling light of one quad facing down, a block of twelve triangles.
fn coarse_cornell(settings: RefineSettings) -> (SceneDesc, Camera) {
    let mut r = MeshBuilder::new();
    let white = r.add_material("white", Vec3::splat(0.73));
    let red = r.add_material("red", Vec3::new(0.63, 0.065, 0.05));
    let green = r.add_material("green", Vec3::new(0.14, 0.45, 0.09));
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0));
    r.cuboid_open(lo, hi, [1; 3], [Some(red), Some(green), Some(white), Some(white), Some(white), None], true);
    let room = r.finish("room", 30.0);
    let mut l = MeshBuilder::new();
    let glow = l.add_material("light", Vec3::splat(0.5));
    // Facing down (u x v points to -y), 1 cm under the ceiling.
    l.quad_grid(Vec3::new(-0.25, 1.99, 0.25), Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.5, 0.0, 0.0), 1, 1, glow);
    let mut light = l.finish("light", 30.0);
    light.materials[0].emission = Vec3::new(50.0, 40.0, 30.0);
    let mut k = MeshBuilder::new();
    let w = k.add_material("white", Vec3::splat(0.73));
    k.cuboid_open(
        Vec3::new(-0.5, 0.0, -0.6),
        Vec3::new(0.1, 1.1, 0.0),
        [1; 3],
        [Some(w), Some(w), None, Some(w), Some(w), Some(w)],
        false,
    );
    let block = k.finish("block", 30.0);
    let mut desc = common::scene_desc("coarse cornell", vec![room, light, block], vec![], None, 256, Bounces::Auto);
    desc.settings.smoothing_angle_deg = 30.0;
    desc.settings.refine = settings;
    (desc, Camera { position: Vec3::new(0.0, 1.0, 3.4), target: Vec3::new(0.0, 1.0, 0.0), fov_deg: 40.0 })
}

/// The link solution's picture (CPU renderer) against the image reference.
fn picture_score(desc: &SceneDesc, camera: Camera) -> (ImageScore, Refined) {
    let r = solve(desc);
    (score_of(r.solver.scene(), &r.solution, desc, camera), r)
}

/// The picture of `solution` on `scene` (CPU renderer, 64x48) against the
/// image reference of `desc` as loaded (the same surfaces, traced exactly).
fn score_of(
    scene: &linkgi::scene::prep::PreparedScene,
    solution: &linkgi::solver::Solution,
    desc: &SceneDesc,
    camera: Camera,
) -> ImageScore {
    let (w, h) = (64, 48);
    let bvh = Bvh::build(&scene.positions, &scene.triangles, &Default::default());
    let p = RenderParams { width: w, height: h, ..Default::default() };
    let (ours, _) = render_cpu(&Frame::of(scene, &solution.e_indirect, camera), &p, Some(&bvh)).unwrap();
    let plain = linkgi::scene::prep::prepare(desc).unwrap();
    let pbvh = Bvh::build(&plain.positions, &plain.triangles, &Default::default());
    let reference = render(&plain, &pbvh, &camera, w, h, 256, &ReferenceParams::default(), &|| {});
    score(&ours, &reference).expect("lit")
}

/// A light move keeps the mesh. The coarse box lit by a point light in
/// one top corner, refined for it, then the light moved to the opposite
/// corner (`Solver::set_lights`: no new mesh): the picture keeps most of
/// what refinement gained over the unrefined box, and what it costs
/// against a mesh refined for the new place is measured and bounded
/// (direct light is drawn per pixel; what the old mesh misses is the
/// indirect light's new shadows and pools).
#[test]
fn a_light_move_keeps_the_mesh_and_the_cost_is_bounded() {
    let at = |p: Vec3, settings: RefineSettings| {
        let (mut desc, camera) = coarse_cornell(settings);
        desc.meshes.retain(|m| m.name != "light");
        desc.lights = vec![linkgi::scene::Light::Point { position: p, intensity: Vec3::splat(4.0) }];
        (desc, camera)
    };
    let (a, b) = (Vec3::new(-0.7, 1.8, 0.7), Vec3::new(0.7, 1.8, -0.7));
    let (desc_a, camera) = at(a, RefineSettings::default());
    let (desc_b, _) = at(b, RefineSettings::default());
    let mut ra = solve(&desc_a);
    ra.solver.set_lights(desc_b.lights.clone());
    let moved_solution = ra.solver.solve();
    let moved = score_of(ra.solver.scene(), &moved_solution, &desc_b, camera);
    let (fresh, rb) = picture_score(&desc_b, camera);
    let (unrefined, _) = picture_score(&at(b, RefineSettings::off()).0, camera);
    eprintln!(
        "light moved corner to corner: mesh refined for the old place ({} vertices) ratio {:.3}, block error {:.3}; \
         refined for the new place ({} vertices) {:.3}, {:.3}; unrefined {:.3}, {:.3}",
        ra.solver.scene().vertex_count(),
        moved.mean_ratio,
        moved.block_error,
        rb.solver.scene().vertex_count(),
        fresh.mean_ratio,
        fresh.block_error,
        unrefined.mean_ratio,
        unrefined.block_error
    );
    assert!(moved.block_error < unrefined.block_error, "{moved:?} against unrefined {unrefined:?}");
    assert!(moved.block_error < fresh.block_error + 0.02, "{moved:?} against {fresh:?}");
    assert!((moved.mean_ratio - 1.0).abs() < 0.05, "{moved:?}");
}

/// The coarse box as loaded reads the light at its few corners: shadows
/// missing, the picture far off the reference. Refined (defaults), the
/// error-driven rounds split where the light changes (round after round
/// more vertices, on the coarse meshes only) and the picture agrees.
#[test]
fn refinement_finds_the_shadows_of_a_coarse_box() {
    let (off, camera) = coarse_cornell(RefineSettings::off());
    let (before, r0) = picture_score(&off, camera);
    assert_eq!(r0.rounds.len(), 1);
    let (auto, _) = coarse_cornell(RefineSettings::default());
    let (after, r) = picture_score(&auto, camera);
    let verts: Vec<usize> = r.rounds.iter().map(|r| r.vertices).collect();
    eprintln!(
        "coarse box 64x48: unrefined ({} vertices) ratio {:.3}, block error {:.3}; refined (vertices per round {verts:?}) ratio {:.3}, block error {:.3}",
        r0.solver.scene().vertex_count(),
        before.mean_ratio,
        before.block_error,
        after.mean_ratio,
        after.block_error
    );
    assert!(r.rounds.len() >= 2, "the error-driven rounds split something");
    assert!(verts.windows(2).all(|w| w[1] > w[0]), "each round adds vertices: {verts:?}");
    assert!(before.block_error > 0.25, "the unrefined picture is far off: {before:?}");
    assert!(after.block_error < 0.5 * before.block_error, "{after:?} against {before:?}");
    assert!(after.block_error < 0.15 && (after.mean_ratio - 1.0).abs() < 0.05, "{after:?}");
    // Every input position is still there, where it was.
    for (m, o) in r.desc.meshes.iter().zip(&auto.meshes) {
        assert_eq!(&m.positions[..o.positions.len()], &o.positions[..], "{}", o.name);
    }
}

/// Solves `desc` through its refinement rounds, checking after every round
/// that each traced part equals a fresh trace of it on that round's mesh
/// and, after the first, that the part named `updated` was updated (kept
/// vertices kept their rows), not traced anew.
fn solve_checking_rounds(desc: &SceneDesc, updated: &[&str]) -> Refined {
    let plan = Plan::of(desc);
    let current = refine::apriori(desc, &desc.settings.refine).0;
    let prepared = linkgi::scene::prep::prepare(&current).unwrap();
    let mut rounds = 0;
    let mut on_round = |s: &linkgi::solver::Solver, _: &linkgi::solver::Solution| {
        let parts = s.check_traced().unwrap_or_else(|e| panic!("round {rounds}: {e}"));
        assert!(parts >= 3, "round {rounds}: the sources traced ({parts} parts)");
        for &updated in updated {
            let (_, cost) = *s.part_costs().iter().find(|(n, _)| *n == updated).expect("a part of that name");
            eprintln!("round {rounds}: {updated} {cost:?}");
            assert!(cost.rays > 0 || rounds > 0, "round {rounds}: {updated} traced");
            if rounds > 0 {
                assert!(cost.selective, "round {rounds}: the {updated} updated after the split");
                // Units redone: vertices, or (vertex, light) entries.
                let all = s.scene().vertex_count() as u64 * s.scene().lights.len().max(1) as u64;
                assert!(cost.redone > 0 && cost.redone < all, "round {rounds}: {} of {all} redone", cost.redone);
            }
        }
        rounds += 1;
    };
    let r = adaptive::solve_planned_with(current, prepared, &plan, &Compute::Cpu, &|_, _| {}, &mut on_round)
        .expect("solves");
    assert!(rounds >= 2, "two marking rounds checked ({rounds})");
    assert_eq!(r.solver.check_traced(), Ok(8), "the final solver's parts");
    r
}

/// The sky's refined cells (a coarse box open on one side under a sky)
/// and a point light's links are updated after each split like the
/// emitter links: kept vertices with the same one-ring (and misses) keep
/// their rows, and every round's parts equal a fresh trace.
#[test]
fn the_sky_rays_and_light_links_are_updated_after_each_split() {
    let (mut desc, _) = coarse_cornell(RefineSettings::default());
    desc.settings.rays_per_vertex = 16;
    desc.sky = Some(linkgi::sky::Sky::gradient(Vec3::new(4.0, 5.0, 7.0), Vec3::splat(4.0), Vec3::ZERO));
    desc.lights.push(linkgi::scene::Light::Point { position: Vec3::new(0.5, 1.6, -0.3), intensity: Vec3::splat(2.0) });
    let r = solve_checking_rounds(&desc, &["sky rays", "light links"]);
    assert!(r.solver.light_links().shadow_rays > 0, "the light's links traced");
    assert!(r.solver.sky_rays().refine.rays > 0, "the sky's cells refined");
}

/// The error-driven rounds carry the hits of kept vertices over to the
/// split mesh (`links::reassign`): new vertices trace, the rest is
/// re-assigned. The result is a fresh shoot of the refined scene: the same
/// links (targets, f16 weights, near hits, sky visibility), bit for bit,
/// and the same solution. The refined scene is the mesh a fresh
/// preparation of the refined file gives (same positions and triangles;
/// kept vertices' normals within rounding, their colours carried). At 16
/// rays a vertex the rounds mark with the full rays
/// (`SolveParams::marking` keeps at least 16), so the final solver is the
/// rounds' own, its links carried and its other parts retraced.
#[test]
fn carried_hits_equal_a_fresh_solve_of_the_refined_mesh() {
    let (desc, _) = coarse_cornell(RefineSettings::default());
    carried_equals_fresh(desc);
}

/// The same with the room's corners shared between its walls, as in most
/// OBJ files: each corner position is several solver vertices (a crease
/// splits it by normal, a material border by albedo), and each old one is
/// matched to the new one of its position with the nearest normal, so the
/// rounds still carry most of the rays.
#[test]
fn carried_hits_at_shared_crease_corners_equal_a_fresh_solve() {
    let (mut desc, _) = coarse_cornell(RefineSettings::default());
    let room = &mut desc.meshes[0];
    let mut first: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
    let remap: Vec<u32> = room
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| *first.entry(p.to_array().map(f32::to_bits)).or_insert(i as u32))
        .collect();
    for t in &mut room.triangles {
        *t = t.map(|c| remap[c as usize]);
    }
    let prepared = linkgi::scene::prep::prepare(&desc).unwrap();
    let m = &prepared.meshes[0];
    let mut per_input = std::collections::HashMap::new();
    for &i in &m.vertex_input {
        *per_input.entry(i).or_insert(0) += 1;
    }
    assert!(per_input.values().any(|&k| k >= 3), "a corner is three solver vertices");
    carried_equals_fresh(desc);
}

/// Solves `desc` at 16 rays a vertex through its refinement rounds (every
/// decided term forced on) and checks the result against a fresh solve
/// of the final mesh; each round after the first traces at most 1.6x the
/// rays of its new vertices (the rest are the kept vertices whose one-ring
/// a split touched: 1.14-1.41x on this box; matching a crease corner's old
/// vertices by input position alone traced 2.1x and 2.6x in the last two).
fn carried_equals_fresh(mut desc: SceneDesc) {
    desc.settings.rays_per_vertex = 16;
    // Every decided term forced on, so every part is traced and compared
    // (on this box the emitters' near field moves the light by under 2%).
    desc.settings.forced = linkgi::scene::terms::Terms::with_on(linkgi::scene::terms::Terms::DECIDED).unwrap();
    let r = solve_checking_rounds(&desc, &["emitter links"]);
    assert!(r.rounds.len() >= 2, "the error-driven rounds split something");
    let marking = linkgi::solver::SolveParams::from_settings(&desc.settings).marking().links.rays_per_vertex;
    assert_eq!(marking, 16, "the rounds mark at the full rays");
    assert_eq!(r.rounds.last().unwrap().final_rays, 0, "the final solver is the rounds' own");
    for (i, round) in r.rounds.iter().enumerate() {
        let total = round.vertices as u64 * marking as u64;
        eprintln!(
            "round {i}: {} vertices, {} rays traced, {} carried, links {:.1} ms",
            round.vertices, round.rays_traced, round.rays_carried, round.links_ms
        );
        assert_eq!(round.rays_traced + round.rays_carried, total, "round {i}");
        if i > 0 {
            let new = (round.vertices - r.rounds[i - 1].vertices) as u64 * marking as u64;
            assert!(
                round.rays_traced as f64 <= 1.6 * new as f64,
                "round {i}: {} rays traced for {new} new",
                round.rays_traced
            );
        }
    }
    let scene = r.solver.scene().clone();
    // The scene's own settings, as the rounds started from (the solver's
    // parameters hold the terms it decided off).
    let params = linkgi::solver::SolveParams::from_settings(&scene.settings);
    let fresh = linkgi::solver::Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
    assert_eq!(fresh.params(), r.solver.params(), "the same parameters");
    let (a, b) = (r.solver.links(), fresh.links());
    let differing: Vec<usize> = (0..scene.vertex_count()).filter(|&v| a.group(v) != b.group(v)).collect();
    for &v in differing.iter().take(5) {
        eprintln!(
            "vertex {v} at {} boundary {}: {:?}\n vs {:?}",
            scene.positions[v],
            scene.boundary[v],
            a.group(v),
            b.group(v)
        );
    }
    assert!(differing.is_empty(), "{} link groups differ from a fresh shoot", differing.len());
    assert_eq!(a.near, b.near, "near hits");
    assert_eq!(a.sky, b.sky, "sky visibility");
    // Every traced part equals a fresh build's (the rounds before traced
    // the sources only, at marking quality; the last traced the rest).
    let (ea, eb) = (r.solver.emitter_links(), fresh.emitter_links());
    assert_eq!(
        (&ea.rows, &ea.group_vertex, ea.shadow_rays),
        (&eb.rows, &eb.group_vertex, eb.shadow_rays),
        "emitter links"
    );
    assert!(ea.shadow_rays > 0, "the box's lamp has emitter links");
    let (na, nb) = (r.solver.near(), fresh.near());
    assert_eq!(na.emitters.rows, nb.emitters.rows, "near emitters");
    assert!(!na.emitters.rows.items.is_empty(), "near emitters traced");
    assert_eq!((&na.gather.hits, na.gather.per_hit), (&nb.gather.hits, nb.gather.per_hit), "near gather");
    assert_eq!(na.light.columns, nb.light.columns, "near light");
    assert_eq!(r.solver.noise_check().rays, fresh.noise_check().rays, "noise check");
    assert_eq!(r.solver.term_decisions(), fresh.term_decisions(), "the same terms decided");
    assert!(r.solver.term_decisions().iter().all(|d| d.on && d.forced), "forced terms stay on");
    let (sa, sb) = (&r.solution, fresh.solve());
    assert_eq!(sa.e_indirect, sb.e_indirect, "the solutions");
    // The same mesh as a fresh preparation of the refined scene.
    let mut plain = linkgi::scene::prep::prepare(&r.desc).unwrap();
    plain.sky = scene.sky.clone();
    assert_eq!((&plain.positions, &plain.triangles), (&scene.positions, &scene.triangles));
    let moved = plain.normals.iter().zip(&scene.normals).map(|(a, b)| (*a - *b).length()).fold(0f32, f32::max);
    assert!(moved < linkgi::links::reassign::KEPT_NORMAL, "a normal moved by {moved}");
    for v in 0..scene.vertex_count() {
        for &u in scene.rings.row(v) {
            assert_ne!(scene.colours[v], scene.colours[u as usize], "neighbours {v} and {u} share a colour");
        }
    }
}

/// At 256 rays the rounds mark at a quarter of them (64: a round's
/// marks read edges against a 25% tolerance) and the final mesh gets a
/// fresh solver at 256 (without a marking solve first where the rounds'
/// falling marks predict it is the last): the same solution as a fresh
/// solve of that mesh.
#[test]
fn marking_rounds_trace_a_quarter_of_the_rays() {
    let (desc, _) = coarse_cornell(RefineSettings::default());
    // After every round, each traced part equals a fresh trace of it on
    // that round's mesh; after the first, the emitter links were updated
    // (kept vertices kept their rows), not traced anew.
    let plan = Plan::of(&desc);
    let current = refine::apriori(&desc, &desc.settings.refine).0;
    let prepared = linkgi::scene::prep::prepare(&current).unwrap();
    let mut rounds = 0;
    let mut on_round = |s: &linkgi::solver::Solver, _: &linkgi::solver::Solution| {
        let parts = s.check_traced().unwrap_or_else(|e| panic!("round {rounds}: {e}"));
        assert!(parts >= 3, "round {rounds}: the sources traced ({parts} parts)");
        let (name, emitters) = s.part_costs()[1];
        assert_eq!(name, "emitter links");
        eprintln!("round {rounds}: emitter links {emitters:?}");
        if rounds > 0 {
            assert!(emitters.selective, "round {rounds}: the emitter links updated after the split");
            let n = s.scene().vertex_count() as u64;
            assert!(emitters.redone > 0 && emitters.redone < n, "round {rounds}: {} of {n} redone", emitters.redone);
        }
        rounds += 1;
    };
    let r = adaptive::solve_planned_with(current, prepared, &plan, &Compute::Cpu, &|_, _| {}, &mut on_round)
        .expect("solves");
    assert!(rounds >= 2, "two marking rounds checked ({rounds})");
    assert_eq!(r.solver.check_traced(), Ok(8), "the final solver's parts");
    assert!(r.rounds.len() >= 2, "the error-driven rounds split something");
    let marking = linkgi::solver::SolveParams::from_settings(&desc.settings).marking().links.rays_per_vertex;
    assert_eq!((desc.settings.rays_per_vertex, marking), (256, 64));
    let (last, marking_rounds) = r.rounds.split_last().unwrap();
    for round in marking_rounds {
        assert_eq!(round.rays_traced + round.rays_carried, round.vertices as u64 * 64);
    }
    assert_eq!(last.final_rays, last.vertices as u64 * 256, "the final mesh traced at full rays");
    // The final mesh is solved at 64 rays first only where its marks were
    // not predicted to fall under MIN_GAIN (adaptive::next_is_last).
    let full = last.vertices as u64 * 256;
    assert!(last.rays_traced + last.rays_carried == last.vertices as u64 * 64 || last.rays_traced == full, "{last:?}");
    let scene = r.solver.scene().clone();
    let fresh =
        linkgi::solver::Solver::new(scene, linkgi::solver::SolveParams::from_settings(&desc.settings), &|_, _| {})
            .unwrap();
    assert_eq!(r.solution.e_indirect, fresh.solve().e_indirect, "a fresh solve of the final mesh");
}

/// A budget below what the rounds want: the round splits the edges whose
/// ends differ most, up to the budget, and the rounds stop there.
#[test]
fn the_vertex_budget_holds() {
    let (desc, _) = coarse_cornell(RefineSettings::default());
    let count_positions = |d: &SceneDesc| d.meshes.iter().map(|m| m.positions.len()).sum::<usize>();
    let input = count_positions(&desc);
    let apriori = count_positions(&refine::apriori(&desc, &desc.settings.refine).0);
    // The budget is room beyond the input: 150 positions past the a-priori step.
    let added = apriori - input + 150;
    let (limited, _) = coarse_cornell(RefineSettings { max_added: added as u32, ..Default::default() });
    let r = solve(&limited);
    let positions = count_positions(&r.desc);
    let budget = input + added;
    eprintln!("a priori {apriori} positions, budget {budget}, reached {positions} in {} rounds", r.rounds.len());
    assert!(positions <= budget && positions > apriori, "{positions} positions for a budget of {budget}");
    // A budget under the a-priori step itself: the mesh stays as loaded.
    let (tiny, _) = coarse_cornell(RefineSettings { max_added: 0, ..Default::default() });
    let (same, _) = refine::apriori(&tiny, &tiny.settings.refine);
    let count = |d: &SceneDesc| d.meshes.iter().map(|m| m.triangles.len()).sum::<usize>();
    assert_eq!(count(&same), count(&tiny));
}

/// A scene whose input alone holds more positions than the budget still
/// refines where its light needs it (the budget is room beyond the
/// input; it used to count the input, and such a scene refined nothing),
/// and a round the budget cuts says so.
#[test]
fn a_scene_bigger_than_the_budget_still_refines() {
    let (mut desc, _) = coarse_cornell(RefineSettings::default());
    let count_positions = |d: &SceneDesc| d.meshes.iter().map(|m| m.positions.len()).sum::<usize>();
    let (input, apriori) = (count_positions(&desc), count_positions(&refine::apriori(&desc, &desc.settings.refine).0));
    let added = apriori - input + 40;
    // A fine grid under the floor, facing down: more positions than the budget, nothing coarse.
    let mut g = MeshBuilder::new();
    let grey = g.add_material("grey", Vec3::splat(0.5));
    let n = (added as f32).sqrt() as u32 + 4;
    g.quad_grid(Vec3::new(-0.25, -0.05, -0.25), Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5), n, n, grey);
    desc.meshes.push(g.finish("filler", 30.0));
    desc.settings.refine.max_added = added as u32;
    let input = count_positions(&desc);
    assert!(input > added, "{input} input positions, budget {added}");
    let r = solve(&desc);
    let positions = count_positions(&r.desc);
    eprintln!("input {input}, budget {added}, reached {positions}; rounds {:?}", r.rounds);
    assert!(positions > input, "refined nothing: {positions} positions of {input}");
    assert!(r.rounds.len() > 1 && r.rounds[0].marked > 0, "the rounds split edges: {:?}", r.rounds);
    assert!(positions <= input + added, "{positions} positions past the budget of {added} beyond {input}");
    let cut = r.rounds.iter().find(|x| x.marked < x.wanted).expect("a round the budget cut");
    assert!(cut.marked < cut.wanted);
}

/// `refine`, `refine_max_edge`, `refine_tolerance` and
/// `refine_max_added` in `[settings]`: read, checked, written back.
#[test]
fn refine_settings_load_check_and_save() {
    let toml = |settings: &str| common::load_with_settings("linkgi-refine", settings);
    let d = toml("refine = \"off\"\nrefine_max_edge = 0.3\nrefine_tolerance = 0.1\nrefine_max_added = 5000").unwrap();
    let r = d.settings.refine;
    assert_eq!((r.mode, r.max_edge, r.tolerance, r.max_added), (RefineMode::Off, 0.3, 0.1, 5000));
    let text = linkgi::scene::file::to_toml(&d, &["q.obj".to_string()]);
    for key in ["refine = \"off\"", "refine_max_edge = 0.3", "refine_tolerance = 0.1", "refine_max_added = 5000"] {
        assert!(text.contains(key), "{key} missing from\n{text}");
    }
    assert_eq!(toml("").unwrap().settings.refine, RefineSettings::default());
    let e = toml("refine = \"sometimes\"").unwrap_err().to_string();
    assert!(e.contains("s.toml") && e.contains("refine") && e.contains("\"auto\" or \"off\""), "{e}");
    let e = toml("refine_tolerance = -1").unwrap_err().to_string();
    assert!(e.contains("refine_tolerance"), "{e}");
    let e = toml("refine_max_edge = -2").unwrap_err().to_string();
    assert!(e.contains("refine_max_edge"), "{e}");
}

/// Extreme scales: the same coarse box a thousand times larger and
/// smaller (the light's exitance kept) refines alike (the target follows
/// the scene's diagonal) and reads the same irradiance; every value finite.
#[test]
fn refinement_is_scale_free() {
    let run = |scale: f32| {
        let (mut desc, _) = coarse_cornell(RefineSettings::default());
        for m in &mut desc.meshes {
            m.transform.scale = scale;
        }
        let r = solve(&desc);
        (r.rounds.iter().map(|r| r.vertices).collect::<Vec<_>>(), common::mean(&r.solution.e_indirect))
    };
    let (v1, e1) = run(1.0);
    for scale in [1e3f32, 1e-3] {
        let (v, e) = run(scale);
        eprintln!("scale {scale}: vertices per round {v:?}, mean E {e} (scale 1: {v1:?}, {e1})");
        // The first round is the same a-priori mesh; later rounds may differ
        // by a few edges where two ends' difference sits at the tolerance.
        assert_eq!(v[0], v1[0], "scale {scale}");
        let last = |v: &[usize]| *v.last().unwrap() as f32;
        assert!((last(&v) / last(&v1) - 1.0).abs() < 0.05, "scale {scale}: {v:?} against {v1:?}");
        assert!(((e / e1) - Vec3::ONE).abs().max_element() < 0.03, "scale {scale}: {e} against {e1}");
    }
}

/// The command line: `solve` refines a coarse OBJ by default and says so;
/// `--refine-max-added` caps it (and a note says so), `--refine off`
/// keeps it as loaded.
#[test]
fn the_cli_refines_and_its_flags_hold() {
    let dir = std::env::temp_dir().join(format!("linkgi-refine-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A closed box of 12 triangles, faces inward, and a point light inside.
    let obj = dir.join("box.obj");
    let mut text = String::new();
    for i in 0..8 {
        text += &format!(
            "v {} {} {}\n",
            if i & 1 == 0 { -1 } else { 1 },
            if i & 2 == 0 { 0 } else { 2 },
            if i & 4 == 0 { -1 } else { 1 }
        );
    }
    for f in ["1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"] {
        let v: Vec<&str> = f.split(' ').collect();
        text += &format!("f {} {} {}\nf {} {} {}\n", v[0], v[1], v[2], v[0], v[2], v[3]);
    }
    std::fs::write(&obj, text).unwrap();
    let toml = dir.join("s.toml");
    std::fs::write(
        &toml,
        "[settings]\nrays_per_vertex = 16\n[[mesh]]\nobj = \"box.obj\"\n[[light]]\nkind = \"point\"\nposition = [0.2, 1.5, 0.1]\nintensity = [1, 1, 1]\n",
    )
    .unwrap();
    let solve = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_linkgi"))
            .args(["solve", toml.to_str().unwrap(), "--backend", "cpu"])
            .args(extra)
            .output()
            .unwrap();
        let (stdout, stderr) =
            (String::from_utf8_lossy(&out.stdout).to_string(), String::from_utf8_lossy(&out.stderr).to_string());
        assert!(out.status.success(), "{stderr}");
        let v: usize = stdout.lines().find_map(|l| l.strip_prefix("vertices")).unwrap().trim().parse().unwrap();
        (v, stderr)
    };
    let (auto, note) = solve(&[]);
    assert!(auto > 200 && note.contains("coarse meshes refined"), "{auto} vertices; {note}");
    let (capped, note) = solve(&["--refine-max-added", "92"]);
    assert!(
        capped < auto && capped <= 100 * 3,
        "{capped} vertices under a budget of 8 + 92 positions (crease copies at most 3 each)"
    );
    assert!(note.contains("refinement budget"), "the budget's cut is said: {note}");
    let (off, note) = solve(&["--refine", "off"]);
    assert_eq!(off, 24, "8 corners, each split three ways at the creases");
    assert!(!note.contains("refined"), "{note}");
}

/// Term decisions (`solver/decide.rs`): deterministic for a scene and
/// seed, a term that changes the sampled light by less than `pay_share`
/// is left out (not traced), `on = [...]` keeps it, `pay_share` 0 keeps all.
#[test]
fn terms_that_do_not_pay_are_left_out_and_forced_ones_stay() {
    use linkgi::exchange::near::NearTerm;
    let (desc, _) = coarse_cornell(RefineSettings::off());
    let scene = linkgi::scene::prep::prepare(&desc).unwrap();
    let build =
        |params: linkgi::solver::SolveParams| linkgi::solver::Solver::new(scene.clone(), params, &|_, _| {}).unwrap();
    let base = linkgi::solver::SolveParams::from_settings(&scene.settings);
    let (a, b) = (build(base), build(base));
    assert_eq!(a.term_decisions(), b.term_decisions(), "deterministic");
    let d = a.term_decisions();
    assert!(!d.is_empty(), "the lamp's box has near terms to decide");
    for x in d {
        eprintln!("{}", x.describe());
        assert_eq!(x.on, x.change >= base.pay_share, "{x:?}");
        let traced = match x.term {
            "near_emitters" => !a.near().emitters.is_empty(),
            "near_gather" => !a.near().gather.is_empty(),
            _ => !a.near().sky.is_empty(),
        };
        assert_eq!(traced, x.on, "{}: traced only when kept", x.term);
    }
    // A threshold above every change: all left out; forced: kept.
    let high = linkgi::solver::SolveParams { pay_share: 10.0, ..base };
    assert!(build(high).term_decisions().iter().all(|x| !x.on));
    let mut forced = high;
    forced.forced.set("near_gather", true).unwrap();
    let f = build(forced);
    let g = f.term_decisions().iter().find(|x| x.term == "near_gather").expect("decided");
    assert!(g.on && g.forced && !f.near().gather.is_empty(), "{g:?}");
    // pay_share 0: nothing decided, every term traced.
    let all = build(linkgi::solver::SolveParams { pay_share: 0.0, ..base });
    assert!(all.term_decisions().is_empty() && !all.near().gather.is_empty());
}
