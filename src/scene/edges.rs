//! World-space edge keys: an edge named by its two ends' world positions
//! as bits, sorted (how preparation welds), so an edge indexed twice (two
//! OBJ groups) or in two meshes is one key. The error-driven rounds
//! ([`crate::solver::adaptive`]) and the contact splits
//! ([`super::contact`]) mark edges by these keys for
//! [`super::refine::split_world_edges`].

use glam::Vec3;

/// A world-space edge: its two ends' world positions as bits, sorted (how
/// preparation welds, so edges indexed twice match).
pub type WorldEdge = ([u32; 3], [u32; 3]);

/// The world-space key of the edge from `a` to `b`.
pub fn world_edge(a: Vec3, b: Vec3) -> WorldEdge {
    let (a, b) = (a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
    (a.min(b), a.max(b))
}
