//! Vertex orders for the link-encoding checks (`tests/measured.rs`)
//! and the gather bench (`benches/solver.rs`): Morton and Hilbert curves
//! over positions, a shuffle, breadth-first over one-rings, and the links
//! renumbered into an order. Orders are `old_of_new` (the old vertex at
//! each new place).
#![allow(dead_code)]

use glam::Vec3;
use linkgi::links::Links;
use linkgi::scene::prep::Csr;

/// The corner and edge of the cube around the points.
fn cube(p: &[Vec3]) -> (Vec3, f32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for q in p {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    (lo, (hi - lo).max_element().max(1e-30))
}

fn sorted_by_key(p: &[Vec3], key: impl Fn(Vec3) -> u64) -> Vec<u32> {
    let mut keys: Vec<(u64, u32)> = p.iter().enumerate().map(|(i, q)| (key(*q), i as u32)).collect();
    keys.sort_unstable();
    keys.iter().map(|k| k.1).collect()
}

/// Morton (Z) order over positions, 21 bits an axis.
pub fn morton(p: &[Vec3]) -> Vec<u32> {
    let (lo, ext) = cube(p);
    let spread = |mut x: u64| {
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    sorted_by_key(p, |q| {
        let c = ((q - lo) / ext * 2097151.0).as_uvec3();
        spread(c.x as u64) | spread(c.y as u64) << 1 | spread(c.z as u64) << 2
    })
}

/// Hilbert order over positions (Skilling's transpose algorithm, 16 bits an axis).
pub fn hilbert(p: &[Vec3]) -> Vec<u32> {
    let (lo, ext) = cube(p);
    const BITS: u32 = 16;
    sorted_by_key(p, |q| {
        let c = ((q - lo) / ext * 65535.0).as_uvec3();
        let mut x = [c.x, c.y, c.z];
        let m = 1u32 << (BITS - 1);
        // Inverse undo excess work.
        let mut qb = m;
        while qb > 1 {
            let pm = qb - 1;
            for i in 0..3 {
                if x[i] & qb != 0 {
                    x[0] ^= pm;
                } else {
                    let t = (x[0] ^ x[i]) & pm;
                    x[0] ^= t;
                    x[i] ^= t;
                }
            }
            qb >>= 1;
        }
        // Gray encode.
        for i in 1..3 {
            x[i] ^= x[i - 1];
        }
        let mut t = 0;
        let mut qb = m;
        while qb > 1 {
            if x[2] & qb != 0 {
                t ^= qb - 1;
            }
            qb >>= 1;
        }
        for v in &mut x {
            *v ^= t;
        }
        // The transposed bits interleaved, most significant first.
        let mut k = 0u64;
        for b in (0..BITS).rev() {
            for v in &x {
                k = k << 1 | ((v >> b) & 1) as u64;
            }
        }
        k
    })
}

/// A fixed pseudo-random permutation of `0..n` (xorshift Fisher-Yates):
/// an exporter that scrambles vertices.
pub fn shuffled(n: usize) -> Vec<u32> {
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for i in (1..n).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        order.swap(i, (state % (i as u64 + 1)) as usize);
    }
    order
}

/// Breadth-first over the one-rings `rings`, from each unvisited vertex
/// of `starts` in turn (the first step of Cuthill-McKee).
pub fn breadth_first(rings: &Csr, starts: &[u32]) -> Vec<u32> {
    linkgi::scene::order::breadth_first_from(rings, starts.iter().copied())
}

/// `links` with the vertices renumbered into `old_of_new`: group `i` is
/// old vertex `old_of_new[i]`'s, its targets renumbered and sorted.
pub fn renumbered(links: &Links, old_of_new: &[u32]) -> Links {
    let n = old_of_new.len();
    let mut new_of_old = vec![0u32; n];
    for (i, &o) in old_of_new.iter().enumerate() {
        new_of_old[o as usize] = i as u32;
    }
    let (mut offsets, mut targets, mut weights) = (vec![0u32], Vec::new(), Vec::new());
    let mut row: Vec<(u32, half::f16)> = Vec::new();
    for &old in old_of_new {
        let (t, w) = links.group(old as usize);
        row.clear();
        row.extend(t.iter().zip(w).map(|(&t, &w)| (new_of_old[t as usize], w)));
        row.sort_unstable_by_key(|x| x.0);
        targets.extend(row.iter().map(|x| x.0));
        weights.extend(row.iter().map(|x| x.1));
        offsets.push(targets.len() as u32);
    }
    Links::from_csr(offsets, &targets, weights)
}
