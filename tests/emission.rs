//! Emissive surfaces: the emissive furnace and emission as a source of the gather.
//!
//! Inside a closed enclosure whose whole surface emits exitance `M_e` and
//! reflects with albedo rho, the uniform radiosity `B = M_e + rho E` with
//! `E = B` (every photon lands on the enclosure) gives
//! `E = M_e / (1 - rho)` everywhere: exact for any closed shape, so the
//! tessellated sphere needs no area correction.

mod common;

use glam::Vec3;
use linkgi::scene::{builtin, prep, Bounces, SceneDesc};

fn emissive_furnace(rho: f32, m_e: Vec3) -> SceneDesc {
    let mut d = common::with_settings(builtin::furnace(rho, 4, Vec3::ZERO, 1.0), 256, Bounces::Auto, 30.0);
    d.lights.clear();
    for m in &mut d.meshes {
        m.materials.iter_mut().for_each(|mat| mat.emission = m_e);
    }
    d
}

#[test]
fn emissive_furnace_irradiance_is_emission_over_one_minus_albedo() {
    let m_e = Vec3::new(2.0, 1.0, 0.25);
    for rho in [0.5f32, 0.9] {
        let (solver, sol) = common::solve(&emissive_furnace(rho, m_e));
        let expect = m_e / (1.0 - rho);
        let mut max_err = 0f32;
        for e in &sol.e_indirect {
            max_err = max_err.max(((*e / expect) - Vec3::ONE).abs().max_element());
        }
        let mean = (common::mean(&sol.e_indirect) / expect - Vec3::ONE).abs().max_element();
        eprintln!("rho {rho}: mean err {mean:.4}, max err {max_err:.4}, {} bounces", sol.gather.bounces);
        assert!(mean < 0.02, "rho {rho}: mean error {mean}");
        assert!(max_err < 0.05, "rho {rho}: per-vertex error {max_err}");
        // With the emission of the band under the vertices' own triangles
        // (`Solver::e_emitter`) exact to rounding: measured below 5e-5 (0.17% low without it).
        assert!(mean < 1e-3 && max_err < 1e-3, "rho {rho}: mean error {mean}, per vertex {max_err}");
        // Emission is not direct light: no lights, no sky.
        assert!(sol.e_direct.iter().chain(&sol.e_sky).all(|e| *e == Vec3::ZERO));
        assert_eq!(solver.scene().emission.len(), solver.scene().vertex_count());
    }
}

/// The gather is linear in its sources: light and emission solved apart
/// add up to both solved together, and doubling the emission doubles its
/// part (energy is neither created nor lost by mixing sources). One
/// solver, its sources edited: the emitter groups' control variate
/// ([`linkgi::exchange::sources::emitter_cv`]) is part of the estimator, and it
/// exists only where the links were built with an emitter. The radiosity
/// correction is off: its clamp to its neighbours' range
/// ([`linkgi::exchange::bounce::reconstruct`]) is not linear.
#[test]
fn emission_adds_linearly_to_light() {
    let mut glowing = common::with_settings(builtin::builtin("cornell").unwrap(), 64, Bounces::Fixed(4), 0.0);
    // The short box glows.
    glowing.meshes[1].materials.iter_mut().for_each(|m| m.emission = Vec3::new(3.0, 2.0, 1.0));
    let scene = prep::prepare(&glowing).unwrap();
    let mut params = linkgi::solver::SolveParams::from_settings(&scene.settings);
    params.terms.reconstruct = false;
    let (mut solver, both) = common::solve_with(scene, params);
    assert!(both.e_cv.iter().any(|d| *d != Vec3::ZERO), "the box's control variate is on");
    let (lights, emission) = (solver.scene().lights.clone(), solver.scene().emission.clone());
    solver.set_lights(vec![]);
    let b = solver.solve();
    solver.set_emission(emission.iter().map(|e| *e * 2.0).collect());
    let b2 = solver.solve();
    solver.set_lights(lights);
    solver.set_emission(emission.iter().map(|_| Vec3::ZERO).collect());
    let a = solver.solve();
    let scale = common::mean(&both.e_indirect_raw).max_element();
    for v in 0..a.e_indirect_raw.len() {
        let sum = a.e_indirect_raw[v] + b.e_indirect_raw[v];
        assert!(
            (both.e_indirect_raw[v] - sum).abs().max_element() <= 1e-4 * scale,
            "vertex {v}: both {} against lights {} + emission {} (scale {scale})",
            both.e_indirect_raw[v],
            a.e_indirect_raw[v],
            b.e_indirect_raw[v]
        );
        assert!((b2.e_indirect_raw[v] - 2.0 * b.e_indirect_raw[v]).abs().max_element() <= 1e-4 * scale, "vertex {v}");
    }
    assert!(common::mean(&b.e_indirect_raw).min_element() > 0.0, "the glow lights the room");
}

/// Stiff and extreme cases: albedo 0.99 with auto bounces and an exitance
/// of 1e6 W/m^2 stay finite and exact within the furnace tolerance.
#[test]
fn emissive_furnace_stiff_and_intense() {
    let m_e = Vec3::splat(1e6);
    let (_, sol) = common::solve(&emissive_furnace(0.99, m_e));
    let expect = m_e.x / 0.01;
    let mean = common::mean(&sol.e_indirect).x;
    eprintln!("rho 0.99: mean {mean:.4e} vs {expect:.4e}, {} bounces", sol.gather.bounces);
    assert!((mean / expect - 1.0).abs() < 0.02, "mean {mean} vs {expect}");
    assert!(sol.e_indirect.iter().all(|e| e.is_finite() && (e.x / expect - 1.0).abs() < 0.05));
}

/// Bad emission is rejected with the mesh named.
#[test]
fn non_finite_emission_is_an_error() {
    let mut d = emissive_furnace(0.5, Vec3::ONE);
    d.meshes[0].materials[0].emission = Vec3::new(1.0, f32::NAN, 0.0);
    let e = prep::prepare(&d).unwrap_err().to_string();
    assert!(e.contains("furnace/sphere") && e.contains("emission"), "{e}");
    d.meshes[0].materials[0].emission = Vec3::new(-1.0, 0.0, 0.0);
    assert!(prep::prepare(&d).is_err());
}

/// The band of directions that dive under a vertex's own triangles
/// ([`linkgi::links::shoot::dive_share`], Lambert's formula on each
/// wedge's clipped spherical triangle) against dense sampling of
/// [`linkgi::links::Wedge::dives_under`] with 200k cosine directions a
/// vertex: on the furnace sphere's concave vertices (about 0.17%) within
/// four standard deviations of the sampling each, 3% summed; zero on a
/// flat plane.
#[test]
fn the_dive_band_by_lambert_matches_dense_sampling() {
    let desc = emissive_furnace(0.5, Vec3::ONE);
    let scene = prep::prepare(&desc).unwrap();
    let setup = linkgi::links::RaySetup::new(&scene, &linkgi::links::LinkParams::default());
    let m = 200_000;
    let (mut exact_sum, mut sampled_sum) = (0f64, 0f64);
    for v in (0..scene.vertex_count()).step_by(251) {
        let n = scene.normals[v];
        let frame = linkgi::sampling::vertex_frame(n, 0.3);
        let dives = (0..m)
            .filter(|&i| {
                // A rank-1 lattice over the unit square (R2 sequence).
                let u = glam::Vec2::new(
                    (i as f64 * 0.7548776662466927).fract() as f32,
                    (i as f64 * 0.5698402909980532).fract() as f32,
                );
                let d = linkgi::sampling::world_direction(frame, linkgi::sampling::cosine_hemisphere(u));
                setup.wedges(v).iter().any(|w| w.dives_under(d))
            })
            .count();
        let sampled = dives as f64 / m as f64;
        let exact = linkgi::links::shoot::dive_share(&scene, v) as f64;
        // Four standard deviations of the sampled share.
        let sigma = (exact / m as f64).sqrt();
        assert!((exact - sampled).abs() < 4.0 * sigma + 1e-6, "vertex {v}: Lambert {exact} against sampled {sampled}");
        exact_sum += exact;
        sampled_sum += sampled;
    }
    eprintln!("furnace sphere: band share {exact_sum:.5} by Lambert, {sampled_sum:.5} sampled (summed over the checked vertices)");
    assert!(exact_sum > 0.0 && (exact_sum - sampled_sum).abs() < 0.03 * exact_sum, "{exact_sum} against {sampled_sum}");
    let plane = prep::prepare(&common::scene_desc(
        "plane",
        vec![builtin::closed_room(2, 1.0).meshes.swap_remove(0)],
        vec![],
        None,
        16,
        Bounces::Fixed(1),
    ))
    .unwrap();
    let flat = (0..plane.vertex_count())
        .filter(|&v| !plane.boundary[v])
        .map(|v| linkgi::links::shoot::dive_share(&plane, v))
        .fold(0f32, f32::max);
    assert!(flat < 1e-6, "a flat surface's vertex dives under nothing ({flat})");
}

/// The emitter groups as a control variate of the first bounce
/// ([`linkgi::exchange::sources::emitter_cv`]) on `window` (its lamp shade glows
/// and reflects much of what it receives) at 64 rays: between two seeds,
/// the shade's unsmoothed `E_i` differs far less with it than without
/// (the link rays' count of hits on the shade is replaced by its form
/// factor), its mean over the shade moves by less than its noise (the
/// control variate has expectation zero), and its coefficients
/// `pi F - W` sum to almost nothing against `pi F` over the scene (the
/// links and the emitter links agree on how much of each vertex's view the
/// shade fills).
#[test]
fn the_emitter_control_variate_cuts_the_shades_noise_without_bias() {
    let solve = |seed: u64, cv: bool| {
        let mut d = builtin::builtin("window").unwrap();
        d.settings.rays_per_vertex = 64;
        d.settings.seed = seed;
        let scene = prep::prepare(&d).unwrap();
        let mut params = linkgi::solver::SolveParams::from_settings(&scene.settings);
        params.terms.emitter_cv = cv;
        common::solve_with(scene, params)
    };
    let (s1, a1) = solve(1, true);
    let (_, a2) = solve(2, true);
    let (s0, b1) = solve(1, false);
    let (_, b2) = solve(2, false);
    let cv = s1.emitter_cv();
    assert!(!cv.is_empty() && s0.emitter_cv().is_empty());
    assert!(a1.e_cv.iter().any(|d| *d != Vec3::ZERO) && b1.e_cv.is_empty());
    let shade: Vec<usize> = (0..s1.scene().vertex_count()).filter(|&v| s1.emitter_links().covered[v]).collect();
    assert!(shade.len() > 100, "{} shade vertices", shade.len());
    let spread = |x: &linkgi::solver::Solution, y: &linkgi::solver::Solution| {
        shade.iter().map(|&v| (x.e_indirect_raw[v] - y.e_indirect_raw[v]).length_squared() as f64).sum::<f64>()
    };
    let mean =
        |x: &linkgi::solver::Solution| shade.iter().map(|&v| x.e_indirect_raw[v].element_sum() as f64).sum::<f64>();
    let (with, without) = (spread(&a1, &a2), spread(&b1, &b2));
    let (m_with, m_without) = (mean(&a1) + mean(&a2), mean(&b1) + mean(&b2));
    // The standard error of the summed means, from the seeds' spread without the control variate.
    let stderr = (without / 2.0).sqrt();
    eprintln!(
        "shade: squared spread between seeds {with:.2} with, {without:.2} without ({:.3}); summed means {m_with:.1} / {m_without:.1} (+-{stderr:.1})",
        with / without
    );
    // Measured 0.64 (what stays is mostly the emitter links' own visibility noise).
    assert!(with < 0.8 * without, "spread {with} with, {without} without");
    assert!((m_with - m_without).abs() < 3.0 * stderr, "means {m_with} / {m_without}, standard error {stderr}");
    // The coefficients' sum against the form factors'.
    let c_sum: f64 = cv.rows.items.iter().map(|c| c.1 as f64).sum();
    let f_sum: f64 = (0..s1.scene().vertex_count())
        .flat_map(|v| s1.emitter_links().of(v).map(|(_, f)| std::f64::consts::PI * f as f64))
        .sum();
    eprintln!("coefficients sum {c_sum:.3} against pi F {f_sum:.3}");
    assert!(f_sum > 0.0 && c_sum.abs() < 0.03 * f_sum, "{c_sum} against {f_sum}");
}

/// One glowing plate (1 m square at z = 0, facing +z, black so that it
/// reflects nothing) in `dir`, its OBJ's MTL with `ke_line`, the scene
/// file's `[[mesh]]` with `mesh_extra`, a camera 2 m in front looking at it.
fn glowing_plate(name: &str, ke_line: &str, mesh_extra: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("emission-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(d.join("plate.mtl"), format!("newmtl glow\nKd 0 0 0\n{ke_line}\n")).unwrap();
    std::fs::write(
        d.join("plate.obj"),
        "mtllib plate.mtl\nusemtl glow\nv -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let toml = format!(
        "[settings]\nrays_per_vertex = 16\n[camera]\nposition = [0, 0, 2]\ntarget = [0, 0, 0]\nfov_deg = 40\n\
         [[mesh]]\nobj = \"plate.obj\"\n{mesh_extra}\n"
    );
    std::fs::write(d.join("s.toml"), toml).unwrap();
    d.join("s.toml")
}

/// The centre pixel of an OpenEXR image, linear RGB.
fn exr_centre(path: &std::path::Path) -> Vec3 {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![Vec3::ZERO; size.width() * size.height()]),
        |(w, px): &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .unwrap();
    let size = image.layer_data.size;
    let (w, px) = &image.layer_data.channel_data.pixels;
    px[size.height() / 2 * w + size.width() / 2]
}

/// Emission units (src/scene/emission.rs): MTL `Ke` and the scene file's
/// `emission` are emitted radiance. A camera looking at a glowing black
/// plate sees exactly that radiance in `linkgi render --exr`, the prepared
/// scene holds exitance `pi` times it, and the command says what it
/// assumed in a note.
#[test]
fn a_glowing_plate_shows_its_radiance() {
    let ke = Vec3::new(17.0, 12.0, 4.0);
    let emission = Vec3::new(2.0, 3.0, 5.0);
    for (name, radiance, scene, key) in [
        ("mtl", ke, glowing_plate("mtl", "Ke 17 12 4", ""), "Ke"),
        ("toml", emission, glowing_plate("toml", "Ke 100 100 100", "emission = [2, 3, 5]"), "emission"),
    ] {
        let exr = scene.with_file_name("plate.exr");
        let png = scene.with_file_name("plate.png");
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_linkgi"))
            .args(["render", scene.to_str().unwrap(), "--size", "32x24", "--backend", "cpu"])
            .args(["--out", png.to_str().unwrap(), "--exr", exr.to_str().unwrap()])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        let seen = exr_centre(&exr);
        assert!((seen / radiance - Vec3::ONE).abs().max_element() < 1e-4, "{name}: pixel {seen}, radiance {radiance}");
        let note =
            stderr.lines().find(|l| l.starts_with("note: ") && l.contains(&format!("{key} read as emitted radiance")));
        assert!(note.is_some_and(|n| n.contains("W/(m^2 sr)") && n.contains("M = pi*")), "{name}: {stderr}");

        let desc = linkgi::scene::load(scene.to_str().unwrap()).unwrap();
        assert!(desc.warnings.is_empty(), "{name}: {:?}", desc.warnings);
        assert_eq!(desc.notes.len(), 1, "{name}: one note, the replaced Ke's dropped: {:?}", desc.notes);
        let prepared = prep::prepare(&desc).unwrap();
        assert_eq!(prepared.emission.len(), 4);
        for m in &prepared.emission {
            assert_eq!(*m, linkgi::scene::emission::exitance(radiance), "{name}");
            assert!((*m / radiance - Vec3::splat(std::f32::consts::PI)).abs().max_element() < 1e-6, "{name}: {m}");
        }
    }
}

/// Emitters are one-sided like every surface: a plate glowing downwards
/// between a floor and a ceiling lights the floor and leaves the ceiling
/// above its back dark (its emitter links, near hits and link rays alike;
/// the reference path tracer stops at back faces too). Before emitter
/// links took the emitter's side into account the ceiling over the plate
/// read light from its back (McGuire's Cornell box: a halo around the
/// ceiling light and the picture 8% bright).
#[test]
fn an_emitter_lights_its_front_only() {
    use linkgi::scene::shapes::MeshBuilder;
    let grid = |origin: Vec3, u: Vec3, v: Vec3, n: u32, albedo: f32| {
        let mut b = MeshBuilder::new();
        let m = b.add_material("m", Vec3::splat(albedo));
        b.quad_grid(origin, u, v, n, n, m);
        b.finish("grid", 30.0)
    };
    let floor = grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), 10, 0.5);
    let ceiling = grid(Vec3::new(-1.0, 2.0, 1.0), Vec3::new(0.0, 0.0, -2.0), Vec3::new(2.0, 0.0, 0.0), 10, 0.5);
    let mut plate = grid(Vec3::new(-0.25, 1.0, 0.25), Vec3::new(0.0, 0.0, -0.5), Vec3::new(0.5, 0.0, 0.0), 2, 0.5);
    plate.materials[0].emission = Vec3::splat(10.0);
    let desc = common::scene_desc("glow", vec![floor, ceiling, plate], vec![], None, 256, Bounces::Fixed(1));
    let (solver, sol) = common::solve(&desc);
    let s = solver.scene();
    assert!(s.normals[s.meshes[2].vertices.start as usize].y < -0.99, "the plate faces down");
    let (floor, ceiling) = (&s.meshes[0], &s.meshes[1]);
    let e = |v: u32| sol.e_emitter[v as usize].x;
    let under = floor.vertices.clone().filter(|&v| {
        let p = s.positions[v as usize];
        p.x.hypot(p.z) < 0.3
    });
    assert!(under.clone().count() > 4 && under.clone().all(|v| e(v) > 0.5), "the floor under the plate is lit");
    let over: Vec<f32> = ceiling.vertices.clone().map(e).collect();
    assert!(over.iter().all(|&x| x == 0.0), "the ceiling reads the plate's back: {:?}", over);
    // And all the light the ceiling gets is what the floor reflects (one
    // bounce): far less than the floor's.
    let mean = |r: std::ops::Range<u32>| r.clone().map(|v| sol.e_indirect[v as usize].x).sum::<f32>() / r.len() as f32;
    assert!(mean(ceiling.vertices.clone()) < 0.5 * mean(floor.vertices.clone()));
}

/// Emitter links trace a pilot of a quarter of their samples first
/// ([`linkgi::exchange::sources::emitter_links::EmitterLinkParams::pilot_share`]):
/// in the Cornell box with a glowing short box, a vertex whose pilot rays
/// all agree keeps the pilot's answer, which is exact (the unshaded factor,
/// or nothing) as all samples give it, so most vertices read bit for bit
/// what tracing every sample reads; only penumbra vertices trace all
/// samples, and the direct light agrees with tracing every sample.
#[test]
fn the_emitter_pilot_is_exact_where_it_decides() {
    let mut glowing = common::with_settings(builtin::builtin("cornell").unwrap(), 256, Bounces::Fixed(2), 0.0);
    glowing.meshes[1].materials.iter_mut().for_each(|m| m.emission = Vec3::new(3.0, 2.0, 1.0));
    let scene = prep::prepare(&glowing).unwrap();
    let params = linkgi::solver::SolveParams::from_settings(&scene.settings);
    assert_eq!(params.emitter.pilot(), Some(64));
    let mut every = params;
    every.emitter.pilot_share = 1.0;
    assert_eq!(every.emitter.pilot(), None);
    let (a, _) = common::solve_with(scene.clone(), params);
    let (b, _) = common::solve_with(scene.clone(), every);
    let (ea, eb) = (a.emitter_links(), b.emitter_links());
    let (penumbra, seen) = ea.penumbra;
    assert!(penumbra > 0 && penumbra < seen / 2, "{penumbra} of {seen} vertices in penumbra");
    assert!(
        ea.shadow_rays < eb.shadow_rays * 3 / 4,
        "{} rays with the pilot, {} without",
        ea.shadow_rays,
        eb.shadow_rays
    );
    let n = scene.vertex_count();
    let same = (0..n).filter(|&v| ea.rows.row(v) == eb.rows.row(v)).count();
    // Decided vertices read as all samples read them, but where the full
    // samples find an occluder the pilot missed.
    let decided = n as u64 - penumbra;
    assert!(same as u64 >= decided * 95 / 100, "{same} of {decided} decided vertices read as without the pilot");
    let (ia, ib) = (ea.irradiance(&scene.emission, n), eb.irradiance(&scene.emission, n));
    let (ma, mb) = (common::mean(&ia), common::mean(&ib));
    assert!(((ma - mb).abs() / mb).max_element() < 0.01, "mean E_em {ma} with the pilot, {mb} without");
}
