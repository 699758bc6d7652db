//! The near field (docs/DESIGN.md §4): where a link ray meets a triangle
//! close by ([`crate::links::near`]), the radiance the link brings,
//! interpolated from the hit triangle's corners, is replaced by the
//! radiance at the hit itself. Every term has one formula,
//!
//! ```text
//! D(x) = 1/n * sum over kept near hits k of w_k [ rho(h_k) X^(h_k) - sum_c beta_c rho_c X(c) ]
//! ```
//!
//! with `X^(h)` the field estimated at the hit (traced when the term is
//! built), `X(c)` the corners' field as the links read it, `beta_c` the
//! hit's barycentrics, `rho` albedo, `n` the link rays of vertex `x` and
//! `w_k` the near hits the kept one stands for (1, or more where the
//! vertex kept a sample of its near hits: [`crate::links::near::NearRule`]).
//! `D` is irradiance at `x`, W/m^2, of either sign. Four terms implement
//! [`NearTerm`]:
//!
//! | term | field `X` | bounce it corrects |
//! |---|---|---|
//! | [`light::NearLight`] | the point and directional lights' direct light | first |
//! | [`emitters::NearEmitters`] | the emissive surfaces' direct light | first |
//! | [`sky::NearSky`] | the sky's light | first |
//! | [`gather::NearGather`] | the later bounces' light (a final gather from the hit) | later |
//!
//! The first-bounce terms are added to the bounces' source (their
//! reflections travel on through the links) and to `E_i`; the later
//! bounces' term is added to the gathered `E_i` after the bounces.
//! [`NearField`] holds the four and sums them ([`NearField::correction`]).
//! Each term stores what a new intensity, emission or sky needs without
//! tracing (columns, coefficients, directions, landing points).
//!
//! This module also holds what the four share: the batches their rays are
//! traced in ([`trace_by_vertex`]), a hit's frame ([`hit_frame`]), where
//! its rays start ([`hit_origin`]), the rank its samples hash from
//! ([`crate::links::near::triangle_ranks`], [`crate::sampling::Stream::hit_key`]) and the
//! interpolated term ([`albedo_and_interpolated`]). Lengths in metres.

use crate::trace::ray::{Hit, Ray};
use crate::links::{NearHit, NearHits};
use crate::scene::motion::Motion;
use crate::scene::prep::PreparedScene;
use crate::scene::Light;
use crate::sky::Sky;
use crate::trace::Tracer;
use glam::Vec3;
use rayon::prelude::*;

pub mod emitters;
pub mod gather;
pub mod light;
pub mod sky;

pub use emitters::{NearEmitterParams, NearEmitters};
pub use gather::{NearGather, NearGatherParams};
pub use light::NearLight;
pub use sky::{NearSky, NearSkyParams};

/// Which bounce a term corrects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounce {
    /// The first bounce: added to the bounces' source and to `E_i`.
    First,
    /// The later bounces: added to the gathered `E_i`.
    Later,
}

/// The fields the terms read at solve time, as the links read them
/// (gradient-corrected where the radiosity correction is on). A field a
/// solve does not have is empty.
#[derive(Clone, Copy, Debug)]
pub struct Fields<'a> {
    /// The prepared scene.
    pub scene: &'a PreparedScene,
    /// The near hits the terms were traced from.
    pub near: &'a NearHits,
    /// Link rays per vertex (`n`).
    pub rays_per_vertex: u32,
    /// The lights, and their bounce source at the vertices, W/m^2.
    pub lights: &'a [Light],
    /// The lights' bounce source at each vertex, W/m^2.
    pub e_lights: &'a [Vec3],
    /// The sky and the vertices' sky light, W/m^2.
    pub sky: Option<&'a Sky>,
    /// The sky light at each vertex, W/m^2.
    pub e_sky: &'a [Vec3],
    /// The vertices' emitted exitance, W/m^2, and each emitter group's vertex.
    pub emission: &'a [Vec3],
    /// Per emitter group, a vertex whose emission is the group's exitance.
    pub group_vertex: &'a [u32],
    /// After the bounces: the total radiosity the links carry, W/(m^2 sr),
    /// and the gathered irradiance, W/m^2 (hidden vertices' stand-ins applied).
    pub b_later: &'a [Vec3],
    /// The gathered irradiance after the bounces at each vertex, W/m^2.
    pub g_later: &'a [Vec3],
}

/// What a term's rays cost when it was last traced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    /// Rays traced.
    pub rays: u64,
    /// Time of the trace, ms.
    pub ms: f64,
    /// Bytes it keeps.
    pub bytes: u64,
}

/// The sizes a term is validated against.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shape {
    /// Solver vertices.
    pub vertices: usize,
    /// Near hits.
    pub near_hits: usize,
    /// Triangles.
    pub triangles: usize,
    /// Emitter groups.
    pub groups: usize,
}

/// One near-hit term (module doc).
pub trait NearTerm: Sync {
    /// Short name for figures ("lights", "emitters", "sky", "gather").
    fn name(&self) -> &'static str;
    /// The bounce it corrects.
    fn bounce(&self) -> Bounce;
    /// True when it holds nothing to add.
    fn is_empty(&self) -> bool;
    /// `D` at every vertex for `fields`, W/m^2; `None` when there is
    /// nothing to add (no samples, or samples stale for these fields).
    fn correction(&self, fields: &Fields) -> Option<Vec<Vec3>>;
    /// The rays, time and memory of its last trace.
    fn cost(&self) -> Cost;
    /// Checks what it holds against the scene's sizes.
    fn validate(&self, shape: &Shape) -> Result<(), String>;
}

/// The four terms of one set of near hits.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearField {
    /// Correction of the point and directional lights' direct light.
    pub light: NearLight,
    /// Correction of the emissive surfaces' direct light.
    pub emitters: NearEmitters,
    /// Correction of the sky's light.
    pub sky: NearSky,
    /// Correction of the later bounces' light.
    pub gather: NearGather,
}

impl NearField {
    /// The terms, in the order their corrections are summed.
    pub fn terms(&self) -> [&dyn NearTerm; 4] {
        [&self.light, &self.emitters, &self.sky, &self.gather]
    }

    /// The sum of the corrections of the terms of `bounce`, W/m^2; `None`
    /// when none has anything to add.
    pub fn correction(&self, bounce: Bounce, fields: &Fields) -> Option<Vec<Vec3>> {
        let mut sum: Option<Vec<Vec3>> = None;
        for term in self.terms().into_iter().filter(|t| t.bounce() == bounce) {
            let Some(d) = term.correction(fields) else { continue };
            match &mut sum {
                None => sum = Some(d),
                Some(s) => s.iter_mut().zip(&d).for_each(|(s, d)| *s += *d),
            }
        }
        sum
    }

    /// Validates every term.
    pub fn validate(&self, shape: &Shape) -> Result<(), String> {
        for t in self.terms() {
            t.validate(shape).map_err(|e| format!("near field, {}: {e}", t.name()))?;
        }
        Ok(())
    }
}

/// What a batch of rays asks a [`Tracer`]: any-hit visibility (`bool`,
/// true where the segment is free) or the closest hit.
pub trait Query: Sized + Send {
    /// Traces `rays` through `tracer`, one answer per ray, in order.
    fn trace(tracer: &dyn Tracer, rays: &[Ray]) -> crate::Result<Vec<Self>>;
}

impl Query for bool {
    fn trace(tracer: &dyn Tracer, rays: &[Ray]) -> crate::Result<Vec<bool>> {
        tracer.visible(rays)
    }
}

impl Query for Option<Hit> {
    fn trace(tracer: &dyn Tracer, rays: &[Ray]) -> crate::Result<Vec<Option<Hit>>> {
        tracer.closest_hits(rays)
    }
}

/// Near hits a batch of rays is made for (bounds memory: the rays of the
/// whole scene are never held at once).
pub const BATCH_HITS: u32 = 1 << 16;

/// Traces the rays of every vertex's near hits in batches of vertices
/// ([`NearHits::vertex_batches`]): `samples(v, hits)` makes vertex `v`'s
/// data and rays (in parallel), and `take(v, data, answers)` receives its
/// answers in order, vertex after vertex. Returns the rays traced.
pub fn trace_by_vertex<S: Send, A: Query>(
    near: &NearHits,
    vertices: usize,
    tracer: &dyn Tracer,
    samples: impl Fn(usize, &[NearHit]) -> (S, Vec<Ray>) + Sync,
    mut take: impl FnMut(usize, S, &[A]),
) -> crate::Result<u64> {
    let mut traced = 0u64;
    for range in near.vertex_batches(vertices, BATCH_HITS) {
        let v0 = range.start;
        let batch: Vec<(S, Vec<Ray>)> = range.into_par_iter().map(|v| samples(v, near.of(v))).collect();
        let rays: Vec<Ray> = batch.iter().flat_map(|b| b.1.iter().copied()).collect();
        traced += rays.len() as u64;
        let answers = A::trace(tracer, &rays)?;
        let mut at = 0usize;
        for (k, (data, rays)) in batch.into_iter().enumerate() {
            take(v0 + k, data, &answers[at..at + rays.len()]);
            at += rays.len();
        }
    }
    Ok(traced)
}

/// Near hit `h`'s point on its flat triangle, the triangle's unit
/// geometric normal and its longest edge (m, at least `f32::MIN_POSITIVE`):
/// where shadow rays from the hit start ([`crate::exchange::near::emitters`] too).
pub fn hit_frame(scene: &PreparedScene, h: &NearHit) -> (Vec3, Vec3, f32) {
    let [a, b, c] = scene.triangles[h.tri as usize].map(|i| scene.positions[i as usize]);
    let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
    let normal = (b - a).cross(c - a).normalize_or_zero();
    let l = (b - a).length().max((c - b).length()).max((a - c).length()).max(f32::MIN_POSITIVE);
    (p, normal, l)
}

/// The albedo at near hit `h` (`sum_c beta_c rho_c`, interpolated from its
/// triangle's corners).
pub fn hit_albedo(scene: &PreparedScene, h: &NearHit) -> Vec3 {
    albedo_and_interpolated(scene, h, &[]).0
}

/// The correction of every vertex by its near hits' own values, W/m^2:
///
/// ```text
/// D(x) = 1/n * sum over x's near hits k of w_k [ rho(h_k) y_k - sum_c beta_c rho_c X(c) ]
/// ```
///
/// with `y_k = at_hit(k)` (`k` the hit's index in `f.near`) the irradiance
/// at the hit itself, `X` the per-vertex field the links interpolate
/// ([`albedo_and_interpolated`]), `w_k` the hit's weight and `n` the rays a
/// vertex: the one loop of the terms that keep a value per near hit (the
/// lights' near field, the final gather).
pub(super) fn correct_by_hits(f: &Fields, field: &[Vec3], at_hit: impl Fn(usize) -> Vec3 + Sync) -> Vec<Vec3> {
    let (scene, near) = (f.scene, f.near);
    let inv = 1.0 / f.rays_per_vertex.max(1) as f32;
    (0..scene.vertex_count())
        .into_par_iter()
        .map(|v| {
            let first = near.rows.offsets[v] as usize;
            let mut d = Vec3::ZERO;
            for (i, h) in near.of(v).iter().enumerate() {
                let (rho, interpolated) = albedo_and_interpolated(scene, h, field);
                d += (rho * at_hit(first + i) - interpolated) * h.weight;
            }
            d * inv
        })
        .collect()
}

/// The albedo at near hit `h` and what its corners interpolate of the
/// per-vertex irradiance `x` reflected, `sum_c beta_c rho_c x(c)` (W/m^2;
/// `x` empty: zero): what a link brought of `x`'s reflection at the hit,
/// which the near-hit corrections replace.
pub fn albedo_and_interpolated(scene: &PreparedScene, h: &NearHit, x: &[Vec3]) -> (Vec3, Vec3) {
    let tri = scene.triangles[h.tri as usize];
    let beta = [1.0 - h.u - h.v, h.u, h.v];
    let (mut rho, mut interpolated) = (Vec3::ZERO, Vec3::ZERO);
    for c in 0..3 {
        let a = scene.albedo[tri[c] as usize] * beta[c];
        rho += a;
        if let Some(xc) = x.get(tri[c] as usize) {
            interpolated += a * *xc;
        }
    }
    (rho, interpolated)
}

/// Where rays from near hit `h` start, and its triangle's unit normal:
/// `eps` times the triangle's longest edge off the surface and as far into
/// the triangle (toward its centroid). A hit on the edge where the floor
/// meets a wall would otherwise start on the wall's plane, where the CPU
/// and GPU triangle tests answer a ray into the wall either way, and a
/// one-sided wall is all that keeps such a ray in the room
/// ([`crate::exchange::near::sky`], [`crate::exchange::near::gather`]). The lights' and emitters'
/// shadow rays start off the surface only: the step into the triangle,
/// `eps` times its longest edge, moves where visibility is taken in a
/// contact gap (the plate 5 mm above a floor of two 2 m triangles, in
/// `tests/near_field.rs`: its underside under a point light read 0.472
/// against the reference's 0.440 with the step, 0.463 without; under a
/// glowing panel 0.147 against 0.143, 0.144 without).
pub fn hit_origin(scene: &PreparedScene, h: &NearHit, eps: f32) -> (Vec3, Vec3) {
    let (p, normal, l) = hit_frame(scene, h);
    let centroid = scene.triangles[h.tri as usize].map(|i| scene.positions[i as usize]).iter().sum::<Vec3>() / 3.0;
    (p + (normal + (centroid - p).normalize_or_zero()) * (eps * l), normal)
}

/// The near hits before and after a deformation, as the near terms'
/// selective updates (`update_deformed`) read them: a near hit keeps its
/// rays' results unless its vertex's near hits were found anew, it lies
/// on a moved triangle, or a ray's segment meets a box of the motion.
pub struct NearChange<'a> {
    /// The near hits the old results were traced over.
    pub before: &'a NearHits,
    /// The near hits now.
    pub after: &'a NearHits,
    /// Per vertex: its near hits were found anew.
    pub redone: &'a [bool],
    /// The deformation.
    pub motion: &'a Motion,
}

impl NearChange<'_> {
    /// The rows of `before` and `after` are of the same vertices.
    pub fn aligned(&self) -> bool {
        self.before.rows.offsets.len() == self.after.rows.offsets.len()
    }

    /// The index in `before` of near hit `h`, the `i`-th of vertex `v` now,
    /// where it stands unchanged; `None` where it must be traced anew.
    pub fn kept_at(&self, v: usize, i: usize, h: &NearHit) -> Option<usize> {
        (!self.redone[v] && !self.motion.moved_triangle[h.tri as usize])
            .then(|| self.before.rows.offsets[v] as usize + i)
    }

    /// Whether ray `r`'s segment `[r.tmin, tmax]` meets a box of the motion.
    pub fn segment_moved(&self, r: &Ray, tmax: f32) -> bool {
        let inv = r.dir.recip();
        self.motion.boxes.iter().any(|b| b.meets_segment(r.origin, inv, r.tmin, tmax))
    }
}
