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

mod boxes;
mod curved;
#[cfg(test)]
mod tests;

use super::{Material, MeshDesc, Transform};
use glam::Vec3;
use std::collections::HashMap;

/// Accumulates one triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct MeshBuilder {
    /// Positions, metres.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles (front face where the normal points).
    pub triangles: Vec<[u32; 3]>,
    /// Material index per triangle.
    pub triangle_material: Vec<u32>,
    /// The materials that `triangle_material` indexes.
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
    /// An empty mesh.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a material and returns its index.
    pub fn add_material(&mut self, name: &str, albedo: Vec3) -> u32 {
        self.materials.push(Material { name: name.to_string(), albedo, emission: Vec3::ZERO });
        (self.materials.len() - 1) as u32
    }

    /// Adds a position and returns its index.
    #[cfg(any(test, feature = "internals"))]
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
    #[cfg(any(test, feature = "internals"))]
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
            vertex_emission: None,
            textures: None,
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
    #[cfg(any(test, feature = "internals"))]
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
}

/// Quads per axis for about `spacing` between grid lines, at least one.
pub fn divisions(extent: Vec3, spacing: f32) -> [u32; 3] {
    extent.to_array().map(|e| ((e.abs() / spacing).round() as u32).max(1))
}
