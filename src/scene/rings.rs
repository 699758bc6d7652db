//! Mesh connectivity: each vertex's one-ring (its edge neighbours) as a
//! [`Csr`] table, the neighbourhood the smoothing, the sample rotations
//! and the vertex order walk.

use crate::csr::Csr;

/// One-rings of `n` vertices over `triangles`: each vertex's edge
/// neighbours, sorted.
pub fn rings_of(triangles: &[[u32; 3]], n: usize) -> Csr {
    let mut pairs: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| (0..3).flat_map(move |k| [(t[k], t[(k + 1) % 3]), (t[(k + 1) % 3], t[k])]))
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    Csr::from_pairs(n, &pairs)
}
