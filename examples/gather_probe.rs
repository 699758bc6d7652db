//! Gather experiments (issue 16): one bounce over a scene's links with
//! different radiosity layouts and prefetching, best of 15 runs each:
//! `cargo run --release --example gather_probe -- tearoom`.
use glam::{Vec3, Vec4};
use half::f16;
use half::slice::HalfFloatSliceExt;

use linkgi::scene::{self, prep};
use linkgi::solver::{SolveParams, Solver};
use rayon::prelude::*;
use std::time::Instant;

fn best(label: &str, links: &Links, mut f: impl FnMut()) -> f64 {
    f();
    let mut b = f64::MAX;
    for _ in 0..15 {
        let t = Instant::now();
        f();
        b = b.min(t.elapsed().as_secs_f64() * 1e3);
    }
    let bytes = links.targets.len() as f64 * 6.0;
    println!(
        "{label:40} {b:7.2} ms  {:6.2} G links/s  {:5.1} GB/s of links",
        links.targets.len() as f64 / b / 1e6,
        bytes / b / 1e6
    );
    b
}

const CHUNK: usize = 256;

/// The library's kernel shape: f16 -> f32 buffer per group, four accumulators.
fn gather_f32(links: &Links, b: &[Vec4], out: &mut [Vec3], prefetch: usize) {
    out.par_chunks_mut(CHUNK).enumerate().for_each_init(Vec::new, |buf: &mut Vec<f32>, (ci, chunk)| {
        for (i, o) in chunk.iter_mut().enumerate() {
            let v = ci * CHUNK + i;
            let (targets, weights) = links.group(v);
            if prefetch > 0 {
                // Prefetch the next group's first targets' radiosity.
                let next = links.offsets[(v + 1).min(links.vertex_count())] as usize;
                for k in 0..prefetch {
                    if let Some(&t) = links.targets.get(next + k) {
                        #[cfg(target_arch = "x86_64")]
                        unsafe {
                            std::arch::x86_64::_mm_prefetch(
                                b.as_ptr().add(t as usize) as *const i8,
                                std::arch::x86_64::_MM_HINT_T0,
                            )
                        };
                    }
                }
            }
            buf.resize(weights.len(), 0.0);
            weights.convert_to_f32_slice(buf);
            let mut acc = [Vec4::ZERO; 4];
            let (t4, tr) = targets.as_chunks::<4>();
            let (w4, wr) = buf.as_chunks::<4>();
            for (t, w) in t4.iter().zip(w4) {
                acc[0] += b[t[0] as usize] * w[0];
                acc[1] += b[t[1] as usize] * w[1];
                acc[2] += b[t[2] as usize] * w[2];
                acc[3] += b[t[3] as usize] * w[3];
            }
            for (k, (&t, &w)) in tr.iter().zip(wr).enumerate() {
                acc[k] += b[t as usize] * w;
            }
            *o = ((acc[0] + acc[1]) + (acc[2] + acc[3])).truncate();
        }
    });
}

/// Radiosity as four f16 (8 bytes a vertex).
fn gather_h(links: &Links, b: &[[f16; 4]], out: &mut [Vec3]) {
    out.par_chunks_mut(CHUNK).enumerate().for_each_init(Vec::new, |buf: &mut Vec<f32>, (ci, chunk)| {
        for (i, o) in chunk.iter_mut().enumerate() {
            let (targets, weights) = links.group(ci * CHUNK + i);
            buf.resize(weights.len(), 0.0);
            weights.convert_to_f32_slice(buf);
            let mut acc = [Vec4::ZERO; 4];
            let ld = |t: u32| {
                let h = b[t as usize];
                let mut f = [0f32; 4];
                h.convert_to_f32_slice(&mut f);
                Vec4::from_array(f)
            };
            let (t4, tr) = targets.as_chunks::<4>();
            let (w4, wr) = buf.as_chunks::<4>();
            for (t, w) in t4.iter().zip(w4) {
                acc[0] += ld(t[0]) * w[0];
                acc[1] += ld(t[1]) * w[1];
                acc[2] += ld(t[2]) * w[2];
                acc[3] += ld(t[3]) * w[3];
            }
            for (k, (&t, &w)) in tr.iter().zip(wr).enumerate() {
                acc[k] += ld(t) * w;
            }
            *o = ((acc[0] + acc[1]) + (acc[2] + acc[3])).truncate();
        }
    });
}

/// The links as they were stored before packing: u32 targets beside f16 weights.
struct Links {
    offsets: Vec<u32>,
    targets: Vec<u32>,
    weights: Vec<f16>,
}

impl Links {
    fn vertex_count(&self) -> usize {
        self.offsets.len() - 1
    }
    fn group(&self, v: usize) -> (&[u32], &[f16]) {
        let r = self.offsets[v] as usize..self.offsets[v + 1] as usize;
        (&self.targets[r.clone()], &self.weights[r])
    }
}

fn main() {
    let name = std::env::args().nth(1).unwrap_or_else(|| "tearoom".into());
    let mut desc = scene::load(&name).unwrap();
    desc.settings.rays_per_vertex = 256;
    let scene = prep::prepare(&desc).unwrap();
    let solver = Solver::new(scene, SolveParams::from_settings(&desc.settings), &|_, _| {});
    let packed = &solver.links;
    let wide = Links { offsets: packed.offsets.clone(), targets: packed.targets(), weights: packed.weights.clone() };
    let links = &wide;
    let n = links.vertex_count();
    println!(
        "{name}: {n} vertices, {} links, {:.1} MB of links",
        links.targets.len(),
        links.targets.len() as f64 * 6e-6
    );
    let b: Vec<Vec4> = (0..n).map(|i| Vec4::new(1.0 + (i % 7) as f32, 0.5, 0.25, 0.0)).collect();
    let bh: Vec<[f16; 4]> = b.iter().map(|v| v.to_array().map(f16::from_f32)).collect();
    let mut out = vec![Vec3::ZERO; n];
    best("f32 radiosity (library kernel shape)", links, || gather_f32(links, &b, &mut out, 0));
    let r0 = out.clone();
    best("f32 radiosity, prefetch 8 of next group", links, || gather_f32(links, &b, &mut out, 8));
    best("f16 radiosity (8 B a vertex)", links, || gather_h(links, &bh, &mut out));
    let err = out
        .iter()
        .zip(&r0)
        .map(|(a, b)| ((*a - *b).abs() / b.abs().max(Vec3::splat(1e-6))).max_element())
        .fold(0f32, f32::max);
    println!("f16 radiosity: worst relative difference {err:.2e}");
    best("library gather_bounce_padded (packed)", links, || {
        linkgi::exchange::gather::gather_bounce_padded(packed, &b, &mut out)
    });
}
