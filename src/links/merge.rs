//! Hits to merged link groups: three barycentric links per front hit,
//! merged per target (f64 accumulation), quantized to f16 with error
//! diffusion. Shared by the CPU and GPU shooting paths.

use bytemuck::{Pod, Zeroable};
use half::f16;

/// `HitRecord::tri` of a ray that left the scene.
pub const HIT_MISS: u32 = u32::MAX;
/// Flag in `HitRecord::tri` of a ray blocked by a back face.
pub const HIT_BACK: u32 = 0x8000_0000;

/// One ray's result, as written by the shooting shader (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HitRecord {
    /// Triangle id, `| HIT_BACK` for a back face, or [`HIT_MISS`].
    pub tri: u32,
    pub u: f32,
    pub v: f32,
    /// Distance, metres.
    pub t: f32,
}

/// Counts of one vertex's rays.
#[derive(Clone, Copy, Debug, Default)]
pub struct HitCounts {
    pub front: u32,
    pub back: u32,
    pub miss: u32,
}

/// Turns one vertex's hits into its merged link group, appended to
/// `targets`/`weights`. `scratch` is reused between calls.
pub fn merge_vertex(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut Vec<(u32, f64)>,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
) -> HitCounts {
    let mut counts = HitCounts::default();
    scratch.clear();
    for h in hits {
        if h.tri == HIT_MISS {
            counts.miss += 1;
            continue;
        }
        if h.tri & HIT_BACK != 0 {
            counts.back += 1;
            continue;
        }
        counts.front += 1;
        let [ia, ib, ic] = triangles[h.tri as usize];
        let (u, v) = (h.u as f64, h.v as f64);
        scratch.push((ia, 1.0 - u - v));
        scratch.push((ib, u));
        scratch.push((ic, v));
    }
    scratch.sort_unstable_by_key(|&(t, _)| t);
    let mut carry = 0.0f64;
    let mut i = 0;
    while i < scratch.len() {
        let target = scratch[i].0;
        let mut sum = 0.0f64;
        while i < scratch.len() && scratch[i].0 == target {
            sum += scratch[i].1;
            i += 1;
        }
        let exact = sum * weight_per_ray + carry;
        let q = f16::from_f64(exact);
        // Barycentrics of zero (a hit exactly on an edge) give no link.
        if q.to_f32() > 0.0 {
            carry = exact - q.to_f64();
            targets.push(target);
            weights.push(q);
        } else {
            carry = exact;
        }
    }
    counts
}
