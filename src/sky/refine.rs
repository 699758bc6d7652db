//! Sky refinement: more rays where a vertex's view of the sky has an edge,
//! so sky light through a window or a gap is not left to one ray per
//! stratum.
//!
//! A vertex's `n = k*k` link rays are one jittered ray in each cell of a
//! `k x k` grid over the unit square, mapped onto the cosine-weighted
//! hemisphere ([`crate::sampling::DirectionSet`]). Its sky estimate is the
//! stratified mean `E_sky = pi/n * sum_c X_c` (`X_c = L(w_c)` when ray `c`
//! left the scene, else 0; `L` in W/(m^2 sr), `E_sky` in W/m^2). Its
//! variance comes almost all from the cells an opening's edge crosses: a
//! cell wholly inside or outside the opening gives the same `X_c` whatever
//! its jitter. So a cell is **refined** when its grid neighbours (up to 8,
//! itself excluded) hold both a ray that left the scene and one that hit:
//! its `X_c` is replaced by the mean of `s*s` fresh any-hit rays, one
//! jittered in each of its `s x s` sub-cells (jitter hashed from the seed,
//! the direction set, the cell and the sub-cell: same seed, same rays).
//!
//! Unbiased: whether a cell is refined depends only on its neighbours' rays,
//! which are independent of its own, so a kept ray's expectation is
//! unchanged, and the fresh rays are independent of the choice.
//!
//! Variance, per channel: `(pi/n)^2 * sum_{refined c} var_c / s^2`, with
//! `var_c` the sample variance of the cell's fresh `X` (the sub-cells are
//! stratified, so this is an upper bound), plus `(pi/n)^2 L(w_c)^2 / 4`
//! for every kept cell unlike its neighbours (a lone miss among hits, a
//! window seen by one ray, or a lone hit among misses: an edge no
//! neighbour saw, whose `X_c` is a coin toss of variance `p (1 - p) L^2 <=
//! L^2 / 4`); other kept cells count 0. Measured on `window` (16384
//! reference paths, total relative RMSE; the term has no switch of its own:
//! `cargo test --release --test measured -- --ignored sky_smoothing_lowers_window_error` checks the smoothing it feeds,
//! 64 rays, portals off, 5.90 -> 5.19%, `E_sky` 39.4 -> 28.8% now): the
//! lone cells' term took 64 / 256 / 1024 rays from 5.49 / 2.99 / 1.95% to
//! 5.17 / 2.98 / 1.94% (`E_sky` alone 33.8% -> 28.8% at 64); a bound of
//! `L^2` (not a variance any cell can have) read 5.04%, `L^2 / 16` 5.36%. The solver
//! pools it over the ring and smooths `E_sky` with it
//! ([`crate::exchange::SmoothParams::sky`]).
//!
//! Stored: per vertex the refined cells (ray index) and one bit per fresh
//! ray (it missed), so any new sky is integrated again without tracing,
//! like [`super::visibility`]. Deviation from the paper: the paper has no
//! sky.

use super::portal::{through_any, Portal};
use super::visibility::{RayFrames, SkyVisibility};
use super::Sky;
use crate::csr::{Csr, RowBuilder};
use crate::trace::ray::Ray;
use crate::links::RaySetup;
use crate::sampling::stream::Stream;
use crate::sampling::{block_order, cosine_hemisphere, vertex_frame, world_direction};
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of the sky refinement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyRefineParams {
    /// Sub-cells a side of a refined cell: `sub * sub` fresh rays replace
    /// its one ray (1 to `MAX_SUB`; the `sky_refine` term switches
    /// refinement off).
    pub sub: u32,
    /// Rays from each vertex toward each of the sky's portals (`super::portal`).
    pub portal: super::PortalParams,
}

/// The largest [`SkyRefineParams::sub`]: a refined cell's rays fit one u32 mask.
pub const MAX_SUB: u32 = 5;

impl SkyRefineParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: SkyRefineParams = Self { sub: 3, portal: super::PortalParams::DEFAULT };
}

impl Default for SkyRefineParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The refined cells of every vertex and which of their rays missed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyRefinement {
    /// Sub-cells a side (0: none refined).
    pub sub: u32,
    /// Row `v`: vertex `v`'s refined cells, `(ray index of the cell in its
    /// vertex's direction set, mask)`, ascending; bit `j` of a mask: its
    /// sub-cell `j` ray left the scene (no rows: none refined anywhere).
    pub cells: Csr<(u32, u32)>,
    /// Fresh rays traced.
    pub rays: u64,
    /// Time spent, ms.
    pub ms: f64,
}

/// The unit-square point of sub-cell `j` of cell `(x, y)` of a `k x k`
/// grid with `sub x sub` sub-cells, jittered by a hash of `seed`, the
/// direction set and the cell.
fn sub_point(k: u32, sub: u32, x: u32, y: u32, j: u32, set: u32, seed: u64) -> Vec2 {
    let h = Stream::SKY_CELLS.hash(seed, &[u64::from(set), u64::from(y * k + x), u64::from(j)]);
    let jitter = Vec2::new((h as u32) as f32, (h >> 32) as u32 as f32) * (1.0 / 4294967296.0);
    let jitter = jitter.clamp(Vec2::splat(1e-4), Vec2::splat(1.0 - 1e-4));
    let (jx, jy) = (j % sub, j / sub);
    let cell = Vec2::new(x as f32, y as f32) + (Vec2::new(jx as f32, jy as f32) + jitter) / sub as f32;
    cell / k as f32
}

/// The grid of a direction set: each ray's cell and each cell's ray.
struct Grid {
    k: u32,
    cell_of: Vec<(u32, u32)>,
    ray_of: Vec<u32>,
}

impl Grid {
    fn new(k: u32) -> Grid {
        let cell_of = block_order(k);
        let mut ray_of = vec![0u32; (k * k) as usize];
        for (r, &(x, y)) in cell_of.iter().enumerate() {
            ray_of[(y * k + x) as usize] = r as u32;
        }
        Grid { k, cell_of, ray_of }
    }

    /// A grid neighbour of ray `r`'s cell (its ray index), if the grid has more than one cell.
    fn first_neighbour(&self, r: u32) -> Option<u32> {
        let (x, y) = self.cell_of[r as usize];
        let k = self.k;
        let nx = if x + 1 < k { x + 1 } else { x.checked_sub(1)? };
        Some(self.ray_of[(y * k + nx) as usize])
    }

    /// The cells (ray indices) whose neighbours hold both a miss and a hit, for miss mask `mask`.
    fn refined(&self, mask: &[u64]) -> Vec<u32> {
        let missed = |r: u32| mask[(r / 64) as usize] >> (r % 64) & 1 == 1;
        let k = self.k as i64;
        let mut out = Vec::new();
        for (r, &(x, y)) in self.cell_of.iter().enumerate() {
            let (mut miss, mut hit) = (false, false);
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= k || ny >= k {
                        continue;
                    }
                    if missed(self.ray_of[(ny * k + nx) as usize]) {
                        miss = true;
                    } else {
                        hit = true;
                    }
                }
            }
            if miss && hit {
                out.push(r as u32);
            }
        }
        out
    }
}

impl SkyRefinement {
    /// Traces the fresh rays of every vertex that saw the sky (`vis`, from
    /// links shot from `setup` with `seed`) with `tracer`; none without a sky.
    pub fn compute(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        setup: &RaySetup,
        vis: &SkyVisibility,
        portals: &[Portal],
        seed: u64,
        params: &SkyRefineParams,
    ) -> crate::Result<SkyRefinement> {
        Self::keeping(scene, tracer, setup, vis, portals, seed, params, &|_| None)
    }

    /// [`SkyRefinement::compute`] where `kept(v)` gives vertex `v`'s row
    /// (cells and their bits) from a refinement it keeps: its refined
    /// cells, found from its miss mask, must be that row's cells, and their
    /// bits are taken instead of traced (`SkyRays::after_split` says when
    /// a row may be kept). Equal to `compute` bit for bit where the kept
    /// rows are what `compute` would trace.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn keeping<'k>(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        setup: &RaySetup,
        vis: &SkyVisibility,
        portals: &[Portal],
        seed: u64,
        params: &SkyRefineParams,
        kept: &(dyn Fn(usize) -> Option<&'k [(u32, u32)]> + Sync),
    ) -> crate::Result<SkyRefinement> {
        let start = Instant::now();
        let sub = params.sub.min(MAX_SUB);
        let n = scene.vertex_count();
        if sub == 0 || vis.is_empty() || scene.sky.is_none() {
            return Ok(SkyRefinement::default());
        }
        let grid = Grid::new(setup.directions.k);
        let frames = RayFrames {
            normals: &setup.normals,
            rotations: &setup.rotations,
            sets: &setup.sets,
            directions: &setup.directions,
            positions: &scene.positions,
            portals,
        };
        // Misses through a portal are the portal's: an edge between them and hits needs no refining.
        let cells: Vec<Vec<u32>> =
            (0..n).into_par_iter().map(|v| grid.refined(&frames.effective_mask(v, vis.vertex(v)))).collect();
        let mut rows = RowBuilder::new();
        for c in cells {
            rows.extend(c.into_iter().map(|cell| (cell, 0u32)));
            rows.end_row();
        }
        let mut cells = rows.finish();
        let offsets = cells.offsets.clone();
        // Rows kept with their bits: not traced.
        let carried: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|v| {
                let row = &cells.items[offsets[v] as usize..offsets[v + 1] as usize];
                kept(v).is_some_and(|k| k.len() == row.len() && k.iter().zip(row).all(|(a, b)| a.0 == b.0))
            })
            .collect();
        for v in (0..n).filter(|&v| carried[v]) {
            let row = kept(v).expect("checked");
            cells.items[offsets[v] as usize..offsets[v + 1] as usize].copy_from_slice(row);
        }
        let per = (sub * sub) as usize;
        let mut rays = 0u64;
        // Batches of vertices, so the rays of the whole scene are never held at once.
        let mut v0 = 0usize;
        while v0 < n {
            let mut v1 = v0;
            while v1 < n && (offsets[v1] - offsets[v0]) as usize * per < 1 << 20 {
                v1 += 1;
            }
            let v1 = v1.max(v0 + 1);
            // Per ray: its cell slot and bit, or a dive under the surface (a hit, not traced).
            let batch: Vec<(usize, u32, Option<Ray>)> = (v0..v1)
                .into_par_iter()
                .flat_map_iter(|v| {
                    let frame = vertex_frame(setup.normals[v], setup.rotations[v]);
                    let set = setup.sets[v];
                    let (setup, grid) = (&setup, &grid);
                    let range = if carried[v] { 0..0 } else { offsets[v] as usize..offsets[v + 1] as usize };
                    let cells = &cells.items;
                    range.flat_map(move |slot| {
                        let (x, y) = grid.cell_of[cells[slot].0 as usize];
                        (0..sub * sub).map(move |j| {
                            let u = sub_point(grid.k, sub, x, y, j, set, seed);
                            let dir = world_direction(frame, cosine_hemisphere(u).normalize());
                            let under = setup.wedges(v).iter().any(|w| w.dives_under(dir));
                            let ray =
                                Ray { origin: setup.origins[v], dir, tmin: 0.0, tmax: f32::INFINITY, skip: v as u32 };
                            (slot, j, (!under).then_some(ray))
                        })
                    })
                })
                .collect();
            let traced: Vec<Ray> = batch.iter().filter_map(|b| b.2).collect();
            rays += traced.len() as u64;
            let visible = tracer.visible(&traced)?;
            let mut it = visible.into_iter();
            for (slot, j, ray) in batch {
                if ray.is_some() && it.next() == Some(true) {
                    cells.items[slot].1 |= 1 << j;
                }
            }
            v0 = v1;
        }
        Ok(SkyRefinement { sub, cells, rays, ms: start.elapsed().as_secs_f64() * 1e3 })
    }

    /// True when no cell is refined.
    pub fn is_empty(&self) -> bool {
        self.cells.items.is_empty()
    }

    /// Bytes held.
    #[cfg(any(feature = "cli", feature = "internals"))]
    pub fn bytes(&self) -> u64 {
        self.cells.bytes()
    }

    /// Checks the structure against `n` vertices of `rays` rays each: offsets
    /// ascending and ending at the cell count, cells in range and ascending
    /// per vertex, masks within `sub * sub` bits.
    pub fn validate(&self, n: usize, rays: usize) -> Result<(), String> {
        if self.is_empty() {
            return Ok(());
        }
        if self.sub == 0 || self.sub > MAX_SUB {
            return Err(format!("sub {}", self.sub));
        }
        let bits = self.sub * self.sub;
        self.cells.validate(n, |v, &(c, m)| {
            if c as usize >= rays || (bits < 32 && m >> bits != 0) {
                return Err(format!("vertex {v}: cell {c} of {rays} rays or mask bits beyond {bits}"));
            }
            Ok(())
        })?;
        for v in 0..n {
            if self.cells.row(v).windows(2).any(|w| w[0].0 >= w[1].0) {
                return Err(format!("vertex {v}: cells out of order"));
            }
        }
        Ok(())
    }

    /// `E_sky` of every vertex under `sky` (W/m^2) and its variance
    /// ((W/m^2)^2, see the module doc), from the link rays' misses `vis`
    /// with the refined cells' rays in place of theirs. `seed` is the links'.
    pub fn irradiance(
        &self,
        vis: &SkyVisibility,
        sky: Option<&Sky>,
        frames: &RayFrames,
        seed: u64,
        n: usize,
    ) -> Vec<(Vec3, Vec3)> {
        let Some(sky) = sky.filter(|_| !vis.is_empty()) else { return vec![(Vec3::ZERO, Vec3::ZERO); n] };
        let radiance = sky.radiance_fn();
        let rays = frames.directions.len();
        let k = frames.directions.k;
        let grid = Grid::new(k);
        let scale = std::f32::consts::PI / rays as f32;
        let sub = self.sub.max(1);
        let per = (sub * sub) as f32;
        (0..n)
            .into_par_iter()
            .map(|v| {
                // Misses through a portal are its samples' to count: here they are hits.
                let mask = frames.effective_mask(v, vis.vertex(v));
                if mask.iter().all(|&m| m == 0) {
                    return (Vec3::ZERO, Vec3::ZERO);
                }
                let frame = vertex_frame(frames.normals[v], frames.rotations[v]);
                let set = frames.sets[v];
                let dirs = frames.directions.set(set);
                let cells = if v < self.cells.rows() { self.cells.row(v) } else { &[] };
                let mut sum = Vec3::ZERO;
                let mut var = Vec3::ZERO;
                let mut next = cells.iter().peekable();
                for r in 0..rays as u32 {
                    if let Some(&(_, m)) = next.next_if(|&&(c, _)| c == r) {
                        let (x, y) = grid.cell_of[r as usize];
                        let (mut s1, mut s2) = (Vec3::ZERO, Vec3::ZERO);
                        for j in 0..sub * sub {
                            if m >> j & 1 == 1 {
                                let u = sub_point(k, sub, x, y, j, set, seed);
                                let d = world_direction(frame, cosine_hemisphere(u).normalize());
                                if through_any(frames.portals, frames.positions[v], d) {
                                    continue;
                                }
                                let l = radiance(d);
                                s1 += l;
                                s2 += l * l;
                            }
                        }
                        let mean = s1 / per;
                        sum += mean;
                        if sub > 1 {
                            var += (s2 - s1 * mean).max(Vec3::ZERO) / (per - 1.0) / per;
                        }
                    } else {
                        let missed = |r: u32| mask[(r / 64) as usize] >> (r % 64) & 1 == 1;
                        let own = missed(r);
                        let l = || radiance(world_direction(frame, dirs[r as usize]));
                        if own {
                            sum += l();
                        }
                        // A kept cell unlike its neighbours (all alike, or it would be refined)
                        // holds an edge no neighbour saw: a coin toss, variance at most L^2 / 4.
                        if grid.first_neighbour(r).is_some_and(|u| missed(u) != own) {
                            let l = l();
                            var += l * l / 4.0;
                        }
                    }
                }
                (sum * scale, var * scale * scale)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mask of `k*k` rays in which the rays of the cells with `x < edge` missed.
    fn half_open(grid: &Grid, edge: u32) -> Vec<u64> {
        let mut mask = vec![0u64; (grid.k * grid.k).div_ceil(64) as usize];
        for (r, &(x, _)) in grid.cell_of.iter().enumerate() {
            if x < edge {
                mask[r / 64] |= 1 << (r % 64);
            }
        }
        mask
    }

    #[test]
    fn the_cells_beside_an_edge_are_refined_and_no_others() {
        let grid = Grid::new(16);
        // All missed, or all hit: nothing to refine.
        assert!(grid.refined(&half_open(&grid, 16)).is_empty());
        assert!(grid.refined(&half_open(&grid, 0)).is_empty());
        // An edge between columns 5 and 6: columns 5 and 6 are refined, every row.
        let cells = grid.refined(&half_open(&grid, 6));
        let mut columns: Vec<u32> = cells.iter().map(|&r| grid.cell_of[r as usize].0).collect();
        columns.sort_unstable();
        columns.dedup();
        assert_eq!(columns, vec![5, 6]);
        assert_eq!(cells.len(), 32);
        assert!(cells.windows(2).all(|w| w[0] < w[1]), "ascending ray order");
        // One missed ray: its 8 neighbours are refined, itself not (its own ray decides nothing).
        let mut one = vec![0u64; 4];
        let r = grid.ray_of[(7 * 16 + 7) as usize];
        one[(r / 64) as usize] |= 1 << (r % 64);
        let cells = grid.refined(&one);
        assert_eq!(cells.len(), 8);
        assert!(!cells.contains(&r));
    }

    /// One vertex sees a uniform sky through one lone ray: its refined
    /// neighbours all hit, so `E_sky = (pi/n) L` and the variance is the
    /// lone cell's coin toss, `(pi/n)^2 L^2 / 4`; open wide (all rays
    /// missed) the variance is 0.
    #[test]
    fn a_lone_miss_carries_a_coin_toss_of_variance() {
        let (k, l) = (16u32, Vec3::new(2.0, 1.0, 0.5));
        let grid = Grid::new(k);
        let r = grid.ray_of[(7 * k + 7) as usize];
        let mut one = vec![0u64; 4];
        one[(r / 64) as usize] |= 1 << (r % 64);
        let directions = crate::sampling::DirectionSet::new(k, 1);
        let (normals, rotations, sets) = (vec![Vec3::Y], vec![0.0f32], vec![0u32]);
        let frames = RayFrames {
            normals: &normals,
            rotations: &rotations,
            sets: &sets,
            directions: &directions,
            positions: &[Vec3::ZERO],
            portals: &[],
        };
        let sky = Sky::uniform(l);
        let scale = std::f32::consts::PI / (k * k) as f32;
        for (mask, want_e, want_var) in
            [(one, l * scale, l * l * scale * scale / 4.0), (vec![u64::MAX; 4], l * std::f32::consts::PI, Vec3::ZERO)]
        {
            let cells = grid.refined(&mask);
            let refine = SkyRefinement {
                sub: 3,
                cells: Csr::from_pairs(1, &cells.iter().map(|&c| (0u32, (c, 0u32))).collect::<Vec<_>>()),
                rays: 0,
                ms: 0.0,
            };
            let vis = SkyVisibility::from_sparse(1, [(0usize, mask)]);
            let (e, var) = refine.irradiance(&vis, Some(&sky), &frames, 1, 1)[0];
            assert!((e - want_e).abs().max_element() <= 1e-5 * want_e.max_element(), "{e} against {want_e}");
            assert!(
                (var - want_var).abs().max_element() <= 1e-5 * want_var.max_element().max(1e-12),
                "{var} against {want_var}"
            );
        }
    }

    #[test]
    fn sub_points_stay_in_their_sub_cells_and_follow_the_seed() {
        let (k, sub) = (16, 3);
        for j in 0..sub * sub {
            let u = sub_point(k, sub, 4, 9, j, 1, 7) * k as f32 - Vec2::new(4.0, 9.0);
            let (jx, jy) = ((j % sub) as f32, (j / sub) as f32);
            assert!(u.x * sub as f32 >= jx && u.x * sub as f32 <= jx + 1.0, "{u}");
            assert!(u.y * sub as f32 >= jy && u.y * sub as f32 <= jy + 1.0, "{u}");
        }
        assert_eq!(sub_point(k, sub, 4, 9, 2, 1, 7), sub_point(k, sub, 4, 9, 2, 1, 7));
        assert_ne!(sub_point(k, sub, 4, 9, 2, 1, 7), sub_point(k, sub, 4, 9, 2, 1, 8));
        assert_ne!(sub_point(k, sub, 4, 9, 2, 0, 7), sub_point(k, sub, 4, 9, 2, 1, 7));
    }
}
