//! Hits to merged link groups: three barycentric links per front hit,
//! merged per target (f64 accumulation), quantized to f16 with error
//! diffusion. Shared by the CPU and GPU shooting paths.
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
/// to summed weight (slots [`MergeScratch::EMPTY`] between calls) and the
/// list of slots in use.
#[derive(Clone, Debug, Default)]
pub struct MergeScratch {
    keys: Vec<u32>,
    sums: Vec<f64>,
    used: Vec<u32>,
    groups: Vec<u64>,
}

impl MergeScratch {
    const EMPTY: u32 = u32::MAX;

    /// Adds `w` to `target`'s sum.
    #[inline(always)]
    fn add(&mut self, target: u32, w: f64) {
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

/// Turns one vertex's hits into its merged link group, appended to
/// `targets`/`weights`. `scratch` is reused between calls.
pub fn merge_vertex(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut MergeScratch,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
) -> HitCounts {
    let mut counts = HitCounts::default();
    // At most half full: a power of two at least twice the raw links.
    let size = (6 * hits.len()).next_power_of_two().max(64);
    if scratch.keys.len() < size {
        scratch.keys = vec![MergeScratch::EMPTY; size];
        scratch.sums = vec![0.0; size];
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
        let (u, v) = (h.u as f64, h.v as f64);
        scratch.add(ia, 1.0 - u - v);
        scratch.add(ib, u);
        scratch.add(ic, v);
    }
    let MergeScratch { keys, sums, used, groups } = scratch;
    // Sorted by target as plain u64 keys (target above, slot below): a
    // primitive sort, about twice as fast as sorting (target, sum) pairs.
    groups.clear();
    groups.extend(used.iter().map(|&slot| (keys[slot as usize] as u64) << 32 | slot as u64));
    groups.sort_unstable();
    let mut carry = 0.0f64;
    for &key in groups.iter() {
        let (target, slot) = ((key >> 32) as u32, (key & 0xffff_ffff) as usize);
        keys[slot] = MergeScratch::EMPTY;
        let exact = sums[slot] * weight_per_ray + carry;
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
