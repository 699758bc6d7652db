//! Reference images: the reference path tracer seen through a camera, and
//! a score of a picture against one (issue 31's image-space reference).
//!
//! Each pixel's radiance, W/(m^2 sr), is [`super::path::Tracer::pixel`]
//! along the ray through the pixel's centre ([`crate::render::pixel_ray`],
//! the rasterizer's and the CPU renderer's pixel): `M_e / pi + rho / pi
//! (E_d + E_sky + E_i)` at the first surface, with `E_d` exact and
//! `E_sky + E_i` from `spp` paths of the reference estimator. It shares
//! nothing with the link solver but the triangle test, so a render of the
//! link solution can be checked against it at the same camera and size.
//!
//! Score ([`score`]): per 8 x 8 block, the mean Rec. 709 luminance of each
//! image; the *mean ratio* is the picture's mean luminance over the
//! reference's; the *block error* the mean of `|ours - ref| / ref` over the
//! blocks whose reference luminance exceeds 1% of the reference's mean
//! (blocks that see nothing lit are left out).

use super::path::Tracer;
use super::ReferenceParams;
use crate::render::exposure::luminance;
use crate::render::{pixel_ray, HdrImage};
use crate::sampling::Stream;
use crate::scene::prep::PreparedScene;
use crate::scene::Camera;
use crate::trace::CpuTracer;
use rayon::prelude::*;

/// Side of the score's blocks, pixels.
pub const BLOCK: u32 = 8;

/// How a picture compares with a reference image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageScore {
    /// Mean luminance of the picture over the reference's.
    pub mean_ratio: f64,
    /// Mean relative error of the blocks' luminance (lit blocks only).
    pub block_error: f64,
    /// Blocks counted in `block_error`.
    pub blocks: usize,
}

/// The reference image of `scene` through `camera`, `width` x `height`,
/// `spp` paths per pixel; `accel` is a CPU tracer over the scene's
/// triangles. `progress` is called with each finished row (from any thread).
#[allow(clippy::too_many_arguments)]
pub fn render(
    scene: &PreparedScene,
    accel: &dyn CpuTracer,
    camera: &Camera,
    width: u32,
    height: u32,
    spp: u32,
    params: &ReferenceParams,
    progress: &(dyn Fn() + Sync),
) -> HdrImage {
    let tracer = Tracer::new(scene, accel, params);
    let (lo, hi) = scene.bounds();
    let extent = (hi - lo).length().max(1e-6);
    let (w, h) = (width.max(1), height.max(1));
    let rows: Vec<Vec<glam::Vec3>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w)
                .map(|x| {
                    let ray = pixel_ray(camera, w, h, extent, x, y);
                    let i = (y * w + x) as u64;
                    tracer.pixel(&ray, spp, Stream::REFERENCE_PIXELS.hash(params.seed, &[i]))
                })
                .collect();
            progress();
            row
        })
        .collect();
    HdrImage { width: w, height: h, pixels: rows.concat() }
}

/// Mean luminance of each `BLOCK` x `BLOCK` block (partial blocks at the
/// right and bottom edges included), row-major.
fn block_means(img: &HdrImage) -> Vec<f64> {
    let (bw, bh) = (img.width.div_ceil(BLOCK), img.height.div_ceil(BLOCK));
    let mut sum = vec![0f64; (bw * bh) as usize];
    let mut count = vec![0u32; (bw * bh) as usize];
    for y in 0..img.height {
        for x in 0..img.width {
            let b = ((y / BLOCK) * bw + x / BLOCK) as usize;
            sum[b] += luminance(img.at(x, y)) as f64;
            count[b] += 1;
        }
    }
    sum.iter().zip(&count).map(|(s, &c)| s / c.max(1) as f64).collect()
}

/// Scores `ours` against `reference` (same size; `None` otherwise or when
/// the reference is black).
pub fn score(ours: &HdrImage, reference: &HdrImage) -> Option<ImageScore> {
    if (ours.width, ours.height) != (reference.width, reference.height) || ours.pixels.is_empty() {
        return None;
    }
    let mean = |img: &HdrImage| img.pixels.iter().map(|&p| luminance(p) as f64).sum::<f64>() / img.pixels.len() as f64;
    let ref_mean = mean(reference);
    if !(ref_mean > 0.0) {
        return None;
    }
    let (a, b) = (block_means(ours), block_means(reference));
    let lit: Vec<f64> =
        a.iter().zip(&b).filter(|(_, &r)| r > 0.01 * ref_mean).map(|(o, r)| (o - r).abs() / r).collect();
    Some(ImageScore {
        mean_ratio: mean(ours) / ref_mean,
        block_error: if lit.is_empty() { 0.0 } else { lit.iter().sum::<f64>() / lit.len() as f64 },
        blocks: lit.len(),
    })
}
