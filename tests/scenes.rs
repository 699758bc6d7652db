//! Scene files: the copies of the built-in scenes in `scenes/` load to the
//! same prepared geometry as the built-ins; a written scene reads back
//! bit-exact; the PLY export carries what the solver computed.

mod common;

use linkgi::scene::{self, builtin, prep, Bounces};

fn same_geometry(a: &prep::PreparedScene, b: &prep::PreparedScene) {
    assert!(a.positions == b.positions, "positions differ");
    assert!(a.triangles == b.triangles, "triangles differ");
    assert!(a.albedo == b.albedo, "albedo differs");
    assert!(a.emission == b.emission, "emission differs");
    assert_eq!(a.sky, b.sky);
    assert_eq!(a.lights, b.lights);
    assert_eq!(a.settings, b.settings);
}

#[test]
fn shipped_scene_files_match_builtins() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    for name in builtin::NAMES {
        let from_file = scene::load(dir.join(format!("{name}.toml")).to_str().unwrap())
            .unwrap_or_else(|e| panic!("scenes/{name}.toml: {e} (regenerate with `linkgi scenes`)"));
        assert!(from_file.warnings.is_empty(), "{:?}", from_file.warnings);
        let built = builtin::builtin(name).unwrap();
        same_geometry(&prep::prepare(&from_file).unwrap(), &prep::prepare(&built).unwrap());
        for (f, b) in from_file.meshes.iter().zip(&built.meshes) {
            assert_eq!(f.dynamic, b.dynamic, "{name}: dynamic flag");
            assert_eq!(f.deform, b.deform, "{name}: deformers");
        }
    }
}

#[test]
fn written_scene_reads_back() {
    let dir = std::env::temp_dir().join(format!("linkgi-scenes-{}", std::process::id()));
    let mut desc = builtin::closed_room(3, 0.4);
    desc.settings.bounces = Bounces::Auto;
    // Emission travels in the MTL (`Ke`), the sky in the TOML.
    desc.meshes[0].materials[0].emission = glam::Vec3::new(0.5, 2.0, 0.0);
    let mut sky = linkgi::sky::Sky::gradient(glam::Vec3::ONE, glam::Vec3::splat(0.5), glam::Vec3::ZERO);
    sky.rotate_deg = 30.0;
    sky.intensity = 2.0;
    sky.portals.push(
        linkgi::sky::Portal::from_corners([
            glam::Vec3::new(0.0, 2.0, 0.0),
            glam::Vec3::new(1.0, 2.0, 0.0),
            glam::Vec3::new(1.0, 2.0, 0.5),
            glam::Vec3::new(0.0, 2.0, 0.5),
        ])
        .unwrap(),
    );
    desc.sky = Some(sky);
    let path = scene::file::write_scene(&desc, &dir).unwrap();
    let back = scene::load(path.to_str().unwrap()).unwrap();
    assert_eq!(back.sky, desc.sky, "the sky with its portal");
    same_geometry(&prep::prepare(&back).unwrap(), &prep::prepare(&desc).unwrap());
}

#[test]
fn ply_export_carries_the_solution() {
    let desc = common::with_settings(builtin::builtin("cornell").unwrap(), 16, Bounces::Fixed(2), 30.0);
    let (solver, sol) = common::solve(&desc);
    let bytes = linkgi::export::ply_bytes(&solver.scene(), &sol);
    let header_end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    let n = solver.scene().vertex_count();
    let t = solver.scene().triangles.len();
    assert!(header.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(header.contains(&format!("element vertex {n}\n")));
    assert!(header.contains(&format!("element face {t}\nproperty list uchar uint vertex_indices\n")));
    for p in linkgi::export::PLY_VERTEX_PROPERTIES {
        assert!(header.contains(&format!("property float {p}\n")), "{p}");
    }
    assert!(header.contains(
        "property float emission_b\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nelement face"
    ));
    let props = linkgi::export::PLY_VERTEX_PROPERTIES.len();
    let stride = props * 4 + 3;
    assert_eq!(bytes.len(), header_end + n * stride + t * 13);
    // Vertex 7's indirect red and the last face read back.
    let rec = header_end + 7 * stride;
    let f = |i: usize| f32::from_le_bytes(bytes[rec + 4 * i..rec + 4 * i + 4].try_into().unwrap());
    assert_eq!(f(0), solver.scene().positions[7].x);
    assert_eq!(f(12), sol.e_indirect[7].x);
    // Every vertex's colour is its radiance from the record's own floats,
    // tone mapped as renders are, at the automatic exposure of all of them.
    let record = |v: usize| {
        let rec = &bytes[header_end + v * stride..header_end + (v + 1) * stride];
        let f = |i: usize| f32::from_le_bytes(rec[4 * i..4 * i + 4].try_into().unwrap());
        let vec = |i: usize| glam::Vec3::new(f(i), f(i + 1), f(i + 2));
        let (rho, e) = (vec(6), vec(9) + vec(12) + vec(15));
        (rec, rho, (rho * e + vec(18)) / std::f32::consts::PI)
    };
    let exposure = linkgi::render::exposure::key_exposure((0..n).map(|v| record(v).2)).unwrap();
    let mut sums = [[0f64; 3]; 2];
    for v in 0..n {
        let (rec, rho, radiance) = record(v);
        let rgb = &rec[props * 4..];
        assert_eq!(rgb, linkgi::render::display_rgb8(radiance, exposure), "vertex {v}");
        // The red and green walls show their colours.
        for (k, wall) in [rho.x > 2.0 * rho.y, rho.y > 2.0 * rho.x].into_iter().enumerate() {
            if wall {
                for c in 0..3 {
                    sums[k][c] += rgb[c] as f64;
                }
            }
        }
    }
    assert!(sums[0][0] > 1.5 * sums[0][1] && sums[1][1] > 1.5 * sums[1][0], "wall colours {sums:?}");
    let last = &bytes[bytes.len() - 13..];
    assert_eq!(last[0], 3);
    assert_eq!(u32::from_le_bytes(last[9..13].try_into().unwrap()), solver.scene().triangles[t - 1][2]);
    let json = linkgi::export::scene_json(&solver.scene(), &solver.stats(&sol, 0.0));
    assert_eq!(json["lights"][0]["kind"], "point");
    assert_eq!(json["stats"]["vertices"], n);
    assert_eq!(json["settings"]["rays_per_vertex"], 16);
    assert_eq!(json["settings"]["tracer"], desc.settings.tracer.name());
    let stats = &json["stats"];
    assert!(stats["tracer"].as_str().is_some_and(|t| !t.is_empty()), "{stats}");
    assert!(stats["rays_per_second"].as_f64().is_some_and(|r| r > 0.0), "{stats}");
    assert!(stats.get("shadow_rays_per_second").is_some(), "{stats}");
    assert!(stats.get("bvh_build_ms").is_some(), "{stats}");
}
