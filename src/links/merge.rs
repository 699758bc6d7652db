//! Hits to merged link groups: three barycentric links per front hit,
//! merged per target, quantized to f16 with error diffusion. Shared by the
//! CPU and GPU shooting paths.
//!
//! Sums are fixed point: each barycentric weight is rounded to a multiple
//! of `1 / fixed_scale(rays)` ([`fixed_scale`]: at least 2^-23 of a ray's
//! weight at 256 rays, far below the f16 step of 2^-11) and added as an
//! integer, so a group's sums do not depend on the order of its rays. That
//! is what lets a selective update patch a group (subtract the old hits of
//! the rays that changed, add the new ones, [`requantize`]) and get exactly
//! the group a full merge gives. A target with a non-zero sum always keeps
//! a link: where its weight rounds to zero in f16 it gets the smallest
//! positive f16 (2^-24) and the difference goes to the carry.
//!
//! Merging: the raw links of a vertex (three per front hit) are summed
//! per target in an open-addressing hash table ([`MergeScratch`], ray
//! order), then only the distinct targets are sorted. Sorting every raw
//! link instead took about 40% of the link stage (conference: 9.9 M rays/s
//! traced, 6.1 M/s with merging).

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

/// Reusable buffers of [`merge_vertex`]: a hash table from target vertex
/// to summed weight (slots empty between calls) and the
/// list of slots in use.
#[derive(Clone, Debug, Default)]
pub struct MergeScratch {
    keys: Vec<u32>,
    sums: Vec<u64>,
    used: Vec<u32>,
    groups: Vec<u64>,
    group_sums: Vec<u32>,
}

impl MergeScratch {
    const EMPTY: u32 = u32::MAX;

    /// Adds `w` to `target`'s sum.
    #[inline(always)]
    fn add(&mut self, target: u32, w: u64) {
        let mask = self.keys.len() - 1;
        let mut h = (target.wrapping_mul(0x9E37_79B1) >> 7) as usize & mask;
        loop {
            let k = self.keys[h];
            if k == target {
                self.sums[h] += w;
                return;
            }
            if k == Self::EMPTY {
                self.keys[h] = target;
                self.sums[h] = w;
                self.used.push(h as u32);
                return;
            }
            h = (h + 1) & mask;
        }
    }
}

/// The fixed-point scale of merged sums for `rays` rays per vertex: a
/// power of two such that `rays` whole weights still fit in a `u32`.
pub fn fixed_scale(rays: usize) -> f64 {
    let bits = usize::BITS - rays.max(1).saturating_sub(1).leading_zeros();
    (1u64 << (31 - bits.min(31))) as f64
}

/// A barycentric weight in fixed point (`x` clamped to [0, 1]).
#[inline(always)]
pub fn to_fixed(x: f64, scale: f64) -> u64 {
    (x.clamp(0.0, 1.0) * scale).round() as u64
}

/// The three fixed-point corner weights of a front hit at barycentrics `(u, v)`.
#[inline(always)]
pub fn corner_weights(u: f32, v: f32, scale: f64) -> [u64; 3] {
    let (u, v) = (u as f64, v as f64);
    [to_fixed(1.0 - u - v, scale), to_fixed(u, scale), to_fixed(v, scale)]
}

/// Appends the f16 weights of a group given as fixed-point sums (targets
/// sorted, sums non-zero) to `weights`: `sum / scale * weight_per_ray`,
/// rounded to f16 in target order with the rounding error carried to the
/// next link; a weight that rounds to zero becomes the smallest positive f16.
pub fn requantize(sums: impl Iterator<Item = u32>, weight_per_ray: f64, scale: f64, weights: &mut Vec<f16>) {
    let unit = weight_per_ray / scale;
    let mut carry = 0.0f64;
    for sum in sums {
        let exact = sum as f64 * unit + carry;
        let mut q = f16::from_f64(exact);
        // `exact` is finite (finite sums and weights), so q is never NaN.
        if q.to_f32() <= 0.0 {
            q = f16::from_bits(1);
        }
        carry = exact - q.to_f64();
        weights.push(q);
    }
}

/// Turns one vertex's hits (one per ray) into its merged link group,
/// appended to `targets`/`weights`; with `sums`, also appends each link's
/// fixed-point sum ([`fixed_scale`] of `hits.len()`). `scratch` is reused
/// between calls.
pub fn merge_vertex(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut MergeScratch,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
) -> HitCounts {
    merge_vertex_sums(hits, triangles, weight_per_ray, scratch, targets, weights, None)
}

/// [`merge_vertex`], also appending the fixed-point sums to `sums` when given.
pub fn merge_vertex_sums(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut MergeScratch,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
    sums: Option<&mut Vec<u32>>,
) -> HitCounts {
    let mut counts = HitCounts::default();
    let scale = fixed_scale(hits.len());
    // At most half full: a power of two at least twice the raw links.
    let size = (6 * hits.len()).next_power_of_two().max(64);
    if scratch.keys.len() < size {
        scratch.keys = vec![MergeScratch::EMPTY; size];
        scratch.sums = vec![0; size];
    }
    scratch.used.clear();
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
        let [wa, wb, wc] = corner_weights(h.u, h.v, scale);
        scratch.add(ia, wa);
        scratch.add(ib, wb);
        scratch.add(ic, wc);
    }
    let MergeScratch { keys, sums: table, used, groups, group_sums } = scratch;
    // Sorted by target as plain u64 keys (target above, slot below): a
    // primitive sort, about twice as fast as sorting (target, sum) pairs.
    groups.clear();
    groups.extend(used.iter().map(|&slot| (keys[slot as usize] as u64) << 32 | slot as u64));
    groups.sort_unstable();
    let first = targets.len();
    group_sums.clear();
    for &key in groups.iter() {
        let (target, slot) = ((key >> 32) as u32, (key & 0xffff_ffff) as usize);
        keys[slot] = MergeScratch::EMPTY;
        // Zero sums (hits exactly on an edge or corner) give no link.
        if table[slot] > 0 {
            targets.push(target);
            group_sums.push(table[slot] as u32);
        }
    }
    debug_assert_eq!(targets.len() - first, group_sums.len());
    requantize(group_sums.iter().copied(), weight_per_ray, scale, weights);
    if let Some(sums) = sums {
        sums.extend_from_slice(group_sums);
    }
    counts
}
