//! Tests of the primitives: closed, consistently wound, facing outward,
//! with the expected volume; open faces and caps leave the expected borders.

use super::*;
use glam::Vec2;
use std::f32::consts::TAU;

/// Signed volume (positive when a closed surface faces outward).
fn volume(b: &MeshBuilder) -> f32 {
    b.triangles
        .iter()
        .map(|t| {
            let [a, bb, c] = t.map(|i| b.positions[i as usize]);
            a.dot(bb.cross(c)) / 6.0
        })
        .sum()
}

/// Directed edge counts after welding exact positions: for each
/// undirected edge (lo, hi), how often it is used lo -> hi and hi -> lo.
fn edge_uses(b: &MeshBuilder) -> HashMap<(u32, u32), (u32, u32)> {
    let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
    let remap: Vec<u32> = b
        .positions
        .iter()
        .map(|&p| {
            let n = ids.len() as u32;
            *ids.entry(key(p)).or_insert(n)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for t in &b.triangles {
        for k in 0..3 {
            let (a, c) = (remap[t[k] as usize], remap[t[(k + 1) % 3] as usize]);
            let e = edges.entry((a.min(c), a.max(c))).or_insert((0, 0));
            if a < c {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    edges
}

/// Checks consistent winding (every edge used at most once in each
/// direction) and returns the number of border edges (used once).
fn border_edges(b: &MeshBuilder) -> usize {
    let edges = edge_uses(b);
    assert!(edges.values().all(|&(f, r)| f <= 1 && r <= 1), "edge used twice in one direction");
    edges.values().filter(|&&(f, r)| f + r == 1).count()
}

/// Number of edges not used equally often in each direction (0 when
/// closed and consistently oriented), after welding exact positions.
fn open_edges(b: &MeshBuilder) -> usize {
    edge_uses(b).values().filter(|&&(f, r)| f != r).count()
}

fn check(b: &MeshBuilder, expect: f32, closed: bool) {
    let v = volume(b);
    assert!((v - expect).abs() < 0.03 * expect.abs(), "volume {v}, expected {expect}");
    if closed {
        assert_eq!(open_edges(b), 0);
    }
    for t in &b.triangles {
        let [a, bb, c] = t.map(|i| b.positions[i as usize]);
        assert!((bb - a).cross(c - a).length() > 0.0);
    }
}

#[test]
fn primitives_are_closed_and_face_outward() {
    let pi = std::f32::consts::PI;
    let mut b = MeshBuilder::new();
    b.cuboid(Vec3::new(-1.0, 0.3, -0.2), Vec3::new(0.5, 1.0, 0.7), 5, 0, false);
    check(&b, 1.5 * 0.7 * 0.9, true);

    let mut b = MeshBuilder::new();
    b.cuboid_faces(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), [3, 4, 5], [0, 1, 2, 3, 4, 5], true);
    check(&b, -8.0, true);

    let mut b = MeshBuilder::new();
    b.icosphere(Vec3::new(0.2, 0.1, 0.0), 1.0, 4, 0, false);
    assert_eq!(b.positions.len(), 2562);
    check(&b, 4.0 / 3.0 * pi, true);
    let mut b = MeshBuilder::new();
    b.icosphere(Vec3::ZERO, 1.0, 3, 0, true);
    check(&b, -4.0 / 3.0 * pi, true);

    let mut b = MeshBuilder::new();
    b.cylinder(Vec3::new(0.0, 0.5, 0.0), 0.3, 2.0, 48, 5, 0, true);
    check(&b, pi * 0.09 * 2.0, true);

    let mut b = MeshBuilder::new();
    b.bowl(Vec3::ZERO, 1.0, 0.2, 64, 16, 0);
    check(&b, 2.0 / 3.0 * pi * (1.0 - 0.512), true);

    let mut b = MeshBuilder::new();
    b.torus(Vec3::new(0.0, 1.0, 0.0), 1.0, 0.25, 96, 32, 0);
    check(&b, 2.0 * pi * pi * 1.0 * 0.0625, true);

    // A sphere from `parametric` with exact poles.
    let mut b = MeshBuilder::new();
    b.parametric(
        48,
        24,
        |u, v| {
            if v == 0.0 {
                return Vec3::new(0.0, -1.0, 0.0);
            }
            if v == 1.0 {
                return Vec3::new(0.0, 1.0, 0.0);
            }
            let (st, ct) = (TAU * u).sin_cos();
            let (sp, cp) = (pi * v).sin_cos();
            Vec3::new(sp * ct, -cp, -sp * st)
        },
        true,
        false,
        0,
    );
    check(&b, 4.0 / 3.0 * pi, true);

    // Open primitives: faces left out leave borders, winding stays consistent.
    let mut b = MeshBuilder::new();
    let mut mats = [Some(0); 6];
    mats[2] = None;
    b.cuboid_open(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), [3, 4, 5], mats, false);
    assert_eq!(b.triangles.len(), 2 * (2 * 3 * 4 + 2 * 4 * 5 + 3 * 5));
    assert_eq!(border_edges(&b), 2 * (3 + 5));
    // The missing face lies in y = 0, so it adds nothing to the volume about the origin.
    check(&b, 8.0, false);
    assert!(b.positions.iter().all(|p| p.y >= 0.0));
    let mut b = MeshBuilder::new();
    mats[3] = None;
    b.cuboid_open(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 1.0), [2, 2, 2], mats, true);
    assert_eq!(b.triangles.len(), 2 * 4 * 4);
    assert_eq!(border_edges(&b), 2 * 2 * 4);

    let mut b = MeshBuilder::new();
    b.cylinder_caps(Vec3::ZERO, 0.3, 2.0, 24, 5, 0, false, true);
    assert_eq!(border_edges(&b), 24);
    assert!(b.positions.iter().all(|p| p.y >= 0.0));
    check(&b, pi * 0.09 * 2.0, false);
    let mut b = MeshBuilder::new();
    b.cylinder_caps(Vec3::ZERO, 0.3, 2.0, 24, 5, 0, false, false);
    assert_eq!(border_edges(&b), 48);
    assert_eq!(b.positions.len(), 6 * 24);
    let mut b = MeshBuilder::new();
    b.cylinder_caps(Vec3::ZERO, 0.3, 2.0, 24, 5, 0, true, true);
    let mut c = MeshBuilder::new();
    c.cylinder(Vec3::ZERO, 0.3, 2.0, 24, 5, 0, true);
    assert_eq!((b.positions, b.triangles), (c.positions, c.triangles));

    // revolve_with: one material per band.
    let mut b = MeshBuilder::new();
    let profile = [Vec2::new(0.5, 0.0), Vec2::new(0.5, 1.0), Vec2::new(0.0, 1.0)];
    b.revolve_with(Vec3::ZERO, &profile, 8, |k| k as u32 + 3, false);
    assert_eq!(b.triangle_material, [[3u32; 16].as_slice(), &[4; 8]].concat());
    assert_eq!(border_edges(&b), 8);

    // Frustum: open, outward normals point away from the axis.
    let mut b = MeshBuilder::new();
    b.frustum(Vec3::ZERO, 0.5, 0.3, 0.4, 24, 3, 0, false);
    let n = b.triangles.len();
    b.frustum(Vec3::ZERO, 0.45, 0.25, 0.4, 24, 3, 0, true);
    for (k, t) in b.triangles.iter().enumerate() {
        let [a, bb, c] = t.map(|i| b.positions[i as usize]);
        let nrm = (bb - a).cross(c - a);
        let radial = Vec3::new(a.x + bb.x + c.x, 0.0, a.z + bb.z + c.z);
        assert_eq!(nrm.dot(radial) > 0.0, k < n);
    }

    // quad_grid faces along edge_u x edge_v.
    let mut b = MeshBuilder::new();
    b.quad_grid(Vec3::ZERO, Vec3::X, Vec3::Z, 3, 2, 0);
    assert_eq!(b.triangles.len(), 12);
    for t in &b.triangles {
        let [a, bb, c] = t.map(|i| b.positions[i as usize]);
        assert!((bb - a).cross(c - a).y < 0.0);
    }
}
