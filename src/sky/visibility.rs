//! Per-vertex sky visibility: what a vertex's link rays that left the
//! scene say about the sky, stored so that any sky (changed, rotated,
//! rescaled) is integrated without new rays.
//!
//! With cosine-distributed directions (pdf `cos / pi`), the sky irradiance
//! of a vertex is estimated from its `n` rays as
//! `E_sky = (pi / n) * sum_{k missed} L(w_k)` (W/m^2, `L` in W/(m^2 sr)).
//! Each vertex keeps the projection of its missed directions onto the
//! spherical harmonics of [`super::sh`]: `v_i = (pi / n) sum_{k missed} Y_i(w_k)`
//! (sr-weighted, unitless), so that `E_sky = sum_i v_i L_i` with the sky's
//! coefficients `L_i`. This equals the ray estimate for the sky's
//! band-limited part `L_trunc` exactly: it differs from re-shooting with the
//! full sky by `(pi / n) sum_missed (L - L_trunc)(w_k)`, at most
//! `pi * missed / n * max |L - L_trunc|` ([`super::SkyProjection::max_truncation`]).
//! 16 f32 a vertex (64 bytes), kept only when some ray missed.

use super::sh::{basis, COEFFS};
use super::SkyProjection;
use glam::Vec3;
use rayon::prelude::*;

/// Coefficients of one vertex.
pub type VertexSky = [f32; COEFFS];

/// Sky visibility of every vertex (see the module doc); empty when no
/// ray of any vertex left the scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyVisibility {
    /// One entry per vertex, or none at all.
    pub coeffs: Vec<VertexSky>,
}

/// The coefficients of a vertex from its rays in order: `(missed, direction)`,
/// `weight_per_ray = pi / n`. `None` when no ray missed. Summed in ray
/// order in f32 (the same bits whoever calls it with the same rays).
pub fn project_misses(rays: impl Iterator<Item = (bool, Vec3)>, weight_per_ray: f32) -> Option<VertexSky> {
    let mut acc = [0f32; COEFFS];
    let mut any = false;
    for (missed, d) in rays {
        if missed {
            any = true;
            for (a, y) in acc.iter_mut().zip(basis(d)) {
                *a += y;
            }
        }
    }
    any.then(|| acc.map(|a| a * weight_per_ray))
}

impl SkyVisibility {
    /// Dense visibility of `n` vertices from `(vertex, coefficients)` of
    /// those that saw the sky; empty when there are none.
    pub fn from_sparse(n: usize, seen: impl IntoIterator<Item = (usize, VertexSky)>) -> SkyVisibility {
        let mut coeffs = Vec::new();
        for (v, c) in seen {
            if coeffs.is_empty() {
                coeffs = vec![[0f32; COEFFS]; n];
            }
            coeffs[v] = c;
        }
        SkyVisibility { coeffs }
    }

    /// True when no vertex sees the sky.
    pub fn is_empty(&self) -> bool {
        self.coeffs.is_empty()
    }

    /// Coefficients of vertex `v` (zero when none are kept).
    pub fn vertex(&self, v: usize) -> VertexSky {
        self.coeffs.get(v).copied().unwrap_or([0.0; COEFFS])
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        std::mem::size_of_val(self.coeffs.as_slice()) as u64
    }

    /// Sky irradiance `E_sky` of each of `n` vertices under `sky`, W/m^2
    /// (zero everywhere without visibility or sky). The band-limited sky
    /// can ring below zero where the sky has strong contrast; such values
    /// are clamped to zero per channel.
    pub fn irradiance(&self, sky: Option<&SkyProjection>, n: usize) -> Vec<Vec3> {
        let Some(sky) = sky.filter(|_| !self.is_empty()) else { return vec![Vec3::ZERO; n] };
        self.coeffs.par_iter().map(|c| c.iter().zip(&sky.coeffs).map(|(v, l)| *l * *v).sum::<Vec3>().max(Vec3::ZERO)).collect()
    }
}
