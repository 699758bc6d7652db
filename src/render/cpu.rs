//! CPU fallback renderer (no adapter): one primary ray per pixel centre
//! through a CPU tracer (a wide BVH of the frame's triangles unless one is given); at a front-face hit the
//! normal, albedo and `E_i` are interpolated with the hit's barycentrics (on a
//! textured triangle the albedo is the texture's at the hit, the same
//! sampling as the GPU's) and
//! each light's visibility is one shadow ray from the hit offset along the
//! normal (hard shadows). Back faces are black, misses show the sky's
//! radiance along the ray (black in the indirect view or without a sky). Radiance as in [`super`]:
//! `L = rho / pi * (E_d + E_sky + E_i) + M_e / pi`; rows run in parallel (rayon).

use super::{pixel_ray, Frame, HdrImage, RenderParams, RenderStats, View};
use crate::bvh::{Bvh, BvhBuildParams};
use crate::exchange::bounce::operator::radiosity;
use crate::trace::ray::NO_SKIP;
use crate::trace::ray::Ray;
use crate::scene::Light;
use crate::trace::CpuTracer;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Renders `frame`; `kd` (any CPU tracer) must be built over
/// `frame.positions`/`triangles` when given, else a BVH is built here.
pub fn render_cpu(
    frame: &Frame,
    params: &RenderParams,
    kd: Option<&dyn CpuTracer>,
) -> crate::Result<(HdrImage, RenderStats)> {
    frame.validate()?;
    let t0 = Instant::now();
    let built;
    let kd: &dyn CpuTracer = match kd {
        Some(k) => k,
        None => {
            built = Bvh::build(frame.positions, frame.triangles, &BvhBuildParams::default());
            &built
        }
    };
    let (w, h) = (params.width.max(1), params.height.max(1));
    let extent = frame.extent();
    let offset = params.normal_offset * extent;
    let pixels: Vec<Vec3> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..w).map(move |x| {
                let ray = pixel_ray(&frame.camera, w, h, extent, x, y);
                shade(frame, kd, params.view, offset, ray)
            })
        })
        .collect();
    let stats = RenderStats { ms: t0.elapsed().as_secs_f64() * 1e3, ..Default::default() };
    Ok((HdrImage { width: w, height: h, pixels }, stats))
}

fn shade(frame: &Frame, kd: &dyn CpuTracer, view: View, offset: f32, ray: Ray) -> Vec3 {
    let Some(hit) = kd.intersect(&ray) else {
        return match (frame.sky, view) {
            (Some(sky), View::Combined | View::Direct) => sky.radiance(ray.dir),
            _ => Vec3::ZERO,
        };
    };
    if !hit.front {
        return Vec3::ZERO;
    }
    let t = frame.triangles[hit.tri as usize];
    let b = hit.barycentrics();
    let lerp = |a: &[Vec3]| a[t[0] as usize] * b[0] + a[t[1] as usize] * b[1] + a[t[2] as usize] * b[2];
    let p = ray.origin + ray.dir * hit.t;
    let n = lerp(frame.normals).normalize_or_zero();
    let rho = frame.textures.and_then(|tex| tex.albedo(hit.tri as usize, b)).unwrap_or_else(|| lerp(frame.albedo));
    let e_i = lerp(frame.e_indirect);
    let at = |f: &dyn Fn(usize) -> Vec3| f(t[0] as usize) * b[0] + f(t[1] as usize) * b[1] + f(t[2] as usize) * b[2];
    let e_sky = at(&|v| frame.sky_at(v));
    let emitted = at(&|v| frame.emitted_at(v));
    let origin = p + n * offset;
    let mut e_d = Vec3::ZERO;
    if view != View::Indirect {
        for l in frame.lights {
            match *l {
                Light::Point { position, intensity } => {
                    let d = position - p;
                    let r2 = d.length_squared().max(1e-8);
                    let c = n.dot(d) / r2.sqrt();
                    if c <= 0.0 {
                        continue;
                    }
                    let to = position - origin;
                    let dist = to.length();
                    let shadow = Ray::shadow(origin, to / dist, dist, 0.0, 0.0, NO_SKIP);
                    if !kd.occluded(&shadow) {
                        e_d += intensity * (c / r2);
                    }
                }
                Light::Directional { direction, irradiance } => {
                    let c = n.dot(-direction);
                    if c <= 0.0 {
                        continue;
                    }
                    if !kd.occluded(&Ray::new(origin, -direction)) {
                        e_d += irradiance * c;
                    }
                }
            }
        }
    }
    match view {
        View::Combined => radiosity(rho, e_d + e_sky + e_i, Vec3::ZERO) + emitted,
        View::Direct => radiosity(rho, e_d + e_sky, Vec3::ZERO) + emitted,
        View::Indirect => radiosity(rho, e_i, Vec3::ZERO),
    }
}
