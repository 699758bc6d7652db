//! The emitter groups as a control variate of the first bounce: the
//! emitter links know exactly (up to their visibility samples) how much of
//! a vertex's view an emitter group fills, so the link rays' count of hits
//! on it, and that count's noise, can be taken out of the light the group
//! reflects.
//!
//! A vertex `x`'s first bounce gathers `sum_j w_j B_0(t_j)` over its links
//! (`w` in sr, `B_0` the source radiosity, W/(m^2 sr)). For an emitter
//! group `g` (an emissive mesh's triangles of one exitance,
//! [`crate::exchange::sources::emitter_links`]) write `W_xg = sum over links into g of w_j`:
//! `pi` times the share of `x`'s rays that met `g`, whose expectation is
//! `pi F_xg`, `F_xg` the visible form factor the emitter links hold (plus,
//! on `g` itself, the band of directions under the vertex's own triangles,
//! [`crate::links::shoot::dive_share`]). With `Bbar_g` the area mean of
//! `B_0` over `g`'s vertices,
//!
//! ```text
//! D_cv(x) = sum_g Bbar_g (pi F_xg - W_xg)        (W/m^2)
//! ```
//!
//! has expectation zero, and added to the first bounce it replaces the
//! rays' count of the group by its form factor: what stays of the group's
//! noise is the spread of `B_0` over it. A glowing surface reflects much
//! of what it receives (inside `window`'s lamp shade the reflected
//! radiosity is a third of the light), and the count's noise is what held
//! the shade's vertices, the brightest of the scene, to 4.5-5.7% at 64
//! rays over three seeds. `D_cv` is part of the gathered first bounce: it
//! is smoothed with it, reflects on through the bounces (it is in the
//! bounces' source), and the noise estimate of the smoothing sees it
//! ([`EmitterCv::adjust_moments`]: the radiosity of a group's vertices
//! less `Bbar_g`, the part the control variate takes out).
//!
//! Deviation from an all-bounce control variate: only the first bounce
//! (later bounces carry `rho` times less of the group's light, and would
//! need a group sum inside both bounce kernels). `Bbar_g` is any constant
//! as far as the bias goes; the area mean is exact for the linear
//! interpolation of `B_0` over the group's triangles.
//!
//! Measured on `window` (16384-path reference, total relative RMSE, auto
//! bounces, `--off emitter_cv` to compare; `cargo test --release --test measured -- --ignored
//! emitter_control_variate_lowers_window_error` checks seed 1 at 64 and 256
//! rays, 4.77 -> 4.05% and 1.97 -> 1.73% now), seeds 1 /
//! 2 / 3: 64 rays 4.52 / 5.13 / 5.72% -> 3.84 / 4.38 / 4.51% (seeds 4, 5,
//! an earlier build: 3.67 / 4.17%), 256 rays 2.12 / 2.16 / 2.01% -> 1.84 /
//! 1.98 / 1.84%, 1024 rays 1.20 / 1.25 / 1.33% -> 1.19 / 1.25 / 1.22%. Between seeds 1
//! and 2 at 64 rays the shade's unsmoothed `E_i` spreads 0.64 times as
//! much (what stays is mostly the emitter links' visibility noise). Built
//! up as post-passes: added after the smoothing, 64 rays seeds 1 / 3 read
//! 4.13 / 5.41%; smoothed with the gathered part but a noise estimate
//! blind to it, 4.12 / 5.40% (the smoothing believed the shade noisier
//! than it was and flattened its steep rings: unsmoothed read 4.56 /
//! 4.51%); with the noise estimate below, 3.92 / 4.68%; in the bounces'
//! source (its reflections corrected too), the figures above. Scenes
//! without emitters are unchanged (cornell 1024 rays 1.02%). Cost: one
//! pass over the links when they or the emitter links change.

use crate::csr::{Csr, RowBuilder};
use crate::exchange::bounce::operator::radiosity;
use crate::exchange::sources::emitter_links::EmitterLinks;
use crate::exchange::sources::emitter_links::NO_GROUP;
use crate::links::Links;
use crate::scene::prep::PreparedScene;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Per vertex and emitter group the coefficient `pi F_xg - W_xg` (sr), and
/// each group vertex's share of its group's area.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterCv {
    /// Per vertex its group ([`NO_GROUP`]: none); empty when there are no groups.
    pub vertex_group: Vec<u32>,
    /// Per vertex its share of its group's area (unitless, summing to 1
    /// over a group; 0 outside groups).
    pub area_share: Vec<f32>,
    /// Groups.
    pub groups: usize,
    /// Per vertex, `(group, pi F_xg - W_xg)` entries (sr).
    pub rows: Csr<(u32, f32)>,
}

impl EmitterCv {
    /// The coefficients of `links` against the form factors of `emitter_links`
    /// (empty without emitter groups).
    pub fn compute(scene: &PreparedScene, links: &Links, emitter_links: &EmitterLinks) -> EmitterCv {
        let n = scene.vertex_count();
        let vertex_group = &emitter_links.vertex_group;
        if !emitter_links.is_active() || vertex_group.len() != n || links.vertex_count() != n {
            return EmitterCv::default();
        }
        let groups = emitter_links.group_vertex.len();
        // Area shares: a third of each group triangle's area to each corner.
        let mut area_share = vec![0f32; n];
        let mut group_area = vec![0f64; groups];
        for t in &scene.triangles {
            let g = vertex_group[t[0] as usize];
            if g == NO_GROUP || t.iter().any(|&v| vertex_group[v as usize] != g) {
                continue;
            }
            let [a, b, c] = t.map(|v| scene.positions[v as usize]);
            let third = (b - a).cross(c - a).length() / 6.0;
            for &v in t {
                area_share[v as usize] += third;
            }
            group_area[g as usize] += 3.0 * third as f64;
        }
        for (s, &g) in area_share.iter_mut().zip(vertex_group) {
            if g != NO_GROUP {
                *s = (*s as f64 / group_area[g as usize].max(f64::MIN_POSITIVE)) as f32;
            }
        }
        let rows: Vec<Vec<(u32, f32)>> = (0..n)
            .into_par_iter()
            .map(|v| {
                let mut row: Vec<(u32, f32)> = Vec::new();
                let mut add = |g: u32, c: f32| match row.iter_mut().find(|e| e.0 == g) {
                    Some(e) => e.1 += c,
                    None => row.push((g, c)),
                };
                let (targets, weights) = links.group(v);
                for (&u, w) in targets.iter().zip(weights) {
                    let g = vertex_group[u as usize];
                    if g != NO_GROUP {
                        add(g, -w.to_f32());
                    }
                }
                for (g, f) in emitter_links.of(v) {
                    add(g, PI * f);
                }
                if vertex_group[v] != NO_GROUP {
                    add(vertex_group[v], PI * crate::links::shoot::dive_share(scene, v));
                }
                row.sort_by_key(|e| e.0);
                row
            })
            .collect();
        let mut out = EmitterCv { vertex_group: vertex_group.clone(), area_share, groups, rows: Csr::default() };
        let mut table = RowBuilder::new();
        for row in rows {
            table.extend(row);
            table.end_row();
        }
        out.rows = table.finish();
        out
    }

    /// True when there are no groups.
    pub fn is_empty(&self) -> bool {
        self.groups == 0
    }

    /// `Bbar_g` of every group: the area mean of `rho/pi e_source` over
    /// its vertices (the group's first radiosity: their emission is the
    /// emitter links'), W/(m^2 sr).
    pub fn group_means(&self, albedo: &[Vec3], e_source: &[Vec3]) -> Vec<Vec3> {
        let mut means = vec![Vec3::ZERO; self.groups];
        for (v, &g) in self.vertex_group.iter().enumerate() {
            if g != NO_GROUP {
                means[g as usize] += radiosity(albedo[v], e_source[v], Vec3::ZERO) * self.area_share[v];
            }
        }
        means
    }

    /// `D_cv` of every vertex (module doc) for the groups' means `means`, W/m^2.
    pub fn correction(&self, means: &[Vec3], n: usize) -> Vec<Vec3> {
        if self.is_empty() {
            return vec![Vec3::ZERO; n];
        }
        (0..n).into_par_iter().map(|v| self.rows.row(v).iter().map(|&(g, c)| means[g as usize] * c).sum()).collect()
    }

    /// Radiosity moments `[B, B^2]` ([`crate::exchange::denoise::noise::radiosity_moments`])
    /// with `B` of every group vertex less its group's mean (`means`): the
    /// part of a link's value the control variate leaves.
    pub fn adjust_moments(&self, b: &mut [[Vec4; 2]], means: &[Vec3]) {
        for (v, &g) in self.vertex_group.iter().enumerate() {
            if g != NO_GROUP {
                let x = b[v][0].truncate() - means[g as usize];
                b[v] = [x.extend(0.0), (x * x).extend(0.0)];
            }
        }
    }

    /// Checks the structure against `n` vertices: groups in range, area
    /// shares summing to 1 per group, CSR offsets, finite coefficients.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.is_empty() {
            return if self.rows.is_empty() && self.rows.items.is_empty() {
                Ok(())
            } else {
                Err("coefficients without groups".into())
            };
        }
        if self.vertex_group.len() != n || self.area_share.len() != n {
            return Err(format!(
                "{} vertex groups, {} area shares for {n} vertices",
                self.vertex_group.len(),
                self.area_share.len()
            ));
        }
        let groups = self.groups;
        self.rows.validate(n, |_, &(g, c)| {
            if g as usize >= groups || !c.is_finite() {
                return Err(format!("entry (group {g} of {groups}, coefficient {c})"));
            }
            Ok(())
        })?;
        if self.vertex_group.iter().any(|&g| g != NO_GROUP && g as usize >= self.groups) {
            return Err(format!("a vertex group out of {}", self.groups));
        }
        let mut sums = vec![0f64; self.groups];
        for (&g, &s) in self.vertex_group.iter().zip(&self.area_share) {
            if !(s.is_finite() && s >= 0.0) {
                return Err(format!("area share {s}"));
            }
            if g != NO_GROUP {
                sums[g as usize] += s as f64;
            }
        }
        if let Some((g, s)) = sums.iter().enumerate().find(|(_, s)| (**s - 1.0).abs() > 1e-3 && **s != 0.0) {
            return Err(format!("group {g}'s area shares sum to {s}"));
        }
        Ok(())
    }
}
