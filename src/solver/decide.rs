//! Terms that pay their way (issue 43): before the near-field terms of
//! [`Terms::DECIDED`] are traced for every near hit, each is traced for a
//! sample of the vertices that have near hits and kept only where it
//! changes the light there by enough.
//!
//! The sample: every vertex with near hits whose hash (the scene's seed,
//! [`Stream::TERM_SAMPLE`], the vertex) falls under a share of
//! [`SAMPLE_SHARE`], raised so that at least [`SAMPLE_MIN`] vertices are
//! drawn; its terms are traced exactly as a full trace would trace them
//! there (a near hit's samples hash from the vertex, its triangle and its
//! rank). With `E_v` a solve's irradiance at vertex `v` without the
//! near-field terms (direct, sky and indirect; W/m^2) and `D_v` the
//! term's correction there, the term's *change* is
//!
//! ```text
//! c = sqrt( mean over sampled v of ( Y(D_v) / max(Y(E_v), 0.05 mean Y(E)) )^2 )
//! ```
//!
//! (`Y` luminance): the RMS share by which it moves a vertex's light. A
//! term stays on where `c >= pay_share` ([`super::SolveParams::pay_share`], 2% by
//! default: below the per-vertex noise of 256 link rays, about 5%, what
//! the term removes does not show). `off = [...]` forces a term off,
//! `on = [...]` ([`super::SolveParams::forced`]) on. Deterministic for a scene,
//! its settings and seed.
//!
//! Deviation from the issue's wording: the rule compares the term's change
//! with a fixed share rather than with what its time would buy as more
//! rays or refinement; the figures per term (the sampled change and the
//! sample's rays) are reported in `solve`'s output so the choice can be
//! checked.

use super::traced::{Change, Inputs, Part};
use super::{compute::Tracers, Solver};
use crate::csr::RowBuilder;
use crate::exchange::near::{Bounce, NearField};
use crate::links::NearHits;
use crate::render::exposure::luminance;
use crate::sampling::stream::{unit, Stream};
use crate::scene::terms::Terms;
use glam::Vec3;

/// Share of the vertices with near hits that a decision samples.
pub const SAMPLE_SHARE: f32 = 1.0 / 32.0;
/// Fewest vertices a decision samples (all of them where there are fewer).
pub const SAMPLE_MIN: usize = 256;

/// What a solve decided about one term of [`Terms::DECIDED`].
#[derive(Clone, Debug, PartialEq)]
pub struct TermDecision {
    /// The term's name ([`Terms::NAMES`]).
    pub term: &'static str,
    /// Vertices sampled, of the vertices with near hits.
    pub sampled: usize,
    /// Vertices with near hits.
    pub with_hits: usize,
    /// Rays the sample traced.
    pub sample_rays: u64,
    /// The RMS relative change of the sampled vertices' light (module doc).
    pub change: f32,
    /// Whether it stays on.
    pub on: bool,
    /// Whether `on = [...]` forced it on.
    pub forced: bool,
}

impl TermDecision {
    /// One line for notes and `solve`'s stats.
    pub fn describe(&self) -> String {
        let why = if self.forced {
            "forced on".to_string()
        } else {
            format!(
                "{} ({:.2}% {} the threshold)",
                if self.on { "on" } else { "off" },
                100.0 * self.change,
                if self.on { ">=" } else { "<" }
            )
        };
        format!(
            "{}: {why}; it changes the light of {} sampled vertices (of {} with near hits, {} rays) by {:.2}% RMS",
            self.term,
            self.sampled,
            self.with_hits,
            self.sample_rays,
            100.0 * self.change
        )
    }
}

impl Solver {
    /// Decides the terms of [`Terms::DECIDED`] that are on and have work
    /// to trace (module doc), turning off those that do not pay unless
    /// forced; returns the decisions. Needs the sources traced ([`Part::SOURCES`]) and the
    /// near-field parts not yet traced.
    pub(super) fn decide_terms(&mut self) -> Vec<TermDecision> {
        let p = self.params;
        if p.pay_share <= 0.0 || self.links.near.is_empty() {
            return Vec::new();
        }
        let candidates: Vec<&'static str> =
            Terms::DECIDED.into_iter().filter(|n| p.terms.get(n) == Some(true)).collect();
        if candidates.is_empty() {
            return Vec::new();
        }
        let (sample, with_hits) = sample(&self.links.near, self.scene.vertex_count(), p.seed());
        let sampled_vertices: Vec<usize> =
            (0..self.scene.vertex_count()).filter(|&v| !sample.of(v).is_empty()).collect();
        // The light without near-field terms (none is traced yet).
        let s0 = self.solve_quick();
        let e: Vec<f32> = (0..self.scene.vertex_count())
            .map(|v| luminance(s0.e_direct[v] + s0.e_sky[v] + s0.e_indirect[v]))
            .collect();
        let floor = 0.05 * e.iter().map(|&x| x as f64).sum::<f64>() as f32 / e.len().max(1) as f32;
        let mut out = Vec::new();
        for name in candidates {
            let forced = p.forced.get(name) == Some(true);
            let part = Part::of_decided(name).expect("a decided term");
            // Traced into the solver's own (still empty) near field, then taken out.
            let t = Tracers::of(&self.gpu, &self.accel);
            let inputs = Inputs { scene: &self.scene, links: &self.links, near: &sample, params: &p };
            self.traced.update(&[part], &Change::Fresh, inputs, t);
            let rays = self.traced.rays(part);
            let probe = std::mem::take(&mut self.traced.near);
            if rays == 0 {
                // Nothing to trace (no emitters, no sky): nothing to decide.
                continue;
            }
            let d = self.correction_of(probe, &sample, &s0);
            let change = if d.is_empty() {
                0.0
            } else {
                let sum: f64 = sampled_vertices
                    .iter()
                    .map(|&v| {
                        let r = luminance(d[v]).abs() / e[v].max(floor).max(f32::MIN_POSITIVE);
                        (r as f64).powi(2)
                    })
                    .sum();
                (sum / sampled_vertices.len().max(1) as f64).sqrt() as f32
            };
            let on = forced || change >= p.pay_share;
            if !on {
                self.params.terms.set(name, false).expect("a term name");
            }
            out.push(TermDecision {
                term: name,
                sampled: sampled_vertices.len(),
                with_hits,
                sample_rays: rays,
                change,
                on,
                forced,
            });
        }
        for d in &out {
            log::info!("{}", d.describe());
        }
        out
    }

    /// `params` with the terms this solver decided off turned off (unless
    /// `params` force them on or decide nothing): what a change of
    /// parameters or a deformation keeps, so they trace none of it.
    pub(super) fn with_decisions(&self, mut params: super::SolveParams) -> super::SolveParams {
        for d in self.term_decisions().iter().filter(|d| !d.on) {
            if params.forced.get(d.term) != Some(true) && params.pay_share > 0.0 {
                params.terms.set(d.term, false).expect("a term name");
            }
        }
        params
    }

    /// The correction at every vertex (W/m^2; empty: none) of the near
    /// terms in `near` alone, traced from the near hits `hits`, for the sources and bounces of the solution
    /// `s0` (solved without near-field terms): what they would add to
    /// `E_i` in the first bounce or after the bounces.
    fn correction_of(&mut self, near: NearField, hits: &NearHits, s0: &super::Solution) -> Vec<Vec3> {
        let later = near.terms().iter().any(|t| !t.is_empty() && t.bounce() == Bounce::Later);
        let saved = std::mem::replace(&mut self.traced.near, near);
        // The terms read their hits in the order of the hits they were traced from.
        let all_hits = std::mem::replace(&mut self.links.near, hits.clone());
        let src = self.sources();
        let d = if later {
            let stand_ins = self.stand_ins();
            self.near_later(&src, &s0.e_gathered, &stand_ins)
        } else {
            src.e_near
        };
        self.traced.near = saved;
        self.links.near = all_hits;
        d
    }
}

/// The near hits of the sampled vertices (the others' rows empty) and the
/// count of vertices with near hits.
fn sample(near: &NearHits, n: usize, seed: u64) -> (NearHits, usize) {
    let with_hits = (0..n).filter(|&v| !near.of(v).is_empty()).count();
    let share = SAMPLE_SHARE.max(SAMPLE_MIN as f32 / with_hits.max(1) as f32).min(1.0);
    let mut rows = RowBuilder::new();
    for v in 0..n {
        if unit(Stream::TERM_SAMPLE.hash(seed, &[v as u64])) < share {
            rows.extend(near.of(v).iter().copied());
        }
        rows.end_row();
    }
    (NearHits { rows: rows.finish() }, with_hits)
}
