//! Deformers (`scene::deform`): identity at t = 0 and at amount 0, twist
//! keeps distances to its axis, normals follow the deformed triangles, and
//! bad `[[mesh.deform]]` values are errors naming the scene file.

use glam::Vec3;
use linkgi::scene::deform::{deform_scene, Deform, DeformKind};
use linkgi::scene::{self, builtin, prep};

fn cloud() -> Vec<Vec3> {
    (0..200)
        .map(|i| {
            let f = i as f32;
            Vec3::new((f * 0.37).sin() * 0.8, (f * 0.11).fract() * 2.0 - 0.3, (f * 0.53).cos() * 0.6)
        })
        .collect()
}

fn all_kinds(amount: f32) -> Vec<Deform> {
    let mut v = Vec::new();
    for kind in [DeformKind::Twist, DeformKind::Bend, DeformKind::Wave] {
        let mut d = Deform::new(kind, amount);
        d.center = Vec3::new(0.1, 0.2, -0.1);
        d.axis = Vec3::new(0.2, 1.0, 0.1);
        d.toward = Vec3::X;
        v.push(d.normalized());
    }
    v
}

#[test]
fn identity_at_time_zero_and_amount_zero() {
    for d in all_kinds(35.0) {
        for p in cloud() {
            assert!((d.apply(p, 0.0) - p).length() < 1e-6, "{:?} moved {p} at t = 0", d.kind);
        }
    }
    for d in all_kinds(0.0) {
        for p in cloud() {
            assert!((d.apply(p, 1.3) - p).length() < 1e-6, "{:?} with amount 0 moved {p}", d.kind);
        }
    }
    // And a non-zero amount at a non-zero time does move points.
    for d in all_kinds(35.0) {
        let moved = cloud().iter().filter(|&&p| (d.apply(p, 1.0) - p).length() > 1e-3).count();
        assert!(moved > 50, "{:?} moved only {moved} points", d.kind);
    }
}

#[test]
fn twist_preserves_distance_to_axis_and_height() {
    let d = all_kinds(60.0)[0];
    let axis_dist = |p: Vec3| {
        let r = p - d.center;
        (r - d.axis * r.dot(d.axis)).length()
    };
    for t in [0.3f32, 1.0, 2.7] {
        for p in cloud() {
            let q = d.apply(p, t);
            assert!((axis_dist(q) - axis_dist(p)).abs() < 1e-5, "distance to axis changed at t = {t}");
            assert!(((q - d.center).dot(d.axis) - (p - d.center).dot(d.axis)).abs() < 1e-5, "height changed");
        }
    }
}

#[test]
fn torso_figure_deforms_and_room_stays() {
    let desc = builtin::builtin("torso").unwrap();
    let s = prep::prepare(&desc).unwrap();
    let (pos, nrm) = deform_scene(&s, &s.positions, &s.normals, 1.0);
    let room = &s.meshes[0];
    let fig = &s.meshes[1];
    assert!(fig.dynamic && !fig.deform.is_empty());
    for v in room.vertices.clone() {
        assert_eq!(pos[v as usize], s.positions[v as usize]);
    }
    let moved = fig.vertices.clone().filter(|&v| (pos[v as usize] - s.positions[v as usize]).length() > 1e-3).count();
    assert!(moved * 2 > fig.vertices.len(), "only {moved} figure vertices moved");
    // Normals stay unit and agree with the deformed faces they touch.
    for v in fig.vertices.clone() {
        let n = nrm[v as usize];
        assert!((n.length() - 1.0).abs() < 1e-4);
        for &ti in s.vertex_triangles.row(v as usize) {
            let t = s.triangles[ti as usize].map(|i| pos[i as usize]);
            let face = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            if face != Vec3::ZERO {
                assert!(face.dot(n) > -0.2, "vertex {v}: normal faces away from its triangle");
            }
        }
    }
    // At t = 0 the scene is exactly the rest scene.
    let (p0, _) = deform_scene(&s, &s.positions, &s.normals, 0.0);
    let worst = p0.iter().zip(&s.positions).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
    assert!(worst < 1e-6, "{worst}");
}

fn write_scene(name: &str, deform: &str, dynamic: bool) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("linkgi-deform-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, format!("[[mesh]]\nobj = \"tri.obj\"\ndynamic = {dynamic}\n\n[[mesh.deform]]\n{deform}\n"))
        .unwrap();
    path
}

#[test]
fn bad_deform_values_name_the_file() {
    let cases = [
        ("kind", "kind = \"melt\"\namount = 1.0", true, "deform.kind"),
        ("period", "kind = \"twist\"\namount = 10.0\nperiod_s = 0.0", true, "period_s"),
        ("axis", "kind = \"bend\"\namount = 10.0\naxis = [0.0, 0.0, 0.0]", true, "axis"),
        ("wavelength", "kind = \"wave\"\namount = 0.1\nwavelength = -1.0", true, "wavelength"),
        ("unknown", "kind = \"wave\"\namount = 0.1\nspeed = 2.0", true, "speed"),
        ("static", "kind = \"twist\"\namount = 10.0", false, "dynamic = true"),
    ];
    for (name, body, dynamic, needle) in cases {
        let path = write_scene(name, body, dynamic);
        let err = scene::load(path.to_str().unwrap()).expect_err(name).to_string();
        assert!(err.contains(&format!("{name}.toml")), "{name}: error does not name the file: {err}");
        assert!(err.contains(needle), "{name}: error does not mention {needle}: {err}");
    }
    // A good table loads, normalized.
    let path = write_scene("good", "kind = \"twist\"\namount = 10.0\naxis = [0.0, 2.0, 0.0]", true);
    let s = scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!(s.meshes[0].deform[0].axis, Vec3::Y);
}

/// A deformation handled by refitting the BVH gives exactly the links and
/// light links of a fresh solve of the deformed scene (the refitted tree
/// finds the same hits), and the refitted tree validates.
#[test]
fn refitted_deformation_equals_a_fresh_solve() {
    use linkgi::solver::{SolveParams, Solver};
    let desc = builtin::builtin("torso").unwrap();
    let mut s = prep::prepare(&desc).unwrap();
    s.settings.rays_per_vertex = 64;
    let params = SolveParams::from_settings(&s.settings);
    let mut solver = Solver::new(s.clone(), params, &|_, _| {}).unwrap();
    let mut refits = 0;
    for t in [0.1f32, 0.25, 0.5] {
        let (positions, normals) = deform_scene(&s, &s.positions, &s.normals, t);
        let mut moved = s.clone();
        moved.positions = positions;
        moved.normals = normals;
        let (next, refitted) = solver.deformed(moved.clone(), params, &|_, _| {});
        refits += refitted as usize;
        next.accel().validate().expect("refitted BVH valid");
        next.links().validate().expect("links valid");
        let fresh = Solver::new(moved, params, &|_, _| {}).unwrap();
        assert_eq!(next.links().offsets, fresh.links().offsets, "t = {t}");
        assert_eq!(next.links().packed, fresh.links().packed, "t = {t}");
        assert_eq!(next.links().weights, fresh.links().weights, "t = {t}");
        assert_eq!(next.light_links().factors, fresh.light_links().factors, "t = {t}");
        solver = next;
    }
    assert!(refits >= 1, "small deformations refit the BVH");
}
