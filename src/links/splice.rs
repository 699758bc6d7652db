//! Splicing link groups into a link matrix in place and taking them out
//! again (deformation previews, [`crate::solver::Solver::deform`]): the
//! groups of a few vertices replaced for one solve, then restored, without
//! copying the rows before the first replaced vertex. Rows are the packed
//! form ([`super::packed`]): unchanged rows are copied as bytes.

use super::packed::PackedTargets;
use super::{LinkStats, Links};
use half::f16;

/// What [`splice_groups`] took out of a link matrix: its groups from
/// the first replaced vertex on (offsets, weights, packed rows) and its stats.
#[derive(Debug)]
pub struct Spliced {
    first: usize,
    offsets: Vec<u32>,
    weights: Vec<f16>,
    /// Packed rows `first..` with the padding, starts rebased to the tail.
    tail: PackedTargets,
    stats: LinkStats,
}

/// Replaces the groups of the listed vertices (sorted, distinct) in
/// `links`, in place: the groups before the first listed vertex stay where
/// they are, the rest is moved aside (copied once) and rebuilt. Returns
/// what [`Spliced::restore`] puts back. Cheap when the listed vertices are
/// near the end (a dynamic mesh prepared last).
pub fn splice_groups(links: &mut Links, groups: &[(u32, Vec<u32>, Vec<f16>)]) -> Spliced {
    let n = links.vertex_count();
    let first = groups.first().map_or(n, |g| g.0 as usize);
    let start = links.offsets[first] as usize;
    let byte_start = links.packed.starts[first] as usize;
    let saved = Spliced {
        first,
        offsets: links.offsets.split_off(first + 1),
        weights: links.weights.split_off(start),
        tail: PackedTargets {
            starts: links.packed.starts.split_off(first).iter().map(|s| s - byte_start as u32).collect(),
            bytes: links.packed.bytes.split_off(byte_start),
        },
        stats: links.stats,
    };
    let mut next = groups.iter().peekable();
    for v in first..n {
        match next.peek() {
            Some((g, t, w)) if *g as usize == v => {
                links.packed.push_group(t);
                links.weights.extend_from_slice(w);
                next.next();
            }
            _ => {
                let a = if v == first { start } else { saved.offsets[v - first - 1] as usize };
                let b = saved.offsets[v - first] as usize;
                links.weights.extend_from_slice(&saved.weights[a - start..b - start]);
                links.packed.push_row_of(&saved.tail, v - first);
            }
        }
        links.offsets.push(links.weights.len() as u32);
    }
    links.packed.finish();
    links.set_sizes();
    saved
}

impl Spliced {
    /// Puts the groups taken out by [`splice_groups`] back into `links`.
    pub fn restore(mut self, links: &mut Links) {
        let start = links.offsets[self.first] as usize;
        let byte_start = links.packed.starts[self.first] as usize;
        links.offsets.truncate(self.first + 1);
        links.weights.truncate(start);
        links.packed.starts.truncate(self.first);
        links.packed.bytes.truncate(byte_start);
        links.offsets.append(&mut self.offsets);
        links.weights.append(&mut self.weights);
        links.packed.starts.extend(self.tail.starts.iter().map(|s| s + byte_start as u32));
        links.packed.bytes.append(&mut self.tail.bytes);
        links.stats = self.stats;
    }
}
