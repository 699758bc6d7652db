//! The path tracer of the reference solver (see the module doc of
//! [`crate::reference`] for the estimator): per-vertex origins and
//! per-triangle normals, next-event estimation to every light, cosine
//! sampling, Russian roulette. Irradiance in W/m^2, lengths in metres.

use super::ReferenceParams;
use crate::trace::ray::{NO_SKIP, Ray};
use crate::sampling::{basis, cosine_hemisphere, Stream};
use crate::scene::prep::PreparedScene;
use crate::scene::Light;
use crate::trace::CpuTracer;
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Where a path currently is: at the vertex it started from, or at a point on a triangle.
#[derive(Clone, Copy, Debug)]
enum At {
    Vertex,
    Triangle { origin: Vec3, normal: Vec3 },
}

/// Precomputed per-vertex and per-triangle data plus the tree.
pub struct Tracer<'a> {
    scene: &'a PreparedScene,
    kd: &'a dyn CpuTracer,
    params: ReferenceParams,
    /// Unit geometric normal of every triangle (zero for degenerate ones).
    tri_normals: Vec<Vec3>,
    /// Origin offset of every triangle, metres.
    tri_offsets: Vec<f32>,
}

/// Sample `i`'s point in `[0, 1)^2`: jittered in cell `i` of a `k x k`
/// grid when `stratified`, else uniform; two draws of `rng` either way.
fn jittered(i: u32, k: u32, stratified: bool, rng: &mut Pcg64Mcg) -> (f32, f32) {
    let (j1, j2): (f32, f32) = (rng.random(), rng.random());
    if stratified {
        (((i % k) as f32 + j1) / k as f32, ((i / k) as f32 + j2) / k as f32)
    } else {
        (j1, j2)
    }
}

/// Cosine-distributed direction around `n` from `(u1, u2)` in `[0, 1)^2`
/// (pdf `cos / pi`): the links' warp ([`cosine_hemisphere`]) in the links'
/// frame ([`basis`]).
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let l = cosine_hemisphere(Vec2::new(u1, u2));
    let (t, b) = basis(n);
    (t * l.x + b * l.y + n * l.z).normalize()
}

/// A few ulps of the coordinates of `p`, so an offset survives rounding.
fn ulp_floor(p: Vec3) -> f32 {
    p.abs().max_element() * 8.0 * f32::EPSILON
}

impl<'a> Tracer<'a> {
    /// The tracer of `scene` through `kd`, with per-triangle data precomputed for `params`.
    pub fn new(scene: &'a PreparedScene, kd: &'a dyn CpuTracer, params: &ReferenceParams) -> Tracer<'a> {
        let mut tri_normals = Vec::with_capacity(scene.triangles.len());
        let mut tri_offsets = Vec::with_capacity(scene.triangles.len());
        for t in &scene.triangles {
            let [a, b, c] = t.map(|i| scene.positions[i as usize]);
            tri_normals.push((b - a).cross(c - a).normalize_or_zero());
            let l = ((b - a).length() + (c - b).length() + (a - c).length()) / 3.0;
            let floor = ulp_floor(a).max(ulp_floor(b)).max(ulp_floor(c));
            tri_offsets.push((params.offset * l).max(floor));
        }
        Tracer { scene, kd, params: *params, tri_normals, tri_offsets }
    }

    /// Origin of vertex `v`'s rays and its offset length (see the module doc).
    fn vertex_origin(&self, v: usize) -> (Vec3, f32) {
        let s = self.scene;
        let p = s.positions[v];
        let n = s.normals[v];
        // Toward the one-ring on border and crease vertices only (as the
        // links' origins): inside a surface the ring's directions cancel,
        // and the rounding left of their sum points anywhere, for example
        // into an object standing on the surface right at the vertex.
        let inward = if s.boundary[v] {
            let toward: Vec3 = s.rings.row(v).iter().map(|&u| (s.positions[u as usize] - p).normalize_or_zero()).sum();
            (toward - n * toward.dot(n)).normalize_or_zero()
        } else {
            Vec3::ZERO
        };
        let d = (self.params.offset * s.mean_edge_length(v)).max(ulp_floor(p));
        (p + (n + inward) * d, d)
    }

    /// Direct irradiance at surface point `p` with normal `n`, shadow rays from `origin`.
    fn direct(&self, p: Vec3, n: Vec3, origin: Vec3, offset: f32) -> Vec3 {
        let mut e = Vec3::ZERO;
        for light in &self.scene.lights {
            match *light {
                Light::Point { position, intensity } => {
                    let d = position - p;
                    let r = d.length();
                    if !(r > 0.0) {
                        // The light sits on the point: the cosine is undefined; count it as facing.
                        let rm = self.params.min_distance;
                        e += intensity / (rm * rm);
                        continue;
                    }
                    let cos = n.dot(d) / r;
                    if cos <= 0.0 {
                        continue;
                    }
                    let rc = r.max(self.params.min_distance);
                    let to = position - origin;
                    let len = to.length();
                    // The links' segment rule: nothing between a touching point and the origin.
                    let visible = Ray::shadow_checked(origin, to / len, len, offset, 0.0, NO_SKIP)
                        .is_none_or(|ray| !self.kd.occluded(&ray));
                    if visible {
                        e += intensity * (cos / (rc * rc));
                    }
                }
                Light::Directional { direction, irradiance } => {
                    let w = -direction.normalize();
                    let cos = n.dot(w);
                    if cos <= 0.0 {
                        continue;
                    }
                    let ray = Ray::new(origin, w);
                    if !self.kd.occluded(&ray) {
                        e += irradiance * cos;
                    }
                }
            }
        }
        e
    }

    /// Vertex `v`'s estimates.
    pub fn vertex(&self, v: usize) -> VertexEstimate {
        let s = self.scene;
        let (origin, offset) = self.vertex_origin(v);
        let n = s.normals[v];
        let e_d = self.direct(s.positions[v], n, origin, offset);
        let samples = self.params.samples_per_vertex.max(1);
        let mut rng = Pcg64Mcg::seed_from_u64(Stream::REFERENCE.hash(self.params.seed, &[v as u64]));
        let k = (samples as f64).sqrt() as u32;
        let stratified = k * k == samples;
        // Per estimate (indirect, sky, both): sum, sum of squares, sum of
        // squared differences within stratum pairs (2j, 2j+1), pair's first.
        let (mut ind, mut sky, mut both) = ([DVec3::ZERO; 4], [DVec3::ZERO; 4], [DVec3::ZERO; 4]);
        let moments = |m: &mut [DVec3; 4], i: u32, x: DVec3| {
            m[0] += x;
            m[1] += x * x;
            if i % 2 == 0 {
                m[3] = x;
            } else {
                m[2] += (x - m[3]) * (x - m[3]);
            }
        };
        for i in 0..samples {
            let (u1, u2) = jittered(i, k, stratified, &mut rng);
            let dir = cosine_direction(n, u1.min(1.0 - f32::EPSILON), u2);
            let (sky_part, est) = self.path(At::Vertex, v, origin, n, e_d, dir, &mut rng);
            let (sky_part, est) = (sky_part.as_dvec3(), est.as_dvec3());
            moments(&mut ind, i, est);
            moments(&mut sky, i, sky_part);
            moments(&mut both, i, sky_part + est);
        }
        let m = samples as f64;
        // Variance of one sample: across neighbouring strata (pairs 2j, 2j+1)
        // when stratified, else the sample variance (see the module doc).
        let pairs = (samples / 2) as f64;
        let stderr = |x: &[DVec3; 4]| {
            let mean = x[0] / m;
            let var = if stratified && pairs > 0.0 {
                x[2] / (2.0 * pairs)
            } else {
                ((x[1] / m - mean * mean) * (m / (m - 1.0).max(1.0))).max(DVec3::ZERO)
            };
            (var / m).map(f64::sqrt).as_vec3()
        };
        VertexEstimate {
            e_direct: e_d,
            e_sky: (sky[0] / m).as_vec3(),
            e_indirect: (ind[0] / m).as_vec3(),
            e_indirect_stderr: stderr(&ind),
            e_total_stderr: stderr(&both),
        }
    }

    /// One path's estimates `(E_sky, E_i)` at vertex `v`, starting along
    /// `dir`: the sky seen along `dir` itself is direct sky light, all
    /// else (emission and sky met after a surface, light reflected by
    /// surfaces) is indirect.
    #[allow(clippy::too_many_arguments)]
    fn path(
        &self,
        start: At,
        v: usize,
        v_origin: Vec3,
        v_normal: Vec3,
        v_direct: Vec3,
        mut dir: Vec3,
        rng: &mut Pcg64Mcg,
    ) -> (Vec3, Vec3) {
        let s = self.scene;
        let mut at = start;
        let mut beta = Vec3::ONE;
        let mut est = Vec3::ZERO;
        for depth in 0..self.params.max_depth {
            let origin = match at {
                At::Vertex => v_origin,
                At::Triangle { origin, .. } => origin,
            };
            let ray = Ray::new(origin, dir);
            let Some(hit) = self.kd.intersect(&ray) else {
                // Left the scene: sky radiance, pi L per cosine-sampled direction.
                if let Some(sky) = &s.sky {
                    let l = beta * sky.radiance(dir) * PI;
                    if depth == 0 {
                        return (l, est);
                    }
                    est += l;
                }
                break;
            };
            let tri = s.triangles[hit.tri as usize];
            let (rho, e_d, emitted, next) = if hit.front {
                let w = hit.barycentrics();
                let p = (0..3).map(|k| s.positions[tri[k] as usize] * w[k]).sum::<Vec3>();
                let rho = (0..3).map(|k| s.albedo[tri[k] as usize] * w[k]).sum::<Vec3>();
                let m_e = (0..3).map(|k| s.emission[tri[k] as usize] * w[k]).sum::<Vec3>();
                let normal = self.tri_normals[hit.tri as usize];
                let o = p + normal * self.tri_offsets[hit.tri as usize];
                let e_d = self.direct(p, normal, o, self.tri_offsets[hit.tri as usize]);
                (rho, e_d, m_e, At::Triangle { origin: o, normal })
            } else if matches!(at, At::Vertex) && tri.contains(&(v as u32)) {
                // Dived under one of the vertex's own triangles: a hit at the vertex itself.
                (s.albedo[v], v_direct, s.emission[v], At::Vertex)
            } else {
                break; // a back face brings no light
            };
            // Emitted radiance M_e / pi, times pi per cosine-sampled direction.
            est += beta * emitted;
            beta *= rho;
            est += beta * e_d;
            if depth + 1 >= self.params.rr_start {
                let survive = beta.max_element().min(1.0).max(self.params.rr_min_survival);
                if rng.random::<f32>() >= survive {
                    break;
                }
                beta /= survive;
            }
            if beta == Vec3::ZERO {
                break;
            }
            let n = match next {
                At::Vertex => v_normal,
                At::Triangle { normal, .. } => normal,
            };
            let (u1, u2): (f32, f32) = (rng.random(), rng.random());
            dir = cosine_direction(n, u1, u2);
            at = next;
        }
        (Vec3::ZERO, est)
    }
}

impl Tracer<'_> {
    /// Outgoing radiance, W/(m^2 sr), toward the eye of `ray`'s first
    /// surface: `M_e / pi + rho / pi (E_d + E_sky + E_i)` at the hit point
    /// `y`, with `E_d` exact at `y` (one shadow ray a light, as at path
    /// vertices) and `E_sky + E_i` the mean of `spp` paths from `y`
    /// (cosine-sampled on a jittered `k x k` grid when `spp` is square),
    /// the same estimator as at the vertices with the triangle's
    /// geometric normal. Albedo: the texture's at `y` on a textured
    /// triangle, else interpolated; emission interpolated. A miss shows the
    /// sky's radiance (black without one); a back face is black.
    pub fn pixel(&self, ray: &Ray, spp: u32, seed: u64) -> Vec3 {
        let s = self.scene;
        let Some(hit) = self.kd.intersect(ray) else {
            return s.sky.as_ref().map_or(Vec3::ZERO, |sky| sky.radiance(ray.dir));
        };
        if !hit.front {
            return Vec3::ZERO;
        }
        let tri = s.triangles[hit.tri as usize];
        let w = hit.barycentrics();
        let lerp = |a: &[Vec3]| (0..3).map(|k| a[tri[k] as usize] * w[k]).sum::<Vec3>();
        let p = lerp(&s.positions);
        let rho = s.textures.as_ref().and_then(|t| t.albedo(hit.tri as usize, w)).unwrap_or_else(|| lerp(&s.albedo));
        let m_e = lerp(&s.emission);
        let normal = self.tri_normals[hit.tri as usize];
        let offset = self.tri_offsets[hit.tri as usize];
        let origin = p + normal * offset;
        let e_d = self.direct(p, normal, origin, offset);
        let spp = spp.max(1);
        let k = (spp as f64).sqrt() as u32;
        let stratified = k * k == spp;
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut e = DVec3::ZERO;
        for i in 0..spp {
            let (u1, u2) = jittered(i, k, stratified, &mut rng);
            let dir = cosine_direction(normal, u1.min(1.0 - f32::EPSILON), u2);
            let start = At::Triangle { origin, normal };
            let (sky, ind) = self.path(start, usize::MAX, origin, normal, e_d, dir, &mut rng);
            e += (sky + ind).as_dvec3();
        }
        let e_total = e_d + (e / spp as f64).as_vec3();
        crate::exchange::bounce::operator::radiosity(rho, e_total, m_e)
    }
}

/// One vertex's reference estimates, W/m^2.
#[derive(Clone, Copy, Debug, Default)]
pub struct VertexEstimate {
    /// Direct irradiance from the lights.
    pub e_direct: Vec3,
    /// Irradiance from the sky.
    pub e_sky: Vec3,
    /// Indirect irradiance.
    pub e_indirect: Vec3,
    /// Standard error of `e_indirect`.
    pub e_indirect_stderr: Vec3,
    /// Standard error of `e_sky + e_indirect`.
    pub e_total_stderr: Vec3,
}
