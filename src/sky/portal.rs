//! Sky portals: next-event rays toward the openings through which a room
//! sees the sky (a window), so that sky light through a small opening is
//! not left to the few link rays that happen to leave through it.
//!
//! A portal is a parallelogram (`[sky] portals` in the scene file: four
//! corners, metres) over an opening. The directions from a vertex `x` are
//! split in two: those whose ray from `x` crosses a portal, and the rest.
//! The rest keep the link rays' estimate ([`super::visibility`],
//! [`super::refine`]: a missed ray through a portal counts as a hit there).
//! The portal directions are integrated by sampling the portal's area:
//! `m = side^2` points `q_j`, one jittered in each cell of a `side x side`
//! grid over the parallelogram, each one a shadow ray from `x` toward `q_j`
//! that must leave the scene (an any-hit ray to infinity, so what stands
//! outside the window still shades it), giving
//!
//! ```text
//! E_portal(x) = 1/m * sum_j V_j L(w_j) cos_x cos_p A / r^2      (W/m^2)
//! ```
//!
//! with `w_j = (q_j - x) / r`, `r = |q_j - x|`, `cos_x = n_x . w_j` (0 when
//! negative), `cos_p = |n_p . w_j|` and `A` the portal's area (m^2); `L` in
//! W/(m^2 sr). A direction that crosses two portals belongs to the first
//! (a sample of a later portal whose ray crosses an earlier one counts 0),
//! so overlapping portals never count a direction twice. Both parts are
//! unbiased, so their sum is too, whatever the portals cover: a portal over
//! only part of an opening (or over a wall) costs variance, never bias.
//!
//! Stored: one bit a sample (it reached the sky), `u64` per vertex and
//! portal (`m <= 64`); the points come back from a hash of the seed, the
//! vertex, the portal and the cell, so a changed, rotated or rescaled sky
//! is integrated again without tracing, exactly as re-shooting would.
//! Moving or adding a portal traces its samples again
//! (`Solver::update_portals`). Portals stay where the
//! scene file puts them when meshes deform.
//!
//! The portals' part is left unsmoothed (the link rays' part keeps its
//! noise-aware smoothing): it is stratified over the opening, so its noise
//! is low and what varies from vertex to vertex is the window's shadow
//! edges. Smoothing it with a variance estimated from neighbouring cells
//! (`(Y_j - Y_k)^2 / 2`, an upper bound) made `window`'s `E_sky` worse
//! (4.25% -> 4.58% relative RMSE at 64 samples).
//!
//! Measured on `window` (16384-path reference, total relative RMSE, auto
//! bounces, seed 1; `cargo test --release --test measured -- --ignored portals_lower_window_error` checks 64 rays
//! against `--off sky_portals`), link rays 16 / 64 / 256 /
//! 1024: without portals 13.6 / 5.17 / 2.98 / 1.94%; with 64 portal
//! samples 9.6 / 4.42 / 2.93 / 1.95% (`E_sky` alone 28.8% -> 4.2% at 64
//! rays). With 16 samples `E_sky` reads 10.3% (total 4.52% at 64 rays).
//! Combining the two estimators by multiple importance sampling instead
//! of splitting the directions was worse: the balance heuristic read
//! `E_sky` 15.7% (16 samples) and 6.3% (64) at 64 rays and 4.8% at 1024
//! (64 samples), the power heuristic 13.4% (16, 64 rays), the maximum
//! heuristic 19.8%: the portal's samples are stratified over the opening
//! and the link rays over the hemisphere, whose cells the window's edges
//! cut, so weighting in the link rays adds their edge noise.
//!
//! Deviation from the paper: the paper has no sky. Portals are the
//! renderers' name for the same thing (pbrt-v4's portal of an image
//! light, Cycles' portal lights).

use crate::trace::ray::Ray;
use crate::links::RaySetup;
use crate::sampling::stream::Stream;
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// A parallelogram `corner + s edge_u + t edge_v`, `s, t` in `[0, 1]`, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Portal {
    /// One corner, metres.
    pub corner: Vec3,
    /// The edge from `corner` along `s`, metres.
    pub edge_u: Vec3,
    /// The edge from `corner` along `t`, metres.
    pub edge_v: Vec3,
}

impl Portal {
    /// The portal with corners `c` in order around it; they must form a
    /// parallelogram (`c0 + c2 = c1 + c3` within 1e-4 of its size) of
    /// non-zero area, with finite coordinates.
    pub fn from_corners(c: [Vec3; 4]) -> Result<Portal, String> {
        if c.iter().any(|p| !p.is_finite()) {
            return Err(format!("portal corners {c:?} are not all finite"));
        }
        let p = Portal { corner: c[0], edge_u: c[1] - c[0], edge_v: c[3] - c[0] };
        let size = p.edge_u.length().max(p.edge_v.length());
        let off = (c[0] + c[2] - c[1] - c[3]).length();
        if off > 1e-4 * size {
            return Err(format!(
                "portal corners {c:?} are not a parallelogram (c0 + c2 - c1 - c3 is {off} m long; give them in order around it)"
            ));
        }
        p.validate()?;
        Ok(p)
    }

    /// The corners in order around the portal.
    pub fn corners(&self) -> [Vec3; 4] {
        [self.corner, self.corner + self.edge_u, self.corner + self.edge_u + self.edge_v, self.corner + self.edge_v]
    }

    /// Area, m^2.
    pub fn area(&self) -> f32 {
        self.edge_u.cross(self.edge_v).length()
    }

    /// Unit normal (`edge_u x edge_v`).
    pub fn normal(&self) -> Vec3 {
        self.edge_u.cross(self.edge_v).normalize_or_zero()
    }

    /// Finite, with an area above `1e-6` of its longest edge squared.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.corner.is_finite() && self.edge_u.is_finite() && self.edge_v.is_finite()) {
            return Err(format!("portal {self:?} is not finite"));
        }
        let size = self.edge_u.length().max(self.edge_v.length());
        if !(self.area() > 1e-6 * size * size) || size == 0.0 {
            return Err(format!("portal with corners {:?} has no area", self.corners()));
        }
        Ok(())
    }

    /// The point of the portal at parameters `(s, t)` in the unit square.
    pub fn point(&self, st: Vec2) -> Vec3 {
        self.corner + st.x * self.edge_u + st.y * self.edge_v
    }

    /// The distance (m) at which the ray from `p` along unit `d` crosses
    /// the portal, if it does at a distance above zero.
    pub fn crossing(&self, p: Vec3, d: Vec3) -> Option<f32> {
        let n = self.edge_u.cross(self.edge_v);
        let denom = d.dot(n);
        if denom == 0.0 {
            return None;
        }
        let t = (self.corner - p).dot(n) / denom;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let q = p + t * d - self.corner;
        let nn = n.length_squared();
        let s = q.cross(self.edge_v).dot(n) / nn;
        let u = self.edge_u.cross(q).dot(n) / nn;
        ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&u)).then_some(t)
    }

    /// Whether the ray from `p` along unit `d` crosses the portal.
    pub fn crossed_by(&self, p: Vec3, d: Vec3) -> bool {
        self.crossing(p, d).is_some()
    }

    /// Density per steradian of a point drawn uniformly on the portal,
    /// seen from `p` along unit `d` crossing it at distance `t`: `t^2 / (A cos_p)`.
    fn solid_angle_density(&self, d: Vec3, t: f32) -> f32 {
        t * t / (self.area() * self.normal().dot(d).abs())
    }
}

/// Whether the ray from `p` along unit `d` crosses any of `portals`.
pub fn through_any(portals: &[Portal], p: Vec3, d: Vec3) -> bool {
    portals.iter().any(|q| q.crossed_by(p, d))
}

/// How many rays each vertex sends toward each portal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PortalParams {
    /// Samples per vertex and portal, `side^2` (rounded down to a square,
    /// at most `MAX_SIDE`^2); at least 1 (the `sky_portals` term switches
    /// portals off: the link rays alone then integrate every direction). [`PortalParams::for_link_rays`]
    /// scales it with the link rays; 64 by default.
    pub rays: u32,
}

impl PortalParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: PortalParams = Self { rays: 64 };
}

impl Default for PortalParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The largest side of a portal's sample grid (256 samples).
pub const MAX_SIDE: u32 = 16;

impl PortalParams {
    /// Cells a side of the sample grid.
    pub fn side(&self) -> u32 {
        ((self.rays.min(MAX_SIDE * MAX_SIDE) as f64).sqrt().floor() as u32).min(MAX_SIDE)
    }

    /// A quarter of `link_rays` a vertex and portal, between 64 and 256,
    /// so the portals' noise keeps falling with the link rays' (see the
    /// module doc's figures).
    pub const fn for_link_rays(link_rays: u32) -> PortalParams {
        let rays = link_rays / 4;
        let rays = if rays < 64 {
            64
        } else if rays > MAX_SIDE * MAX_SIDE {
            MAX_SIDE * MAX_SIDE
        } else {
            rays
        };
        PortalParams { rays }
    }
}

/// Which portal samples of every vertex reached the sky.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PortalSamples {
    /// The portals the samples were traced for (empty: none).
    pub portals: Vec<Portal>,
    /// Cells a side of each portal's sample grid.
    pub side: u32,
    /// Bit `j % 64` of `masks[(v * portals.len() + p) * words + j / 64]`:
    /// sample `j` of vertex `v` toward portal `p` left the scene.
    pub masks: Vec<u64>,
    /// Mask words a vertex and portal, `ceil(side^2 / 64)`.
    pub words: usize,
    /// Shadow rays traced.
    pub rays: u64,
    /// Time spent, ms.
    pub ms: f64,
}

/// One portal sample: its unit direction, `cos_x` at the receiver and the
/// density per steradian of one point drawn on its portal, `t^2 / (A cos_p)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sample {
    pub dir: Vec3,
    pub cos_x: f32,
    pub density: f32,
}

/// A vertex the samples start from: its index, position and unit normal.
#[derive(Clone, Copy, Debug)]
struct Receiver {
    v: usize,
    x: Vec3,
    n: Vec3,
}

/// Sample `j` of receiver `r` toward portal `p` of `portals` (a `side x
/// side` grid), or `None` when it counts 0 whatever the scene (behind the
/// receiver, or a direction of an earlier portal).
fn sample(portals: &[Portal], p: usize, side: u32, j: u32, r: Receiver, seed: u64) -> Option<Sample> {
    let Receiver { v, x, n } = r;
    let h = Stream::PORTALS.hash(seed, &[v as u64, p as u64, u64::from(j)]);
    sample_jittered(portals, p, side, j, x, n, h)
}

/// Sample `j` of the point `x` (unit normal `n`) toward portal `p` of
/// `portals`, jittered in its cell of the `side x side` grid by the hash
/// `h`; `None` when it counts 0 whatever the scene. Its part of `E` is
/// `L(dir) * cos_x / density / side^2`.
pub(crate) fn sample_jittered(
    portals: &[Portal],
    p: usize,
    side: u32,
    j: u32,
    x: Vec3,
    n: Vec3,
    h: u64,
) -> Option<Sample> {
    let jitter = Vec2::new((h as u32) as f32, (h >> 32) as u32 as f32) * (1.0 / 4294967296.0);
    let cell = Vec2::new((j % side) as f32, (j / side) as f32);
    let portal = &portals[p];
    let q = portal.point((cell + jitter) / side as f32);
    let d = q - x;
    let t = d.length();
    if !(t > 0.0 && t.is_finite()) {
        return None;
    }
    let dir = d / t;
    let cos_x = n.dot(dir);
    if !(cos_x > 0.0) || portals[..p].iter().any(|e| e.crossed_by(x, dir)) {
        return None;
    }
    let density = portal.solid_angle_density(dir, t);
    (density.is_finite() && density > 0.0).then_some(Sample { dir, cos_x, density })
}

impl PortalSamples {
    /// Traces every vertex's samples toward `portals` with `tracer`, from
    /// the link rays' origins (`setup`; the links' `seed`); empty without
    /// portals or with `params.rays` below 1.
    pub fn compute(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        setup: &RaySetup,
        portals: &[Portal],
        seed: u64,
        params: &PortalParams,
    ) -> crate::Result<PortalSamples> {
        let start = Instant::now();
        let side = params.side();
        if portals.is_empty() || side == 0 {
            return Ok(PortalSamples::default());
        }
        let (n, np, m) = (scene.vertex_count(), portals.len(), side * side);
        let words = (m as usize).div_ceil(64);
        let mut masks = vec![0u64; n * np * words];
        let mut rays = 0u64;
        let per_vertex = np * m as usize;
        let batch_vertices = ((1usize << 20) / per_vertex).max(1);
        for v0 in (0..n).step_by(batch_vertices) {
            let v1 = (v0 + batch_vertices).min(n);
            // Per sample: its mask slot and bit, and its ray (none: counts 0 or dives under the surface).
            let batch: Vec<(usize, u32, Ray)> = (v0..v1)
                .into_par_iter()
                .flat_map_iter(|v| {
                    let (x, nv) = (scene.positions[v], scene.normals[v]);
                    (0..np).flat_map(move |p| {
                        (0..m).filter_map(move |j| {
                            let dir = sample(portals, p, side, j, Receiver { v, x, n: nv }, seed)?.dir;
                            if setup.wedges(v).iter().any(|w| w.dives_under(dir)) {
                                return None;
                            }
                            let ray =
                                Ray { origin: setup.origins[v], dir, tmin: 0.0, tmax: f32::INFINITY, skip: v as u32 };
                            Some(((v * np + p) * words + j as usize / 64, j % 64, ray))
                        })
                    })
                })
                .collect();
            let traced: Vec<Ray> = batch.iter().map(|b| b.2).collect();
            rays += traced.len() as u64;
            let visible = tracer.visible(&traced)?;
            for ((slot, j, _), vis) in batch.into_iter().zip(visible) {
                if vis {
                    masks[slot] |= 1 << j;
                }
            }
        }
        Ok(PortalSamples {
            portals: portals.to_vec(),
            side,
            masks,
            words,
            rays,
            ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// True when there are no portal samples.
    pub fn is_empty(&self) -> bool {
        self.portals.is_empty()
    }

    /// Bytes held.
    #[cfg(any(feature = "cli", feature = "internals"))]
    pub fn bytes(&self) -> u64 {
        std::mem::size_of_val(self.masks.as_slice()) as u64
    }

    /// Checks the structure against `n` vertices: one mask (of `words`
    /// words) per vertex and portal, no bit beyond `side^2` samples, valid
    /// portals.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.is_empty() {
            return if self.masks.is_empty() { Ok(()) } else { Err("masks without portals".into()) };
        }
        let m = (self.side * self.side) as usize;
        if self.side == 0
            || self.side > MAX_SIDE
            || self.words != m.div_ceil(64)
            || self.masks.len() != n * self.portals.len() * self.words
        {
            return Err(format!(
                "{} masks of {} words for {n} vertices, {} portals, side {}",
                self.masks.len(),
                self.words,
                self.portals.len(),
                self.side
            ));
        }
        for p in &self.portals {
            p.validate()?;
        }
        let last = m - 64 * (self.words - 1); // bits used in each mask's last word
        if last < 64 && self.masks.chunks(self.words).any(|w| w[self.words - 1] >> last != 0) {
            return Err(format!("mask bits beyond {m} samples"));
        }
        Ok(())
    }

    /// The portals' part of `E_sky` of every vertex under `sky`, W/m^2
    /// (see the module doc); `positions` and unit `normals` are the
    /// vertices', `seed` the links'. The link rays' part is
    /// [`super::SkyRefinement::irradiance`] or
    /// [`super::SkyVisibility::irradiance_and_moment`].
    pub fn irradiance(&self, sky: &super::Sky, positions: &[Vec3], normals: &[Vec3], seed: u64) -> Vec<Vec3> {
        let n = positions.len();
        if self.is_empty() {
            return vec![Vec3::ZERO; n];
        }
        let radiance = sky.radiance_fn();
        let (np, side) = (self.portals.len(), self.side);
        let m = side * side;
        (0..n)
            .into_par_iter()
            .map(|v| {
                let mut e = Vec3::ZERO;
                for p in 0..np {
                    let base = (v * np + p) * self.words;
                    let mask = &self.masks[base..base + self.words];
                    for j in (0..m).filter(|&j| mask[(j / 64) as usize] >> (j % 64) & 1 == 1) {
                        if let Some(smp) =
                            sample(&self.portals, p, side, j, Receiver { v, x: positions[v], n: normals[v] }, seed)
                        {
                            e += radiance(smp.dir) * (smp.cos_x / smp.density);
                        }
                    }
                }
                e / m as f32
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> Portal {
        Portal::from_corners([
            Vec3::new(2.0, 0.75, -1.0),
            Vec3::new(2.0, 2.0, -1.0),
            Vec3::new(2.0, 2.0, 1.0),
            Vec3::new(2.0, 0.75, 1.0),
        ])
        .unwrap()
    }

    #[test]
    fn corners_must_form_a_parallelogram_with_area() {
        let p = window();
        assert!((p.area() - 2.5).abs() < 1e-6);
        assert_eq!(p.corners()[2], Vec3::new(2.0, 2.0, 1.0));
        let skew = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.3), Vec3::Y];
        assert!(Portal::from_corners(skew).unwrap_err().contains("parallelogram"));
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X];
        assert!(Portal::from_corners(flat).unwrap_err().contains("no area"));
        let nan = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, f32::NAN, 0.0), Vec3::Y];
        assert!(Portal::from_corners(nan).unwrap_err().contains("finite"));
    }

    #[test]
    fn crossing_follows_the_parallelogram_and_the_ray_direction() {
        let p = window();
        let x = Vec3::new(0.0, 1.0, 0.0);
        assert!(p.crossed_by(x, Vec3::X));
        assert!(!p.crossed_by(x, -Vec3::X), "behind the ray's origin");
        assert!(!p.crossed_by(x, Vec3::Y), "parallel to the portal");
        assert!(!p.crossed_by(x, (Vec3::new(2.0, 2.1, 0.0) - x).normalize()), "above the top edge");
        assert!(p.crossed_by(x, (Vec3::new(2.0, 1.9, 0.99) - x).normalize()));
        assert!(!p.crossed_by(x, (Vec3::new(2.0, 1.9, 1.01) - x).normalize()));
    }

    /// Seen from far away on its axis, a portal of area `A` at distance `r`
    /// gives `E = L A / r^2` to a receiver facing it; its samples all cross
    /// it, and an earlier, identical portal takes every one of them.
    #[test]
    fn samples_integrate_the_solid_angle_and_give_way_to_earlier_portals() {
        let p = window();
        let x = Vec3::new(-200.0, 1.375, 0.0);
        let n = Vec3::X;
        let side = 4;
        let (mut sum, mut crossed) = (0.0f32, 0);
        for j in 0..side * side {
            let smp = sample(&[p], 0, side, j, Receiver { v: 7, x, n }, 3).unwrap();
            sum += smp.cos_x / (smp.density * (side * side) as f32);
            crossed += p.crossed_by(x, smp.dir) as u32;
        }
        let want = p.area() / 202.0f32.powi(2); // the portal is at x = 2
        assert!((sum / want - 1.0).abs() < 1e-3, "{sum} against {want}");
        assert_eq!(crossed, side * side);
        assert!((0..side * side).all(|j| sample(&[p, p], 1, side, j, Receiver { v: 7, x, n }, 3).is_none()));
        assert!(
            (0..side * side).all(|j| sample(&[p], 0, side, j, Receiver { v: 7, x, n: -n }, 3).is_none()),
            "behind the receiver"
        );
    }
}
