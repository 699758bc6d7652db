//! Memory traffic of a gather bounce against the machine's read bandwidth
//! (the target: one bounce at >= 50% of it).
//!
//! A CPU bounce ([`crate::exchange::bounce::gather::gather_bounce_padded`]) streams
//! every link once as the gathers store it ([`Links::gather_bytes`]: packed
//! targets, f16 weights, row offsets), reads the source radiosity (16 bytes a vertex, padded,
//! counted once: a lower bound, repeated reads hit the cache) and writes the
//! result (12 bytes a vertex). The reference is a parallel (rayon) sum over a
//! buffer far larger than the caches: the read bandwidth a streaming
//! kernel can reach on this machine. Units: bytes and GB/s (1e9 bytes/s).

use crate::links::Links;
use rayon::prelude::*;
use std::time::Instant;

/// Bytes one gather bounce moves at least.
pub fn gather_bytes(links: &Links) -> u64 {
    let v = links.vertex_count() as u64;
    links.gather_bytes() + v * (16 + 12)
}

/// Read bandwidth of a parallel sum over `bytes` (best of `repeats`), GB/s.
pub fn read_bandwidth_gbps(bytes: usize, repeats: u32) -> f64 {
    let data = vec![1u64; (bytes / 8).max(1)];
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let s: u64 = data.par_chunks(1 << 16).map(|c| c.iter().fold(0u64, |a, &x| a.wrapping_add(x))).sum();
        let secs = t.elapsed().as_secs_f64();
        assert_eq!(s, data.len() as u64, "bandwidth probe summed wrong");
        best = best.min(secs);
    }
    (data.len() * 8) as f64 / best.max(1e-12) / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_bytes_counts_links_offsets_and_vertices() {
        let links = Links::from_csr(vec![0, 2, 3], &[0, 1, 0], vec![half::f16::ONE; 3]);
        // Packed: row 0 one block (control byte, gaps 0 and 0), row 1 one
        // block (gap 0); starts 3 x 4, padding 16; weights 3 x 2; offsets 3 x 4.
        assert_eq!(links.packed.bytes.len(), 2 + 16);
        assert_eq!(gather_bytes(&links), (2 + 16 + 3 * 4) + 3 * 2 + 3 * 4 + 2 * 28);
    }

    #[test]
    fn bandwidth_is_finite_and_positive() {
        let g = read_bandwidth_gbps(8 << 20, 2);
        assert!(g.is_finite() && g > 0.01, "{g} GB/s");
    }
}
