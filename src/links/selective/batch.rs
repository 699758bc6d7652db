//! Selective updates traced by a batch tracer (a GPU's): the rays the
//! rule of [`super`] picks, traced in two batches (every ray of the remade
//! vertices through [`Tracer::origin_rays`], the other rays to trace again
//! through [`Tracer::closest_hits`]) before the per-vertex merge and
//! patch, which read them from a [`Batch`]; and the preview's groups of a
//! few rays ([`shoot_groups`]), traced the same way.

use super::{Context, Scratch};
use crate::trace::ray::Ray;
use crate::trace::ray::Hit;
use crate::links::merge::{merge_vertex, HitRecord, MergeScratch};
use crate::links::shoot::RaySetup;
use crate::links::LinkParams;
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::Vec3;
use half::f16;
use rayon::prelude::*;

/// What a batch tracer traced: every ray of the remade vertices, and the
/// rays of the other vertices that must be traced again.
#[derive(Default)]
pub(super) struct Batch {
    /// Per vertex: its place among the remade ones, or `u32::MAX`.
    slot: Vec<u32>,
    /// The remade vertices' records, vertex after vertex.
    records: Vec<HitRecord>,
    rays: usize,
    /// Per vertex: its re-traced rays' range in the arrays below.
    start: Vec<u32>,
    /// Ray index, direction, kept old record and new hit of each re-traced ray.
    retrace: Vec<u32>,
    dirs: Vec<Vec3>,
    kept: Vec<Option<HitRecord>>,
    hits: Vec<Option<Hit>>,
}

impl Batch {
    /// Vertex `v`'s records, where it was remade.
    pub(super) fn records(&self, v: usize) -> Option<&[HitRecord]> {
        let s = self.slot[v];
        (s != u32::MAX).then(|| &self.records[s as usize * self.rays..(s as usize + 1) * self.rays])
    }

    /// Vertex `v`'s re-traced rays into `scratch` (as [`Context::to_retrace`]
    /// leaves them, with their hits); false when there is none.
    pub(super) fn retraced(&self, v: usize, scratch: &mut Scratch) -> bool {
        let r = self.start[v] as usize..self.start[v + 1] as usize;
        scratch.retrace.clear();
        scratch.retrace.extend_from_slice(&self.retrace[r.clone()]);
        scratch.dirs.clear();
        scratch.dirs.extend_from_slice(&self.dirs[r.clone()]);
        scratch.kept.clear();
        scratch.kept.extend_from_slice(&self.kept[r.clone()]);
        scratch.hits.clear();
        scratch.hits.extend_from_slice(&self.hits[r.clone()]);
        !r.is_empty()
    }
}

/// Traces on `tracer`, in two batches, every ray of the remade vertices
/// ([`Tracer::origin_rays`]) and the other vertices' rays that must be
/// traced again ([`Context::to_retrace`], [`Tracer::closest_hits`]).
pub(super) fn batch_records(ctx: &Context, ids: &[u32], tracer: &dyn Tracer) -> crate::Result<Batch> {
    let n = ctx.scene.vertex_count();
    let rays = ctx.setup.directions.len();
    let remade: Vec<u32> = (0..n as u32).filter(|&v| ctx.motion.remade[v as usize]).collect();
    let records = ctx.setup.trace_vertices(tracer, &remade)?;
    let mut slot = vec![u32::MAX; n];
    for (i, &v) in remade.iter().enumerate() {
        slot[v as usize] = i as u32;
    }
    type Lists = (Vec<u32>, Vec<Vec3>, Vec<Option<HitRecord>>);
    let lists: Vec<Option<Lists>> = (0..n)
        .into_par_iter()
        .map_init(Scratch::default, |scratch, v| {
            let row = &ids[v * rays..(v + 1) * rays];
            (!ctx.motion.remade[v] && ctx.to_retrace(v, row, scratch)).then(|| {
                (
                    std::mem::take(&mut scratch.retrace),
                    std::mem::take(&mut scratch.dirs),
                    std::mem::take(&mut scratch.kept),
                )
            })
        })
        .collect();
    let mut b = Batch { slot, records, rays, start: Vec::with_capacity(n + 1), ..Batch::default() };
    let mut traced = Vec::new();
    b.start.push(0);
    for (v, l) in lists.into_iter().enumerate() {
        if let Some((retrace, dirs, kept)) = l {
            let o = ctx.setup.origins[v];
            traced.extend(dirs.iter().map(|&d| Ray {
                origin: o,
                dir: d,
                tmin: 0.0,
                tmax: f32::INFINITY,
                skip: v as u32,
            }));
            b.retrace.extend(retrace);
            b.dirs.extend(dirs);
            b.kept.extend(kept);
        }
        b.start.push(b.retrace.len() as u32);
    }
    b.hits = tracer.closest_hits(&traced)?;
    Ok(b)
}

/// The link groups of `vertices` shot with `params` through `tracer` in
/// one batch (used for previews at few rays); returns
/// `(vertex, targets, weights)` per vertex.
pub fn shoot_groups(
    scene: &PreparedScene,
    tracer: &dyn Tracer,
    params: &LinkParams,
    vertices: &[u32],
) -> crate::Result<Vec<(u32, Vec<u32>, Vec<f16>)>> {
    let setup = RaySetup::new(scene, params);
    let rays = setup.directions.len().max(1);
    let weight_per_ray = std::f64::consts::PI / rays as f64;
    let records = setup.trace_vertices(tracer, vertices)?;
    Ok(vertices
        .par_iter()
        .zip(records.par_chunks(rays))
        .map_init(MergeScratch::default, |merge, (&v, records)| {
            let (mut t, mut w) = (Vec::new(), Vec::new());
            merge_vertex(records, &scene.triangles, weight_per_ray, merge, &mut t, &mut w);
            (v, t, w)
        })
        .collect())
}
