//! Per-vertex sky visibility: which of a vertex's link rays left the
//! scene, one bit a ray, so that any sky (changed, rotated, rescaled) is
//! integrated again without tracing.
//!
//! With cosine-distributed directions (pdf `cos / pi`), the sky irradiance
//! of a vertex is estimated from its `n` rays as
//! `E_sky = (pi / n) * sum_{k missed} L(w_k)` (W/m^2, `L` in W/(m^2 sr)).
//! The missed directions `w_k` are not stored: they are the vertex's
//! direction set turned into its frame ([`crate::sampling::world_direction`]),
//! regenerated from the seed, so `E_sky` is exactly the estimate a new
//! shoot with the current sky would give, for any sky. Cost of a sky
//! change: one direction and one radiance lookup per missed ray.
//! Storage: `ceil(n / 64)` u64 words a vertex (32 bytes at 256 rays), kept
//! only when some ray missed.

use super::Sky;
use crate::sampling::{vertex_frame, world_direction};
use glam::Vec3;
use rayon::prelude::*;

/// Which rays of every vertex missed (see the module doc); empty when no
/// ray of any vertex left the scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyVisibility {
    /// u64 words per vertex, `ceil(rays_per_vertex / 64)`.
    pub words: usize,
    /// Bit `k % 64` of word `v * words + k / 64`: ray `k` of vertex `v` missed.
    pub masks: Vec<u64>,
}

/// The miss mask of a vertex from its rays' `missed` flags in ray order;
/// `None` when no ray missed.
pub fn miss_mask(missed: impl Iterator<Item = bool>, rays: usize) -> Option<Vec<u64>> {
    let mut mask = vec![0u64; rays.div_ceil(64)];
    let mut any = false;
    for (k, m) in missed.enumerate() {
        if m {
            mask[k / 64] |= 1 << (k % 64);
            any = true;
        }
    }
    any.then_some(mask)
}

/// The vertex frames and shared local directions the rays were shot with.
pub struct RayFrames<'a> {
    /// Unit normal of each vertex.
    pub normals: &'a [Vec3],
    /// Rotation of each vertex's frame about its normal, radians.
    pub rotations: &'a [f32],
    /// Each vertex's direction set.
    pub sets: &'a [u32],
    /// The local direction sets, in ray order.
    pub directions: &'a crate::sampling::DirectionSet,
    /// Vertex positions (where the portals are seen from).
    pub positions: &'a [Vec3],
    /// Sky portals with samples ([`super::portal`]): the directions through
    /// them are theirs, so a link ray that left through one counts as a hit.
    pub portals: &'a [super::Portal],
}

impl RayFrames<'_> {
    /// Vertex `v`'s miss mask `mask` without the rays that left through a
    /// portal (borrowed as it is when there are no portals).
    pub fn effective_mask<'m>(&self, v: usize, mask: &'m [u64]) -> std::borrow::Cow<'m, [u64]> {
        if self.portals.is_empty() || mask.iter().all(|&m| m == 0) {
            return std::borrow::Cow::Borrowed(mask);
        }
        let frame = vertex_frame(self.normals[v], self.rotations[v]);
        let set = self.directions.set(self.sets[v]);
        let mut out = mask.to_vec();
        for (w, word) in out.iter_mut().enumerate() {
            let mut b = *word;
            while b != 0 {
                let k = w * 64 + b.trailing_zeros() as usize;
                b &= b - 1;
                if super::portal::through_any(self.portals, self.positions[v], world_direction(frame, set[k])) {
                    *word &= !(1u64 << (k % 64));
                }
            }
        }
        std::borrow::Cow::Owned(out)
    }
}

impl SkyVisibility {
    /// Visibility of `n` vertices from the masks ([`miss_mask`], all of
    /// one length) of those that saw the sky; empty when there are none.
    pub fn from_sparse(n: usize, seen: impl IntoIterator<Item = (usize, Vec<u64>)>) -> SkyVisibility {
        let mut out = SkyVisibility::default();
        for (v, m) in seen {
            if out.is_empty() {
                out.words = m.len();
                out.masks = vec![0u64; n * out.words];
            }
            out.masks[v * out.words..(v + 1) * out.words].copy_from_slice(&m);
        }
        out
    }

    /// True when no vertex sees the sky.
    pub fn is_empty(&self) -> bool {
        self.masks.is_empty()
    }

    /// Vertex `v`'s mask (all zero when none are kept).
    pub fn vertex(&self, v: usize) -> &[u64] {
        if self.is_empty() {
            &[]
        } else {
            &self.masks[v * self.words..(v + 1) * self.words]
        }
    }

    /// Sets vertex `v`'s mask (`None`: no ray missed) for `n` vertices of
    /// `rays` rays, allocating the masks on the first miss.
    pub fn set(&mut self, v: usize, n: usize, rays: usize, mask: Option<&[u64]>) {
        if self.is_empty() {
            let Some(_) = mask else { return };
            self.words = rays.div_ceil(64);
            self.masks = vec![0u64; n * self.words];
        }
        let w = self.words;
        match mask {
            Some(m) => self.masks[v * w..(v + 1) * w].copy_from_slice(m),
            None => self.masks[v * w..(v + 1) * w].fill(0),
        }
    }

    /// Drops the masks when every one is zero (as a fresh shoot would have none).
    pub fn compact(&mut self) {
        if self.masks.iter().all(|&m| m == 0) {
            *self = SkyVisibility::default();
        }
    }

    /// Bytes held.
    #[cfg(any(feature = "cli", feature = "internals"))]
    pub fn bytes(&self) -> u64 {
        std::mem::size_of_val(self.masks.as_slice()) as u64
    }

    /// Sky irradiance `E_sky` of each of `n` vertices under `sky`, W/m^2:
    /// `pi / n_rays * sum_{missed} L(w_k)` with the directions of `frames`
    /// (zero everywhere without visibility or sky), leaving the directions
    /// through `frames.portals` to their samples.
    #[cfg(any(test, feature = "internals"))]
    pub fn irradiance(&self, sky: Option<&Sky>, frames: &RayFrames, n: usize) -> Vec<Vec3> {
        self.irradiance_and_moment(sky, frames, n).into_iter().map(|(e, _)| e).collect()
    }

    /// [`SkyVisibility::irradiance`] with each vertex's second moment of
    /// its ray estimates, `mean_k X_k^2` ((W/m^2)^2 per channel) with
    /// `X_k = pi L(w_k)` for a missed ray and 0 for one that hit: the
    /// input of the sky's noise estimate ([`crate::exchange::denoise::smooth::pooled_variance`]).
    pub fn irradiance_and_moment(&self, sky: Option<&Sky>, frames: &RayFrames, n: usize) -> Vec<(Vec3, Vec3)> {
        let Some(sky) = sky.filter(|_| !self.is_empty()) else { return vec![(Vec3::ZERO, Vec3::ZERO); n] };
        let radiance = sky.radiance_fn();
        let rays = frames.directions.len() as f32;
        let scale = std::f32::consts::PI / rays;
        let dirs = frames.directions;
        (0..n)
            .into_par_iter()
            .map(|v| {
                let mask = frames.effective_mask(v, self.vertex(v));
                if mask.iter().all(|&m| m == 0) {
                    return (Vec3::ZERO, Vec3::ZERO);
                }
                let frame = vertex_frame(frames.normals[v], frames.rotations[v]);
                let set = dirs.set(frames.sets[v]);
                let (mut sum, mut sum2) = (Vec3::ZERO, Vec3::ZERO);
                for (w, &bits) in mask.iter().enumerate() {
                    let mut b = bits;
                    while b != 0 {
                        let k = w * 64 + b.trailing_zeros() as usize;
                        b &= b - 1;
                        let l = radiance(world_direction(frame, set[k]));
                        sum += l;
                        sum2 += l * l;
                    }
                }
                (sum * scale, sum2 * (scale * std::f32::consts::PI))
            })
            .collect()
    }
}
