//! Tests of the built-in scenes: validity, determinism, vertex counts,
//! winding and closure, no shared vertices between parts, nothing hidden
//! on supports, rooms facing inward, cameras and lights inside.

use super::conference::{chair_seat, conference_layout, table_top};
use super::tearoom::tearoom_table;
use super::*;
use std::collections::HashMap;

/// The slabs (table tops, seats) that parts of the built-in scene `name`
/// stand on or end at, for tests.
fn supports(name: &str) -> Vec<Slab> {
    match name {
        "tearoom" | "dancer" => vec![tearoom_table()],
        "conference" => {
            let (tables, chairs) = conference_layout();
            tables.into_iter().map(table_top).chain(chairs.into_iter().map(chair_seat)).collect()
        }
        _ => Vec::new(),
    }
}

fn key(p: Vec3) -> [u32; 3] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
}

/// Unique positions per mesh (exact-position weld), summed.
fn unique_positions(s: &SceneDesc) -> usize {
    s.meshes.iter().map(|m| m.positions.iter().map(|&p| key(p)).collect::<std::collections::HashSet<_>>().len()).sum()
}

#[test]
fn builtins_are_valid() {
    for &name in NAMES {
        let t0 = std::time::Instant::now();
        let s = builtin(name).expect(name);
        let dt = t0.elapsed();
        let emits = s.meshes.iter().any(|m| m.materials.iter().any(|mat| mat.emission != Vec3::ZERO));
        assert!(!s.lights.is_empty() || emits || s.sky.is_some(), "{name}: no light, emitter or sky");
        assert!(!s.meshes.is_empty(), "{name}: no mesh");
        let mut tris = 0;
        for m in &s.meshes {
            assert_eq!(m.triangles.len(), m.triangle_material.len(), "{}", m.name);
            assert!(m.positions.iter().all(|p| p.is_finite()), "{}: non-finite position", m.name);
            for (k, t) in m.triangles.iter().enumerate() {
                assert!(t.iter().all(|&i| (i as usize) < m.positions.len()), "{}: triangle {k} out of range", m.name);
                assert!((m.triangle_material[k] as usize) < m.materials.len(), "{}: material of {k}", m.name);
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                assert!((b - a).cross(c - a).length() > 0.0, "{}: triangle {k} has zero area", m.name);
            }
            for mat in &m.materials {
                assert!(mat.albedo.max_element() < 0.9 && mat.albedo.min_element() >= 0.0, "{}", mat.name);
            }
            tris += m.triangles.len();
        }
        eprintln!(
            "{name:>11}: {:>7} unique positions, {:>7} triangles, {} meshes, {} lights, built in {:.1} ms",
            unique_positions(&s),
            tris,
            s.meshes.len(),
            s.lights.len(),
            dt.as_secs_f64() * 1e3
        );
        for m in &s.meshes {
            let n = m.positions.iter().map(|&p| key(p)).collect::<std::collections::HashSet<_>>().len();
            eprintln!("{:>30}: {n:>7} unique positions, {:>7} triangles", m.name, m.triangles.len());
        }
    }
}

#[test]
fn builtins_are_deterministic() {
    for &name in NAMES {
        let (a, b) = (builtin(name).unwrap(), builtin(name).unwrap());
        assert_eq!(a.meshes.len(), b.meshes.len());
        for (ma, mb) in a.meshes.iter().zip(&b.meshes) {
            let bits = |m: &MeshDesc| m.positions.iter().map(|&p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert_eq!(bits(ma), bits(mb), "{name}");
            assert_eq!(ma.triangles, mb.triangles, "{name}");
        }
        assert_eq!(a.lights, b.lights);
    }
    assert!(builtin("nonesuch").is_none());
}

#[test]
fn unique_positions_near_targets() {
    let targets = [
        ("cornell", 3000),
        ("furnace", 2562),
        ("colorlamp", 1600),
        ("torso", 7100),
        ("tearoom", 11900),
        ("dancer", 16900),
        ("sculpture", 76500),
        ("conference", 122800),
    ];
    for (name, target) in targets {
        let n = unique_positions(&builtin(name).unwrap()) as f64;
        assert!((n / target as f64 - 1.0).abs() < 0.15, "{name}: {n} unique positions, target {target}");
    }
}

/// Welded position ids of a mesh's vertices (exact-position weld).
fn weld(m: &MeshDesc) -> Vec<u32> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    m.positions
        .iter()
        .map(|&p| {
            let n = ids.len() as u32;
            *ids.entry(key(p)).or_insert(n)
        })
        .collect()
}

fn find(parent: &mut HashMap<u32, u32>, x: u32) -> u32 {
    let mut r = x;
    while let Some(&p) = parent.get(&r) {
        if p == r {
            break;
        }
        r = p;
    }
    parent.insert(x, r);
    r
}

fn union(parent: &mut HashMap<u32, u32>, a: u32, b: u32) {
    parent.entry(a).or_insert(a);
    parent.entry(b).or_insert(b);
    let (ra, rb) = (find(parent, a), find(parent, b));
    parent.insert(ra.max(rb), ra.min(rb));
}

/// Every mesh is consistently wound once exact positions are welded
/// (each edge used at most once in each direction); rooms are closed
/// (each edge used exactly once in each direction). Faces hidden
/// against a support are left out, so other meshes may be open: their
/// signed volume, with every border loop closed by a flat fan, is
/// negative for rooms (facing inward) and positive for everything else.
#[test]
fn meshes_are_consistently_wound_and_rooms_closed() {
    for &name in NAMES {
        let s = builtin(name).unwrap();
        for (k, m) in s.meshes.iter().enumerate() {
            let remap = weld(m);
            let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
            let mut volume = 0.0f64;
            for t in &m.triangles {
                for e in 0..3 {
                    let (a, b) = (remap[t[e] as usize], remap[t[(e + 1) % 3] as usize]);
                    let entry = edges.entry((a.min(b), a.max(b))).or_insert((0, 0));
                    if a < b {
                        entry.0 += 1;
                    } else {
                        entry.1 += 1;
                    }
                }
                let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
                volume += a.dot(b.cross(c)) / 6.0;
            }
            let bad = edges.values().filter(|&&(f, b)| f > 1 || b > 1).count();
            assert_eq!(bad, 0, "{}: {bad} edges used twice in one direction", m.name);
            let room = k == 0;
            let border: Vec<(u32, u32)> = edges
                .iter()
                .filter(|(_, &(f, b))| f + b == 1)
                .map(|(&(lo, hi), &(f, _))| if f == 1 { (lo, hi) } else { (hi, lo) })
                .collect();
            if room && s.sky.is_none() {
                assert!(border.is_empty(), "{}: room has {} border edges", m.name, border.len());
            }
            if room && name == "window" {
                // The window: 5 x 8 cells of 0.25 m.
                assert_eq!(border.len(), 2 * (5 + 8), "{}: the window's border", m.name);
            }
            // Close each border loop (they are planar) by a fan from one of its vertices.
            let mut pos = vec![Vec3::ZERO; remap.len()];
            for (i, &w) in remap.iter().enumerate() {
                pos[w as usize] = m.positions[i];
            }
            let mut parent = HashMap::new();
            for &(a, b) in &border {
                union(&mut parent, a, b);
            }
            for &(a, b) in &border {
                let apex = pos[find(&mut parent, a) as usize].as_dvec3();
                let (pa, pb) = (pos[a as usize].as_dvec3(), pos[b as usize].as_dvec3());
                volume += apex.dot(pb.cross(pa)) / 6.0;
            }
            assert!((volume < 0.0) == room, "{}: signed volume {volume}", m.name);
        }
    }
}

/// No two parts of a mesh share a vertex: around every welded position
/// the incident triangles form one fan (connected through shared edges).
#[test]
fn parts_share_no_vertex() {
    for &name in NAMES {
        let s = builtin(name).unwrap();
        for m in &s.meshes {
            let remap = weld(m);
            // For every welded vertex, join the other two corners of each incident triangle.
            let mut links: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
            for t in &m.triangles {
                let w = t.map(|i| remap[i as usize]);
                for e in 0..3 {
                    links.entry(w[e]).or_default().push((w[(e + 1) % 3], w[(e + 2) % 3]));
                }
            }
            for (v, link) in &links {
                let mut parent = HashMap::new();
                for &(a, b) in link {
                    union(&mut parent, a, b);
                }
                let root = find(&mut parent, link[0].0);
                assert!(
                    link.iter().all(|&(a, _)| find(&mut parent, a) == root),
                    "{}: vertex {v} joins separate fans",
                    m.name
                );
            }
        }
    }
}

/// Nothing is hidden in contact with, or buried in, what it stands on:
/// no vertex of a non-room mesh lies below the floor, and no face lies
/// on the floor facing down. Likewise for table tops and seats: no face
/// lies on a top facing down or on an underside facing up (a buried leg
/// top) inside the footprint, and no vertex lies strictly inside a slab
/// unless it belongs to the slab's own box.
#[test]
fn nothing_hidden_on_supports() {
    const EPS: f32 = 1e-5;
    for &name in NAMES {
        let s = builtin(name).unwrap();
        let floor = s.meshes[0].positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        let slabs = supports(name);
        if matches!(name, "tearoom" | "dancer" | "conference") {
            assert!(!slabs.is_empty(), "{name}: no supports");
        }
        let on = |y: f32, h: f32| (y - h).abs() <= EPS;
        let inside = |sl: &Slab, x: f32, z: f32, margin: f32| {
            x > sl.min_xz.x + margin && x < sl.max_xz.x - margin && z > sl.min_xz.y + margin && z < sl.max_xz.y - margin
        };
        for m in &s.meshes[1..] {
            for p in &m.positions {
                assert!(p.y >= floor, "{}: vertex {p} below the floor", m.name);
            }
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let n = (b - a).cross(c - a);
                let centre = (a + b + c) / 3.0;
                let flat_at = |h: f32| on(a.y, h) && on(b.y, h) && on(c.y, h);
                assert!(!(flat_at(floor) && n.y < 0.0), "{}: face {a} {b} {c} lies on the floor", m.name);
                for sl in &slabs {
                    if !inside(sl, centre.x, centre.z, 0.0) {
                        continue;
                    }
                    assert!(!(flat_at(sl.top) && n.y < 0.0), "{}: face {a} {b} {c} lies on a top", m.name);
                    assert!(!(flat_at(sl.bottom) && n.y > 0.0), "{}: face {a} {b} {c} buried under a top", m.name);
                }
            }
            // Vertices strictly inside a slab: only a slab's own sides
            // (on its footprint's border) may lie between its faces.
            for p in &m.positions {
                for sl in &slabs {
                    let between = p.y > sl.bottom + EPS && p.y < sl.top - EPS;
                    assert!(!(between && inside(sl, p.x, p.z, EPS)), "{}: vertex {p} inside a slab", m.name);
                }
            }
        }
    }
}

/// Every triangle of the room mesh faces the room's centre.
fn assert_inward(m: &MeshDesc, centre: Vec3) {
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let n = (b - a).cross(c - a);
        assert!(n.dot(centre - (a + b + c) / 3.0) > 0.0, "{}: triangle faces out", m.name);
    }
}

#[test]
fn rooms_face_inward() {
    let centre = Vec3::new(0.0, 1.0, 0.0);
    assert_inward(&closed_room(8, 0.5).meshes[0], centre);
    let c = builtin("cornell").unwrap();
    assert_inward(&c.meshes[0], centre);
    let f = furnace(0.5, 2, Vec3::ZERO, 1.0);
    assert_inward(&f.meshes[0], Vec3::ZERO);
}

#[test]
fn cameras_and_lights_inside_rooms() {
    for &name in NAMES.iter().filter(|&&n| n != "furnace") {
        let s = builtin(name).unwrap();
        let room = &s.meshes[0];
        let (lo, hi) =
            room.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let inside = |p: Vec3| p.cmpgt(lo).all() && p.cmplt(hi).all();
        assert!(inside(s.camera.expect("built-in scenes have cameras").position), "{name}: camera outside");
        for l in &s.lights {
            if let Light::Point { position, .. } = l {
                assert!(inside(*position), "{name}: light outside");
            }
        }
    }
}
