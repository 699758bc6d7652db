//! One vertex's shadow rays toward the emitters and the factors they
//! give ([`super::emitter_links`] has the method): the exact form factor
//! `F_t` of every emissive triangle at the vertex, `samples` rays spread
//! over the triangles by systematic sampling of `F_t` (one seeded offset
//! per vertex, [`crate::sampling::stream::Stream::point_seed`]), R2 points
//! on each clipped triangle weighted by `cos_p |cos_y| / r^2`; then per
//! group `F_vg = F_g * sum (F_t / pi_t) V_t / sum (F_t / pi_t)` from the
//! rays' visibility. Unitless factors; positions in metres.

use super::emitter_geometry::{polygon_point, seen_polygon, Emitter, EmitterMesh, FormFactorScratch};
use crate::trace::ray::Ray;
use crate::links::shoot::ray_origin;
use crate::sampling::stream::Stream;
use crate::scene::prep::PreparedScene;
use crate::trace::RAY_OFFSET;
use glam::Vec2;
use rand::{Rng, SeedableRng};

/// A triangle a vertex sends rays to, and what its rays found.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pick {
    group: u32,
    /// `F_t / pi_t`.
    scale: f32,
    first_ray: u32,
    rays: u32,
}

/// One vertex's shadow rays, their weights, the triangles they go to and
/// the exact unshaded factor of every group it sees.
#[derive(Clone, Debug, Default)]
pub(super) struct VertexRays {
    pub(super) rays: Vec<Ray>,
    weights: Vec<f32>,
    picks: Vec<Pick>,
    /// `(group, F_g)` for the groups with `F_g > 0`.
    unshaded: Vec<(u32, f64)>,
}

/// Per-thread buffers of [`vertex_rays`].
#[derive(Default)]
pub(super) struct Scratch {
    form: FormFactorScratch,
    /// `F_t` per emitter triangle at the current vertex.
    f: Vec<f64>,
}

/// Vertex `v`'s `samples` shadow rays toward the emitters (of `groups`
/// groups; `mesh` is made of `emitters`).
#[allow(clippy::too_many_arguments)]
pub(super) fn vertex_rays(
    scene: &PreparedScene,
    emitters: &[Emitter],
    mesh: &EmitterMesh,
    groups: usize,
    v: usize,
    nudge: f32,
    samples: u32,
    seed: u64,
    scratch: &mut Scratch,
) -> VertexRays {
    let (p, n) = (scene.positions[v], scene.normals[v]);
    mesh.form_factors(emitters, p, n, &mut scratch.form, &mut scratch.f);
    // Emitters are one-sided like every surface: a vertex behind an
    // emitter's plane (or in it) gets none of its light.
    for (e, f) in emitters.iter().zip(scratch.f.iter_mut()) {
        if *f > 0.0 && !e.faces(p) {
            *f = 0.0;
        }
    }
    let f = &scratch.f;
    // `F_sum` and each group's `F_g` summed in emitter order; zeros are
    // left out (adding +0 changes no sum), and the group at hand is
    // summed in a register.
    let (mut f_sum, mut f_group) = (0f64, vec![0f64; groups]);
    let mut at: Option<(u32, f64)> = None;
    for (e, &ft) in emitters.iter().zip(f) {
        if ft > 0.0 {
            f_sum += ft;
            let sum = match at {
                Some((g, ref mut sum)) if g == e.group => sum,
                _ => {
                    if let Some((g, sum)) = at {
                        f_group[g as usize] = sum;
                    }
                    &mut at.insert((e.group, f_group[e.group as usize])).1
                }
            };
            *sum += ft;
        }
    }
    if let Some((g, sum)) = at {
        f_group[g as usize] = sum;
    }
    let mut out = VertexRays::default();
    if !(f_sum > 0.0) {
        return out;
    }
    out.unshaded = f_group.iter().enumerate().filter(|(_, &x)| x > 0.0).map(|(g, &x)| (g as u32, x)).collect();
    let VertexRays { rays, weights, picks, .. } = &mut out;
    let mut rng = rand_pcg::Pcg32::seed_from_u64(Stream::EMITTER_LINKS.point_seed(seed, p, n));
    let xi: f64 = rng.random();
    let offset = Vec2::new(rng.random(), rng.random());
    let total = samples as f64;
    let origin = ray_origin(scene, v, nudge);
    let eps = RAY_OFFSET * scene.mean_edge_length(v).max(f32::MIN_POSITIVE);
    // Triangle t covers [lo, hi) of the `total` samples; its `lo` is the
    // `hi` of the triangle before it, so its rounding is carried over.
    let mut below = 0.0;
    let mut lo_up = (below / f_sum * total - xi).ceil();
    for (e, &ft) in emitters.iter().zip(f) {
        if ft <= 0.0 {
            continue;
        }
        let hi = (below + ft) / f_sum * total;
        below += ft;
        let hi_up = (hi - xi).ceil();
        let count = (hi_up - lo_up).max(0.0) as u32;
        lo_up = hi_up;
        if count == 0 {
            continue;
        }
        let (poly, m) = seen_polygon(p, n, &e.corners);
        let pi_t = (total * ft / f_sum).min(1.0);
        picks.push(Pick { group: e.group, scale: (ft / pi_t) as f32, first_ray: rays.len() as u32, rays: 0 });
        let pick = picks.last_mut().expect("pushed");
        let en = (e.corners[1] - e.corners[0]).cross(e.corners[2] - e.corners[0]).normalize_or_zero();
        for j in 0..count {
            // R2 low-discrepancy points, rotated per vertex: stratified on the triangle.
            let u = (offset + Vec2::new(0.754_877_7, 0.569_840_3) * (j + 1) as f32).fract();
            let y = (p.as_dvec3() + polygon_point(&poly[..m], u)).as_vec3();
            let d = y - p;
            let r2 = d.length_squared();
            let w = if r2 > 0.0 { n.dot(d).max(0.0) * en.dot(d).abs() / (r2 * r2) } else { 0.0 };
            let to = y - origin;
            let dist = to.length();
            let dir = to / dist.max(f32::MIN_POSITIVE);
            pick.rays += 1;
            weights.push(w);
            let ray = Ray::shadow_checked(origin, dir, dist, eps, eps, v as u32);
            rays.push(ray.unwrap_or_else(|| Ray::touching(origin, n, v as u32)));
        }
    }
    out
}

/// `F_vg` of one vertex from its rays' visibility: `(group, factor)` pairs.
pub(super) fn finish_vertex(visible: &[bool], r: &VertexRays) -> Vec<(u32, f32)> {
    // Per group: sum of F_t / pi_t times the visible share, and of F_t / pi_t.
    let mut sums: Vec<(u32, f64, f64)> = Vec::new();
    for p in &r.picks {
        let span = p.first_ray as usize..(p.first_ray + p.rays) as usize;
        let (mut seen, mut all, mut hits) = (0f64, 0f64, 0u32);
        for (&vis, &w) in visible[span.clone()].iter().zip(&r.weights[span]) {
            all += w as f64;
            if vis {
                seen += w as f64;
                hits += 1;
            }
        }
        let share = if all > 0.0 { seen / all } else { hits as f64 / p.rays.max(1) as f64 };
        let scale = p.scale as f64;
        match sums.iter_mut().find(|e| e.0 == p.group) {
            Some(e) => {
                e.1 += scale * share;
                e.2 += scale;
            }
            None => sums.push((p.group, scale * share, scale)),
        }
    }
    let (num, den) = sums.iter().fold((0.0, 0.0), |a, e| (a.0 + e.1, a.1 + e.2));
    let overall = if den > 0.0 { num / den } else { 0.0 };
    r.unshaded
        .iter()
        .filter_map(|&(g, f_g)| {
            let share = sums.iter().find(|e| e.0 == g).map_or(overall, |e| e.1 / e.2);
            let f = (f_g * share) as f32;
            (f > 0.0).then_some((g, f))
        })
        .collect()
}
