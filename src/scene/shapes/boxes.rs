//! Axis-aligned boxes: closed, with faces left out, or with a hole (a
//! window) in one face.

use super::{divisions, lerp_step, MeshBuilder};
use glam::Vec3;

impl MeshBuilder {
    /// An axis-aligned box with `n_per_edge` quads along every edge.
    #[cfg(any(test, feature = "internals"))]
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
}
