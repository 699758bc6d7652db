//! Direct light through light links: the reported `E_d` is the point value
//! at the vertex, `I cos / r^2` (directional: `E cos`) exactly where the
//! vertex sees the light and 0 where it does not, whatever the shadow edges
//! do inside the triangles; the one-ring oversampled factors (the bounce
//! source) are partial at penumbra vertices.

mod common;

use glam::Vec3;
use linkgi::exchange::{BounceSource, LightLinkParams, LightLinks};
use linkgi::kdtree::{KdBuildParams, KdTree};
use linkgi::scene::shapes::MeshBuilder;
use linkgi::scene::{prep, Light, SceneDesc, Settings};

/// A 2x2 m floor at y = 0 (20x20 grid), optionally a 0.6 m square occluder
/// facing down at y = 0.5 over the centre.
fn floor_scene(occluder: bool, lights: Vec<Light>) -> prep::PreparedScene {
    let mut meshes = Vec::new();
    let mut b = MeshBuilder::new();
    let m = b.add_material("floor", Vec3::splat(0.5));
    b.quad_grid(Vec3::new(-1.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -2.0), 20, 20, m);
    meshes.push(b.finish("floor", 30.0));
    if occluder {
        let mut b = MeshBuilder::new();
        let m = b.add_material("occluder", Vec3::splat(0.5));
        // Its grid is offset from the floor's so no shadow ray passes exactly
        // through one of its vertices (a measure-zero case the kd-tree does
        // not guarantee; see the kdtree module doc).
        b.quad_grid(Vec3::new(-0.3, 0.5, -0.3), Vec3::new(0.6, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.6), 7, 7, m);
        meshes.push(b.finish("occluder", 30.0));
    }
    let desc = SceneDesc {
        name: "floor".into(),
        settings: Settings::default(),
        camera: None,
        meshes,
        lights,
        sky: None,
        warnings: vec![],
        notes: vec![],
    };
    let s = prep::prepare(&desc).unwrap();
    assert!(s.normals[..441].iter().all(|n| (*n - Vec3::Y).length() < 1e-6), "floor faces up");
    s
}

/// Light-link parameters with the one-ring oversampling and its bounce source.
fn ring_params() -> LightLinkParams {
    LightLinkParams { oversample: true, bounce_source: BounceSource::Ring, ..Default::default() }
}

fn direct(scene: &prep::PreparedScene) -> Vec<Vec3> {
    let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
    kd.validate().unwrap();
    let ll = LightLinks::compute(scene, &kd, &LightLinkParams::default());
    ll.direct(&scene.lights, scene.vertex_count())
}

#[test]
fn point_light_unblocked_is_exact() {
    let (lp, i) = (Vec3::new(0.2, 1.5, -0.1), Vec3::new(3.0, 2.0, 1.0));
    let scene = floor_scene(false, vec![Light::Point { position: lp, intensity: i }]);
    let e = direct(&scene);
    for (v, (&p, &ev)) in scene.positions.iter().zip(&e).enumerate() {
        let d = lp - p;
        let expect = i * (d.y / d.length()) / d.length_squared();
        assert!((ev - expect).abs().max_element() <= 1e-6 * expect.max_element(), "{v}: {ev} vs {expect}");
    }
}

/// True if the segment from `p` to `light` crosses the occluder square
/// (|x|, |z| < 0.3 at y = 0.5), and how far (m) the crossing is from the
/// square's edge (the margin of the analytic answer).
fn blocked(p: Vec3, light: Vec3) -> (bool, f32) {
    let t = (0.5 - p.y) / (light.y - p.y);
    let q = p + (light - p) * t;
    let inside = q.x.abs().max(q.z.abs());
    (inside < 0.3, (inside - 0.3).abs())
}

#[test]
fn point_light_e_d_is_analytic_at_every_vertex_with_shadow_edges_crossing_triangles() {
    // Off-centre too, so the shadow's edges (about 0.45 m out) cut floor
    // triangles at no particular place and differ on every side.
    for lp in [
        Vec3::new(0.0, 1.5, 0.0),
        Vec3::new(0.13, 1.61, 0.09),
        Vec3::new(-0.31, 1.2, 0.22),
        Vec3::new(-0.17, 1.33, -0.21),
    ] {
        let i = Vec3::new(5.0, 4.0, 3.0);
        let scene = floor_scene(true, vec![Light::Point { position: lp, intensity: i }]);
        let e = direct(&scene);
        let (mut umbra, mut lit, mut crossed) = (0, 0, 0);
        for (&p, &ev) in scene.positions.iter().zip(&e).take(441) {
            let d = lp - p;
            let expect = i * (d.y / d.length()) / d.length_squared();
            let (is_blocked, margin) = blocked(p, lp);
            assert!(margin > 1e-3, "vertex at {p}: its shadow ray grazes the occluder's edge");
            if is_blocked {
                assert_eq!(ev, Vec3::ZERO, "light {lp}: vertex at {p} is in the shadow");
                umbra += 1;
            } else {
                assert!((ev - expect).abs().max_element() <= 1e-6 * expect.max_element(), "{p}: {ev} vs {expect}");
                lit += 1;
            }
        }
        // Triangles with lit and shadowed corners: the shadow edge crosses them.
        for t in &scene.triangles {
            if t.iter().all(|&c| (c as usize) < 441) {
                let lit_corners = t.iter().filter(|&&c| e[c as usize].x > 0.0).count();
                crossed += (lit_corners == 1 || lit_corners == 2) as usize;
            }
        }
        assert!(umbra > 20 && lit > 200 && crossed > 20, "light {lp}: {umbra} umbra, {lit} lit, {crossed} crossed");
    }
}

#[test]
fn penumbra_is_partial_in_the_one_ring_oversampled_bounce_source() {
    // A vertex near the shadow edge sees part of its one-ring.
    let lp = Vec3::new(0.0, 1.5, 0.0);
    let scene = floor_scene(true, vec![Light::Point { position: lp, intensity: Vec3::ONE }]);
    let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
    let ll = LightLinks::compute(&scene, &kd, &ring_params());
    let n = scene.vertex_count();
    let (ring, point) = (ll.direct_ring(&scene.lights, n), ll.direct(&scene.lights, n));
    let partial = (0..441)
        .filter(|&v| {
            let d = lp - scene.positions[v];
            let full = (d.y / d.length()) / d.length_squared();
            ring[v].x > 0.01 * full && ring[v].x < 0.99 * full
        })
        .count();
    assert!(partial >= 8, "only {partial} penumbra vertices");
    // Both are the same G at the vertex times a visible share.
    for v in 0..441 {
        let d = lp - scene.positions[v];
        let full = (d.y / d.length()) / d.length_squared();
        assert!(ring[v].x <= full * (1.0 + 1e-6) && (point[v].x == 0.0 || (point[v].x / full - 1.0).abs() < 1e-6));
    }
    // The bounce source follows the parameter.
    assert_eq!(ll.bounce_source(&scene.lights, n), ring);
    let p = LightLinkParams { bounce_source: BounceSource::Point, ..ring_params() };
    let ll = LightLinks::compute(&scene, &kd, &p);
    assert_eq!(ll.bounce_source(&scene.lights, n), point);
    // Without oversampling (the default) the factors are the point values.
    let ll = LightLinks::compute(&scene, &kd, &LightLinkParams::default());
    assert_eq!((ll.direct_ring(&scene.lights, n), ll.direct(&scene.lights, n)), (point.clone(), point));
}

#[test]
fn directional_light_is_irradiance_times_cosine() {
    let dir = Vec3::new(0.27, -1.0, 0.13).normalize();
    let irr = Vec3::new(2.0, 1.0, 0.5);
    let scene = floor_scene(true, vec![Light::Directional { direction: dir, irradiance: irr }]);
    let e = direct(&scene);
    let expect = irr * (-dir).dot(Vec3::Y);
    let mut shadowed = 0;
    for (&p, &ev) in scene.positions.iter().zip(&e).take(441) {
        // Where the occluder's shadow falls: p + t*(-dir) crosses y = 0.5 inside the square.
        let q = p + (-dir) * (0.5 / (-dir).y);
        let inside = q.x.abs().max(q.z.abs());
        assert!((inside - 0.3).abs() > 1e-3, "vertex at {p} grazes the occluder's edge");
        if inside < 0.3 {
            assert_eq!(ev, Vec3::ZERO, "{p} should be shadowed");
            shadowed += 1;
        } else {
            assert!((ev - expect).abs().max_element() <= 1e-6 * expect.max_element(), "{p}: {ev}");
        }
    }
    assert!(shadowed > 5);
}

#[test]
fn light_on_a_vertex_and_behind_surfaces_stay_finite() {
    let scene = floor_scene(false, vec![]);
    let on_vertex = scene.positions[220];
    let scene = floor_scene(
        false,
        vec![
            Light::Point { position: on_vertex, intensity: Vec3::splat(1.0) },
            Light::Point { position: Vec3::new(0.0, -1.0, 0.0), intensity: Vec3::splat(100.0) },
        ],
    );
    let e = direct(&scene);
    assert!(e.iter().all(|x| x.is_finite() && x.min_element() >= 0.0));
    // The light below the floor lights nothing (back side); the one on the floor
    // plane has cos = 0 everywhere.
    assert!(e.iter().all(|x| *x == Vec3::ZERO), "{:?}", e.iter().find(|x| **x != Vec3::ZERO));
}

/// Updating the light links after light edits traces only the lights at a
/// new position or direction; every column equals a fresh computation bit
/// for bit. A changed intensity or a removed light traces nothing; new
/// parameters or moved vertices retrace every light.
#[test]
fn light_updates_trace_only_moved_lights() {
    let point = |p: Vec3, i: f32| Light::Point { position: p, intensity: Vec3::splat(i) };
    let sun = Light::Directional { direction: Vec3::new(0.3, -1.0, 0.2).normalize(), irradiance: Vec3::ONE };
    let mut scene =
        floor_scene(true, vec![point(Vec3::new(0.2, 1.0, 0.1), 3.0), sun, point(Vec3::new(-0.4, 0.8, 0.3), 1.0)]);
    let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
    kd.validate().unwrap();
    let params = ring_params();
    let mut links = LightLinks::compute(&scene, &kd, &params);
    let one = |scene: &prep::PreparedScene, l: &Light| LightLinks::compute_light(scene, &kd, l, &params).unwrap().rays;
    let bits = |c: &[f32]| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let check_fresh = |scene: &prep::PreparedScene, links: &LightLinks| {
        let fresh = LightLinks::compute(scene, &kd, &params);
        assert_eq!(links.factors.len(), fresh.factors.len());
        for (a, b) in links.factors.iter().zip(&fresh.factors).chain(links.point.iter().zip(&fresh.point)) {
            assert_eq!(bits(a), bits(b));
        }
    };
    let before = links.factors.clone();

    // Move the last light: only it is traced.
    scene.lights[2] = point(Vec3::new(0.5, 0.7, -0.2), 1.0);
    let rays = links.update_with(&scene, &kd, &params).unwrap();
    assert_eq!(rays, one(&scene, &scene.lights[2]));
    assert!(rays > 0);
    assert_eq!((bits(&links.factors[0]), bits(&links.factors[1])), (bits(&before[0]), bits(&before[1])));
    assert_ne!(bits(&links.factors[2]), bits(&before[2]));
    check_fresh(&scene, &links);

    // A new intensity, then a removed light: no rays, columns follow their lights.
    scene.lights[0] = point(Vec3::new(0.2, 1.0, 0.1), 6.0);
    assert_eq!(links.update_with(&scene, &kd, &params).unwrap(), 0);
    let e = links.direct(&scene.lights, scene.vertex_count());
    scene.lights.remove(0);
    assert_eq!(links.update_with(&scene, &kd, &params).unwrap(), 0);
    assert_eq!(bits(&links.factors[0]), bits(&before[1]));
    check_fresh(&scene, &links);
    let lit = e.iter().filter(|e| e.x > 0.0).count();
    assert!(lit > 100, "{lit} vertices lit");

    // Other parameters, or moved vertices, void every column.
    let coarse = LightLinkParams { oversample: false, ..params };
    let rays = links.update_with(&scene, &kd, &coarse).unwrap();
    assert_eq!(rays, LightLinks::compute(&scene, &kd, &coarse).shadow_rays);
    assert!(rays > 0);
    scene.positions[5].y += 1e-3;
    assert_eq!(links.update_with(&scene, &kd, &coarse).unwrap(), rays);
}

/// A preview traces one shadow ray per lit vertex (no oversampling): where
/// the full result sees the light from the whole one-ring or from none of
/// it, the preview gives the same factor (to rounding); the next full update replaces the
/// preview columns and equals a fresh computation bit for bit.
#[test]
fn light_preview_is_exact_outside_penumbrae_and_refines() {
    let point = |p: Vec3| Light::Point { position: p, intensity: Vec3::ONE };
    let mut scene = floor_scene(true, vec![point(Vec3::new(0.05, 1.2, -0.03))]);
    let kd = KdTree::build(&scene.positions, &scene.triangles, &KdBuildParams::default());
    kd.validate().unwrap();
    let params = ring_params();
    let mut links = LightLinks::compute(&scene, &kd, &params);
    scene.lights[0] = point(Vec3::new(-0.1, 1.0, 0.12));
    let preview_rays = links.preview_with(&scene, &kd, &params).unwrap();
    assert_eq!(links.coarse, vec![true]);
    let full = LightLinks::compute(&scene, &kd, &params);
    assert!(preview_rays > 0 && preview_rays * 5 < full.shadow_rays, "{preview_rays} vs {}", full.shadow_rays);
    let g = |v: usize| {
        linkgi::exchange::sources::light_links::geometry(&scene.lights[0], scene.positions[v], scene.normals[v], 1e-6)
    };
    let (mut lit, mut dark) = (0, 0);
    for v in 0..441 {
        let (f, p) = (full.factors[0][v], links.factors[0][v]);
        assert!(p.is_finite() && p >= 0.0 && p <= g(v) * 1.0001);
        if f == 0.0 || (f - g(v)).abs() <= 1e-6 * g(v) {
            assert!((p - f).abs() <= 1e-6 * f, "vertex {v}: preview {p}, full {f}");
            if f == 0.0 {
                dark += 1
            } else {
                lit += 1
            }
        }
    }
    assert!(lit > 100 && dark > 10, "{lit} lit, {dark} in umbra");
    // The reported E_d is the point value, which the preview traces with the very same rays.
    assert_eq!(links.point, full.point);
    let n = scene.vertex_count();
    assert_eq!(links.direct(&scene.lights, n), full.direct(&scene.lights, n));
    let rays = links.update_with(&scene, &kd, &params).unwrap();
    assert_eq!((rays, links.coarse.clone()), (full.shadow_rays, vec![false]));
    assert_eq!(links.factors, full.factors);
    assert_eq!(links.point, full.point);
}
