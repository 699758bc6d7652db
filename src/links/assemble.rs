//! Hit records to CSR links, in one place whatever traced the rays (the CPU
//! tracers in [`super::shoot`], the GPU in `crate::gpu::schedule`): each
//! vertex's records are merged into its link group ([`merge_vertex_sums`]),
//! groups of consecutive vertices are collected into [`GroupRun`]s (one per
//! worker chunk or device batch), and [`assemble`] stitches the runs in
//! vertex order into [`Links`] with the counters and storage sizes.
//!
//! Sizes: raw links are counted as (u32 target, f32 weight), 8 bytes;
//! merged links as the gathers read them ([`Links::gather_bytes`]).

use super::merge::{merge_vertex_sums, HitRecord, MergeScratch, HIT_MISS};
use super::near::{NearHit, NearHits, NearRule};
use super::packed::PackedTargets;
use super::{LinkStats, Links};
use crate::sky::visibility::miss_mask;
use crate::sky::SkyVisibility;
use half::f16;

/// Bytes of one raw link (u32 target + f32 weight).
pub const RAW_LINK_BYTES: u64 = 8;

/// The merged link groups of consecutive vertices `first..first + counts.len()`.
#[derive(Clone, Debug, Default)]
pub struct GroupRun {
    /// The first vertex of the run.
    pub first: usize,
    /// Links of each vertex, in order.
    pub counts: Vec<u32>,
    /// The groups' targets, packed (an unfinished stream, [`super::packed`]).
    pub packed: PackedTargets,
    /// The groups' link weights, in link order.
    pub weights: Vec<f16>,
    /// Fixed-point sums of the links ([`super::merge::fixed_scale`]), kept
    /// only when the run records them ([`GroupRun::recording`]).
    pub sums: Vec<u32>,
    /// Sky visibility of the vertices of the run whose rays missed:
    /// `(vertex, miss mask)` ([`crate::sky::visibility`]).
    pub sky: Vec<(usize, Vec<u64>)>,
    /// Near hits of each vertex ([`super::near`]), when the run records them ([`GroupRun::with_near`]).
    pub near_counts: Vec<u32>,
    /// The near hits of the run's vertices, `near_counts` of them per vertex in order.
    pub near: Vec<NearHit>,
    /// Counters of the run's rays and links.
    pub stats: LinkStats,
    record_sums: bool,
    /// Which hits are near and which of them a vertex keeps.
    near_rule: Option<NearRule>,
    scratch: MergeScratch,
    /// The group being merged.
    targets: Vec<u32>,
}

impl GroupRun {
    /// An empty run starting at vertex `first` (no sums, no near hits recorded).
    pub fn new(first: usize) -> GroupRun {
        GroupRun { first, ..Default::default() }
    }

    /// A run that also keeps every link's fixed-point sum (selective updates).
    pub fn recording(first: usize) -> GroupRun {
        GroupRun { first, record_sums: true, ..Default::default() }
    }

    /// The run recording near hits under `rule`; `None` records none.
    pub fn with_near(mut self, rule: Option<NearRule>) -> GroupRun {
        self.near_rule = rule;
        self
    }

    /// Appends the next vertex's group, merged from its hit records (one
    /// per ray; triangles give the hit triangles' corner vertices), and
    /// notes which of its rays missed (its sky visibility) and which hit
    /// near (when recording them).
    pub fn push_vertex(&mut self, hits: &[HitRecord], triangles: &[[u32; 3]], weight_per_ray: f64) {
        let v = self.first + self.counts.len();
        if let Some(rule) = &self.near_rule {
            let before = self.near.len();
            super::near::push_near(v, hits, triangles, rule, &mut self.near);
            self.near_counts.push((self.near.len() - before) as u32);
        }
        self.targets.clear();
        let sums = self.record_sums.then_some(&mut self.sums);
        let c = merge_vertex_sums(
            hits,
            triangles,
            weight_per_ray,
            &mut self.scratch,
            &mut self.targets,
            &mut self.weights,
            sums,
        );
        self.counts.push(self.targets.len() as u32);
        self.packed.push_group(&self.targets);
        let st = &mut self.stats;
        st.rays += hits.len() as u64;
        st.front_hits += c.front as u64;
        st.back_hits += c.back as u64;
        st.misses += c.miss as u64;
        st.raw_links += 3 * c.front as u64;
        if c.miss > 0 {
            if let Some(m) = miss_mask(hits.iter().map(|h| h.tri == HIT_MISS), hits.len()) {
                self.sky.push((v, m));
            }
        }
    }

    /// Appends `next`, which must start where this run ends.
    pub fn append(&mut self, next: GroupRun) {
        debug_assert_eq!(next.first, self.first + self.counts.len());
        self.counts.extend(next.counts);
        self.packed.append(&next.packed);
        self.weights.extend(next.weights);
        self.sums.extend(next.sums);
        self.sky.extend(next.sky);
        self.near_counts.extend(next.near_counts);
        self.near.extend(next.near);
        self.stats.add(&next.stats);
    }
}

/// CSR links built from runs pushed in vertex order; each run's links
/// are copied once into the final arrays, so a caller that pushes batch
/// by batch never holds more than one batch beside the links.
#[derive(Debug)]
pub struct CsrBuilder {
    links: Links,
    sums: Vec<u32>,
    sky: Vec<(usize, Vec<u64>)>,
    near: NearHits,
}

impl CsrBuilder {
    /// A builder for `n` vertices, with no run pushed yet.
    pub fn new(n: usize) -> CsrBuilder {
        let mut links = Links { offsets: Vec::with_capacity(n + 1), ..Default::default() };
        links.offsets.push(0);
        CsrBuilder { links, sums: Vec::new(), sky: Vec::new(), near: NearHits::default() }
    }

    /// Appends `run`, which must start at the next vertex.
    pub fn push(&mut self, r: GroupRun) -> Result<(), String> {
        let links = &mut self.links;
        let at = links.offsets.len() - 1;
        if r.first != at {
            return Err(format!("link groups of vertices {at}..{} are missing or overlap", r.first.max(at)));
        }
        for c in r.counts {
            let last = *links.offsets.last().expect("non-empty");
            links.offsets.push(last + c);
        }
        links.packed.append(&r.packed);
        links.weights.extend(r.weights);
        self.sums.extend(r.sums);
        self.sky.extend(r.sky);
        if !r.near_counts.is_empty() {
            if self.near.rows.offsets.is_empty() {
                self.near.rows.offsets.push(0);
            }
            for c in r.near_counts {
                let last = *self.near.rows.offsets.last().expect("non-empty");
                self.near.rows.offsets.push(last + c);
            }
            self.near.rows.items.extend(r.near);
        }
        links.stats.add(&r.stats);
        Ok(())
    }

    /// The fixed-point sums pushed so far (runs that record them), taken out.
    pub fn take_sums(&mut self) -> Vec<u32> {
        std::mem::take(&mut self.sums)
    }

    /// The links of vertices `0..n`, with their counters and sizes;
    /// `shoot_ms` is the time the caller spent, ms.
    pub fn finish(self, n: usize, shoot_ms: f64) -> Result<Links, String> {
        let mut links = self.links;
        if links.offsets.len() != n + 1 {
            return Err(format!("link groups cover {} of {n} vertices", links.offsets.len() - 1));
        }
        links.packed.finish();
        links.packed.bytes.shrink_to_fit();
        links.weights.shrink_to_fit();
        links.sky = SkyVisibility::from_sparse(n, self.sky);
        if !self.near.rows.offsets.is_empty() && self.near.rows.offsets.len() != n + 1 {
            return Err(format!("near hits recorded for {} of {n} vertices", self.near.rows.offsets.len() - 1));
        }
        links.near = self.near;
        links.set_sizes();
        let stats = &mut links.stats;
        stats.raw_bytes = stats.raw_links * RAW_LINK_BYTES;
        stats.shoot_ms = shoot_ms;
        Ok(links)
    }
}

/// Stitches runs covering vertices `0..n` (in any order) into CSR links,
/// with the links' fixed-point sums where the runs recorded them (else
/// empty); `shoot_ms` is the time the caller spent, ms. Missing or
/// overlapping runs are an error naming the first gap.
pub fn assemble(n: usize, mut runs: Vec<GroupRun>, shoot_ms: f64) -> Result<(Links, Vec<u32>), String> {
    runs.sort_by_key(|r| r.first);
    let mut csr = CsrBuilder::new(n);
    for r in runs {
        csr.push(r)?;
    }
    let sums = csr.take_sums();
    Ok((csr.finish(n, shoot_ms)?, sums))
}
