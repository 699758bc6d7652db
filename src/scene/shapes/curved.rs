//! Curved primitives: the geodesic sphere, surfaces of revolution
//! (cylinder, frustum, bowl) and the torus.

use super::{lerp_step, MeshBuilder};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::f32::consts::TAU;

impl MeshBuilder {
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
    #[cfg(test)]
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
    #[cfg(test)]
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
