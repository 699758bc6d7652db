//! Solver vertex order (issue 16): a vertex's link targets are mostly its
//! neighbours' neighbours, so vertices that are close on the surface
//! should be close in number. The packed links ([`crate::links::packed`])
//! code a target as the gap to the previous one, and half their gaps are 0
//! when meshes come in strips of neighbouring vertices, as the built-in
//! scenes and most exporters write them (solver vertices are numbered in
//! the order of their first triangle corner, [`super::prep`]).
//!
//! A mesh whose triangles come in scrambled order gets its vertices
//! renumbered breadth-first over its edges (the first step of
//! Cuthill-McKee: each vertex's unnumbered neighbours next), which gives
//! strips again, when that improves the mesh's [`locality`] by at least
//! [`MIN_GAIN`]. A mesh in good order is left alone, so the built-in
//! scenes keep their order. Renumbering stays inside a mesh (its vertex
//! range is unchanged) and is a permutation of solver vertices, so
//! one-rings, crease splits and every result per vertex are the same, in
//! the new order; exports list solver vertices in that order.
//!
//! Measured (`cargo test --release --test measured -- --ignored
//! scene_order_keeps_link_targets_compact`, 256 rays, bytes a link of the
//! packed targets with their control bytes): conference in its own order
//! 0.79, scrambled 1.73, scrambled then breadth-first 0.88, a Morton order
//! over positions 1.08, a Hilbert order 1.01 (a space-filling curve over 3D
//! points breaks the strips, and the gather was 5-10% slower in Morton order
//! than in the scene's, `cargo bench --bench solver -- gather_bounce`);
//! tearoom 0.64, 1.22, 0.69, 0.81, 0.76.

/// The least relative improvement of [`locality`] for which a mesh is renumbered.
pub const MIN_GAIN: f64 = 0.2;

/// Mean of `log2(1 + |a - b|)` over the edges `(a, b)` of `triangles`
/// (local vertex numbers): about the bytes of a gap between neighbours,
/// in bits. 0 for a mesh without triangles.
pub fn locality(triangles: &[[u32; 3]]) -> f64 {
    if triangles.is_empty() {
        return 0.0;
    }
    let sum: f64 = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
        .map(|(a, b)| (1.0 + a.abs_diff(b) as f64).log2())
        .sum();
    sum / (3 * triangles.len()) as f64
}

/// Breadth-first order of `n` vertices over the edges of `triangles`:
/// `order[new] = old`. Each connected part starts at its lowest-numbered
/// vertex; neighbours are taken in increasing number.
pub fn breadth_first(triangles: &[[u32; 3]], n: usize) -> Vec<u32> {
    breadth_first_from(&super::rings::rings_of(triangles, n), 0..n as u32)
}

/// Breadth-first numbering over the one-rings `rings`, each component
/// started at the first vertex of `starts` not yet numbered (`order[new] = old`).
pub fn breadth_first_from(rings: &crate::csr::Csr, starts: impl IntoIterator<Item = u32>) -> Vec<u32> {
    let n = rings.rows();
    let mut seen = vec![false; n];
    let mut order = Vec::with_capacity(n);
    for s in starts {
        let s = s as usize;
        if seen[s] {
            continue;
        }
        seen[s] = true;
        let mut head = order.len();
        order.push(s as u32);
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            for &u in rings.row(v) {
                if !seen[u as usize] {
                    seen[u as usize] = true;
                    order.push(u);
                }
            }
        }
    }
    order
}

/// The new order of a mesh's `n` vertices (`order[new] = old`) if
/// breadth-first numbering improves its [`locality`] by [`MIN_GAIN`] or
/// more; `None` keeps the order.
pub fn better_order(triangles: &[[u32; 3]], n: usize) -> Option<Vec<u32>> {
    let order = breadth_first(triangles, n);
    let mut new_of_old = vec![0u32; n];
    for (new, &old) in order.iter().enumerate() {
        new_of_old[old as usize] = new as u32;
    }
    let renumbered: Vec<[u32; 3]> = triangles.iter().map(|t| t.map(|v| new_of_old[v as usize])).collect();
    (locality(&renumbered) < (1.0 - MIN_GAIN) * locality(triangles)).then_some(order)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w x h` grid of quads, vertices row by row (strips), two triangles a quad.
    fn grid(w: u32, h: u32) -> Vec<[u32; 3]> {
        let mut t = Vec::new();
        for y in 0..h - 1 {
            for x in 0..w - 1 {
                let a = y * w + x;
                t.push([a, a + 1, a + w]);
                t.push([a + 1, a + w + 1, a + w]);
            }
        }
        t
    }

    /// The grid with its vertices numbered by a fixed scrambling permutation.
    fn scrambled(t: &[[u32; 3]], n: u32) -> Vec<[u32; 3]> {
        // 7919 is prime and does not divide n: a permutation of 0..n.
        t.iter().map(|t| t.map(|v| (v * 7919 + 13) % n)).collect()
    }

    #[test]
    fn breadth_first_is_a_permutation_that_restores_strips() {
        let (w, h) = (40, 30);
        let t = scrambled(&grid(w, h), w * h);
        let order = breadth_first(&t, (w * h) as usize);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..w * h).collect::<Vec<_>>());
        let better = better_order(&t, (w * h) as usize).expect("a scrambled grid is renumbered");
        assert_eq!(better, order);
        let mut new_of_old = vec![0u32; (w * h) as usize];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        let renumbered: Vec<[u32; 3]> = t.iter().map(|t| t.map(|v| new_of_old[v as usize])).collect();
        let (before, after, strips) = (locality(&t), locality(&renumbered), locality(&grid(w, h)));
        // Scrambled 7.9 bits, breadth-first 4.1, the strips 3.9.
        assert!(after < 0.6 * before, "locality {before} -> {after}");
        assert!(after < 1.1 * strips, "breadth-first {after} against strips {strips}");
    }

    #[test]
    fn a_mesh_in_strips_keeps_its_order() {
        let t = grid(40, 30);
        assert_eq!(better_order(&t, 1200), None);
        assert_eq!(better_order(&[], 0), None);
    }

    #[test]
    fn separate_parts_are_numbered_one_after_another() {
        // Two triangles sharing nothing, interleaved numbers.
        let t = [[0, 2, 4], [1, 3, 5]];
        assert_eq!(breadth_first(&t, 6), vec![0, 2, 4, 1, 3, 5]);
    }
}
