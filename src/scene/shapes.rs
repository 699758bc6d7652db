//! Tessellated primitives for building scenes in code.
//!
//! A [`MeshBuilder`] collects positions, counter-clockwise triangles and
//! materials, and [`MeshBuilder::finish`] turns them into a [`MeshDesc`].
//! Every primitive winds its triangles so that the front face (normal
//! `(b - a) x (c - a)`) points outward, unless an `inward` flag asks for the
//! opposite (rooms, the furnace sphere).
//!
//! Primitives do not share vertices with each other; where two pieces of one
//! primitive meet (the faces of a cuboid, the caps of a cylinder) their shared
//! positions are bit-identical, so the exact-position weld of mesh
//! preparation joins them. Pieces of different primitives in one mesh must
//! not share positions, so that no weld joins them by accident: they may
//! overlap, or one may end on the face of another (a leg ending at the
//! underside of a table top), as long as no vertex of one coincides with a
//! vertex of the other. Faces that would lie hidden against another surface
//! (the bottom of a box standing on the floor, the top of a table leg) are
//! left out rather than buried: [`MeshBuilder::cuboid_open`] takes an optional material per face
//! and [`MeshBuilder::cylinder_caps`] a flag per cap; the surface is then
//! open there, still consistently wound. No primitive produces zero-area
//! triangles: poles are single vertices with triangle fans, and
//! [`MeshBuilder::add_triangle`] drops any degenerate triangle that a
//! caller's parametric function would create.

use super::{Material, MeshDesc, Transform};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::f32::consts::TAU;

/// Accumulates one triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    pub materials: Vec<Material>,
}

/// Coordinate `i` of `n` equal steps from `lo` to `hi`; the ends are exactly
/// `lo` and `hi`, and the same inputs always give the same bits, so grids
/// built from the same bounds agree where they meet.
fn lerp_step(lo: f32, hi: f32, i: u32, n: u32) -> f32 {
    if i == 0 {
        lo
    } else if i == n {
        hi
    } else {
        lo + (hi - lo) * (i as f32 / n as f32)
    }
}

/// Bit pattern of a position, with -0.0 folded into +0.0.
fn key(p: Vec3) -> [u32; 3] {
    [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
}

impl MeshBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, name: &str, albedo: Vec3) -> u32 {
        self.materials.push(Material { name: name.to_string(), albedo, emission: Vec3::ZERO });
        (self.materials.len() - 1) as u32
    }

    /// Adds a position and returns its index.
    pub fn add_vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Adds the counter-clockwise triangle `(a, b, c)`. A triangle with a
    /// repeated corner, or whose area is negligible against its longest edge
    /// (ratio below 1e-6), is dropped; returns whether it was added.
    pub fn add_triangle(&mut self, a: u32, b: u32, c: u32, mat: u32) -> bool {
        if a == b || b == c || a == c {
            return false;
        }
        let (pa, pb, pc) = (self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]);
        let cross = (pb - pa).cross(pc - pa).length();
        let longest = (pb - pa).length_squared().max((pc - pb).length_squared()).max((pa - pc).length_squared());
        if cross.is_nan() || cross <= 1e-6 * longest {
            return false;
        }
        self.triangles.push([a, b, c]);
        self.triangle_material.push(mat);
        true
    }

    /// Applies `f` to every position from index `first` on (for example to
    /// rotate and place a primitive just added: note `first = positions.len()`
    /// before adding it). `f` must preserve orientation (no mirroring).
    pub fn transform_from(&mut self, first: usize, f: impl Fn(Vec3) -> Vec3) {
        for p in &mut self.positions[first..] {
            *p = f(*p);
        }
    }

    /// Reverses the winding of every triangle from index `first` on.
    pub fn flip_from(&mut self, first: usize) {
        for t in &mut self.triangles[first..] {
            t.swap(1, 2);
        }
    }

    /// The mesh, with the default transform, not dynamic, no source file.
    /// Negative zeros in positions are replaced by positive zeros so that an
    /// exact-position weld sees equal points as equal.
    pub fn finish(self, name: &str, crease_angle_deg: f32) -> MeshDesc {
        MeshDesc {
            name: name.to_string(),
            positions: self.positions.into_iter().map(|p| p + Vec3::ZERO).collect(),
            triangles: self.triangles,
            triangle_material: self.triangle_material,
            materials: self.materials,
            vertex_albedo: None,
            crease_angle_deg,
            transform: Transform::default(),
            dynamic: false,
            deform: Vec::new(),
            source: None,
        }
    }

    /// Adds a grid of `f(u, v)` over `u = i / nu`, `v = j / nv` and returns
    /// the index of its first position. The front faces along
    /// `df/du x df/dv`. With `wrap_u` the column `u = 1` is the column
    /// `u = 0` (f is not evaluated at `u = 1`), likewise `wrap_v`. Points
    /// where `f` returns bit-identical positions (a pole where every `u`
    /// gives the same point, e.g. by testing `v == 0.0`) become one vertex,
    /// and the triangles that collapse there are dropped.
    pub fn parametric(
        &mut self,
        nu: u32,
        nv: u32,
        f: impl Fn(f32, f32) -> Vec3,
        wrap_u: bool,
        wrap_v: bool,
        mat: u32,
    ) -> u32 {
        let (nu, nv) = (nu.max(1), nv.max(1));
        let first = self.positions.len() as u32;
        let cols = if wrap_u { nu } else { nu + 1 };
        let rows = if wrap_v { nv } else { nv + 1 };
        let mut seen: HashMap<[u32; 3], u32> = HashMap::new();
        let mut index = Vec::with_capacity((cols * rows) as usize);
        for j in 0..rows {
            let v = lerp_step(0.0, 1.0, j, nv);
            for i in 0..cols {
                let u = lerp_step(0.0, 1.0, i, nu);
                let p = f(u, v);
                let id = *seen.entry(key(p)).or_insert_with(|| {
                    self.positions.push(p);
                    (self.positions.len() - 1) as u32
                });
                index.push(id);
            }
        }
        let at = |i: u32, j: u32| index[((j % rows) * cols + (i % cols)) as usize];
        for j in 0..nv {
            for i in 0..nu {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                self.add_triangle(a, b, c, mat);
                self.add_triangle(a, c, d, mat);
            }
        }
        first
    }

    /// A flat grid of `nu x nv` quads (two triangles each) spanning
    /// `origin + s * edge_u + t * edge_v`, s, t in [0, 1]; the front faces
    /// along `edge_u x edge_v`.
    pub fn quad_grid(&mut self, origin: Vec3, edge_u: Vec3, edge_v: Vec3, nu: u32, nv: u32, mat: u32) {
        let (nu, nv) = (nu.max(1), nv.max(1));
        let base = self.positions.len() as u32;
        for j in 0..=nv {
            let t = lerp_step(0.0, 1.0, j, nv);
            for i in 0..=nu {
                let s = lerp_step(0.0, 1.0, i, nu);
                self.positions.push(origin + edge_u * s + edge_v * t);
            }
        }
        let at = |i: u32, j: u32| base + j * (nu + 1) + i;
        for j in 0..nv {
            for i in 0..nu {
                self.add_triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1), mat);
                self.add_triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1), mat);
            }
        }
    }

    /// An axis-aligned box with `n_per_edge` quads along every edge.
    pub fn cuboid(&mut self, min: Vec3, max: Vec3, n_per_edge: u32, mat: u32, inward: bool) {
        self.cuboid_faces(min, max, [n_per_edge; 3], [mat; 6], inward);
    }

    /// An axis-aligned box with about `spacing` between grid lines (at least
    /// one quad per edge).
    pub fn cuboid_spaced(&mut self, min: Vec3, max: Vec3, spacing: f32, mat: u32, inward: bool) {
        self.cuboid_faces(min, max, divisions(max - min, spacing), [mat; 6], inward);
    }

    /// An axis-aligned box with `res[k]` quads along its edges parallel to
    /// axis k and material `mats[f]` on face f, faces ordered
    /// -x, +x, -y, +y, -z, +z. Every face grid takes its coordinates from the
    /// same `min` and `max`, so edges and corners shared by two faces have
    /// bit-identical positions.
    pub fn cuboid_faces(&mut self, min: Vec3, max: Vec3, res: [u32; 3], mats: [u32; 6], inward: bool) {
        self.cuboid_open(min, max, res, mats.map(Some), inward);
    }

    /// [`MeshBuilder::cuboid_faces`] with face f left out where `mats[f]` is
    /// `None` (faces ordered -x, +x, -y, +y, -z, +z), e.g. the hidden bottom
    /// of a box resting on the floor. The box is then open there: the edges
    /// around a missing face are borders, each used by one triangle.
    pub fn cuboid_open(&mut self, min: Vec3, max: Vec3, res: [u32; 3], mats: [Option<u32>; 6], inward: bool) {
        self.cuboid_holed(min, max, res, mats, inward, None);
    }

    /// [`MeshBuilder::cuboid_open`] with a rectangular hole (a window) in
    /// one face: `hole = (face, cells)` leaves out the grid cells `(i, j)`
    /// of that face with `cells[0] <= i < cells[1]` and
    /// `cells[2] <= j < cells[3]` (i along the face's first in-plane axis
    /// `(a + 1) % 3`, j along `(a + 2) % 3`, for a face normal to axis a).
    pub fn cuboid_holed(
        &mut self,
        min: Vec3,
        max: Vec3,
        res: [u32; 3],
        mats: [Option<u32>; 6],
        inward: bool,
        hole: Option<(usize, [u32; 4])>,
    ) {
        let res = res.map(|n| n.max(1));
        let (lo, hi) = (min.to_array(), max.to_array());
        for a in 0..3 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            for side in 0..2 {
                let Some(mat) = mats[2 * a + side] else { continue };
                let fixed = if side == 0 { lo[a] } else { hi[a] };
                // e_b x e_c = e_a: the grid's natural front faces +a.
                let flip = (side == 0) != inward;
                let base = self.positions.len() as u32;
                for j in 0..=res[c] {
                    for i in 0..=res[b] {
                        let mut p = [0.0f32; 3];
                        p[a] = fixed;
                        p[b] = lerp_step(lo[b], hi[b], i, res[b]);
                        p[c] = lerp_step(lo[c], hi[c], j, res[c]);
                        self.positions.push(Vec3::from_array(p));
                    }
                }
                let at = |i: u32, j: u32| base + j * (res[b] + 1) + i;
                for j in 0..res[c] {
                    for i in 0..res[b] {
                        if let Some((face, [i0, i1, j0, j1])) = hole {
                            if face == 2 * a + side && (i0..i1).contains(&i) && (j0..j1).contains(&j) {
                                continue;
                            }
                        }
                        let (p, q, r, s) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                        if flip {
                            self.add_triangle(p, r, q, mat);
                            self.add_triangle(p, s, r, mat);
                        } else {
                            self.add_triangle(p, q, r, mat);
                            self.add_triangle(p, r, s, mat);
                        }
                    }
                }
            }
        }
    }

    /// A geodesic sphere: an icosahedron whose faces are split 1:4
    /// `subdivisions` times, `10 * 4^s + 2` vertices, all projected onto the
    /// sphere. Edge midpoints are shared, so the surface is closed.
    pub fn icosphere(&mut self, center: Vec3, radius: f32, subdivisions: u32, mat: u32, inward: bool) {
        let t = (1.0 + 5.0f32.sqrt()) / 2.0;
        let mut verts: Vec<Vec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
            let mut midpoint = |a: u32, b: u32, verts: &mut Vec<Vec3>| -> u32 {
                let k = (a.min(b), a.max(b));
                *mid.entry(k).or_insert_with(|| {
                    verts.push(((verts[a as usize] + verts[b as usize]) * 0.5).normalize());
                    (verts.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for &[a, b, c] in &faces {
                let ab = midpoint(a, b, &mut verts);
                let bc = midpoint(b, c, &mut verts);
                let ca = midpoint(c, a, &mut verts);
                next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        let base = self.positions.len() as u32;
        self.positions.extend(verts.iter().map(|&v| center + v * radius));
        for [a, b, c] in faces {
            if inward {
                self.add_triangle(base + a, base + c, base + b, mat);
            } else {
                self.add_triangle(base + a, base + b, base + c, mat);
            }
        }
    }

    /// A surface of revolution about the vertical axis through `center`.
    /// `profile` holds `(r, y)` points (radius from the axis, height above
    /// `center`); walking along it in the (r, y) plane with r to the right
    /// and y up, the front faces the walker's right-hand side. A point with
    /// `r == 0.0` is a pole (one vertex, a triangle fan). With `closed_loop`
    /// the last point joins the first. `segments` vertices per ring.
    pub fn revolve(&mut self, center: Vec3, profile: &[Vec2], segments: u32, mat: u32, closed_loop: bool) {
        self.revolve_with(center, profile, segments, |_| mat, closed_loop);
    }

    /// [`MeshBuilder::revolve`] with material `mat(k)` on the band between
    /// profile points `k` and `k + 1` (the last band of a closed loop is
    /// `k = profile.len() - 1`), so one seamless surface can carry several
    /// materials (a cup on its saucer).
    pub fn revolve_with(
        &mut self,
        center: Vec3,
        profile: &[Vec2],
        segments: u32,
        mat: impl Fn(usize) -> u32,
        closed_loop: bool,
    ) {
        let segments = segments.max(3);
        let trig: Vec<(f32, f32)> = (0..segments)
            .map(|j| {
                let a = TAU * j as f32 / segments as f32;
                (a.cos(), a.sin())
            })
            .collect();
        // First vertex of each ring (a pole has one vertex).
        let rings: Vec<(u32, bool)> = profile
            .iter()
            .map(|q| {
                let first = self.positions.len() as u32;
                if q.x == 0.0 {
                    self.positions.push(center + Vec3::new(0.0, q.y, 0.0));
                    (first, true)
                } else {
                    for &(c, s) in &trig {
                        self.positions.push(center + Vec3::new(q.x * c, q.y, q.x * s));
                    }
                    (first, false)
                }
            })
            .collect();
        let at = |(first, pole): (u32, bool), j: u32| if pole { first } else { first + j % segments };
        let n = rings.len();
        let spans = if closed_loop { n } else { n.saturating_sub(1) };
        for k in 0..spans {
            let (r0, r1) = (rings[k], rings[(k + 1) % n]);
            let m = mat(k);
            for j in 0..segments {
                let (a, b, c, d) = (at(r0, j), at(r0, j + 1), at(r1, j + 1), at(r1, j));
                self.add_triangle(a, d, c, m);
                self.add_triangle(a, c, b, m);
            }
        }
    }

    /// A cylinder along +y from `base_center`, `segments` around and `rings`
    /// bands along its height; with `caps`, closed by flat discs (split in
    /// rings so their triangles stay well shaped), else open at both ends.
    #[allow(clippy::too_many_arguments)]
    pub fn cylinder(
        &mut self,
        base_center: Vec3,
        radius: f32,
        height: f32,
        segments: u32,
        rings: u32,
        mat: u32,
        caps: bool,
    ) {
        self.cylinder_caps(base_center, radius, height, segments, rings, mat, caps, caps);
    }

    /// [`MeshBuilder::cylinder`] with the bottom disc (at `base_center`) and
    /// the top disc each present or left out on their own, e.g. no bottom
    /// for a post standing on the floor.
    #[allow(clippy::too_many_arguments)]
    pub fn cylinder_caps(
        &mut self,
        base_center: Vec3,
        radius: f32,
        height: f32,
        segments: u32,
        rings: u32,
        mat: u32,
        bottom: bool,
        top: bool,
    ) {
        let rings = rings.max(1);
        let cap_rings = ((segments as f32 / TAU).round() as u32).max(1);
        let mut profile = Vec::new();
        if bottom {
            for k in 0..cap_rings {
                profile.push(Vec2::new(lerp_step(0.0, radius, k, cap_rings), 0.0));
            }
        }
        for k in 0..=rings {
            profile.push(Vec2::new(radius, lerp_step(0.0, height, k, rings)));
        }
        if top {
            for k in (0..cap_rings).rev() {
                profile.push(Vec2::new(lerp_step(0.0, radius, k, cap_rings), height));
            }
        }
        self.revolve(base_center, &profile, segments, mat, false);
    }

    /// An open cone frustum along +y from `base_center`: radius
    /// `radius_bottom` at the base, `radius_top` at `height`. Faces away
    /// from the axis, or towards it with `inward`.
    #[allow(clippy::too_many_arguments)]
    pub fn frustum(
        &mut self,
        base_center: Vec3,
        radius_bottom: f32,
        radius_top: f32,
        height: f32,
        segments: u32,
        rings: u32,
        mat: u32,
        inward: bool,
    ) {
        let rings = rings.max(1);
        let mut profile: Vec<Vec2> = (0..=rings)
            .map(|k| Vec2::new(lerp_step(radius_bottom, radius_top, k, rings), lerp_step(0.0, height, k, rings)))
            .collect();
        if inward {
            profile.reverse();
        }
        self.revolve(base_center, &profile, segments, mat, false);
    }

    /// A hemispherical bowl hanging below `rim_center`: an outer half sphere
    /// of `radius`, an inner one of `radius - thickness`, joined by a flat
    /// rim ring at the top. Closed: the outer surface faces out, the inner
    /// one faces into the bowl. `rings` bands per half sphere.
    pub fn bowl(&mut self, rim_center: Vec3, radius: f32, thickness: f32, segments: u32, rings: u32, mat: u32) {
        let rings = rings.max(2);
        let inner = radius - thickness;
        let mut profile = Vec::new();
        // Outer: from the bottom pole up to the rim.
        for k in 0..=rings {
            let a = std::f32::consts::FRAC_PI_2 * k as f32 / rings as f32;
            let (s, c) = if k == 0 {
                (0.0, 1.0)
            } else if k == rings {
                (1.0, 0.0)
            } else {
                a.sin_cos()
            };
            profile.push(Vec2::new(radius * s, -radius * c));
        }
        // Inner: from the rim down to the inner pole.
        for k in (0..=rings).rev() {
            let a = std::f32::consts::FRAC_PI_2 * k as f32 / rings as f32;
            let (s, c) = if k == 0 {
                (0.0, 1.0)
            } else if k == rings {
                (1.0, 0.0)
            } else {
                a.sin_cos()
            };
            profile.push(Vec2::new(inner * s, -inner * c));
        }
        self.revolve(rim_center, &profile, segments, mat, false);
    }

    /// A torus in the xz plane around `center`: `major_radius` to the tube's
    /// centre line, `minor_radius` of the tube; `segments_major` around the
    /// ring, `segments_minor` around the tube.
    pub fn torus(
        &mut self,
        center: Vec3,
        major_radius: f32,
        minor_radius: f32,
        segments_major: u32,
        segments_minor: u32,
        mat: u32,
    ) {
        self.parametric(
            segments_major,
            segments_minor,
            |u, v| {
                let (su, cu) = (TAU * u).sin_cos();
                let (sv, cv) = (TAU * v).sin_cos();
                let r = major_radius + minor_radius * cv;
                center + Vec3::new(r * cu, minor_radius * sv, -r * su)
            },
            true,
            true,
            mat,
        );
    }
}

/// Quads per axis for about `spacing` between grid lines, at least one.
pub fn divisions(extent: Vec3, spacing: f32) -> [u32; 3] {
    extent.to_array().map(|e| ((e.abs() / spacing).round() as u32).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
