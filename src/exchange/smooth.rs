//! Feature-aware one-ring smoothing (docs/DESIGN.md §4):
//! `E_s(v) = (E(v) + sum_{u in N'(v)} E(u)) / (|N'(v)| + 1)`, where `N'(v)`
//! is the one-ring without neighbours whose normal differs by more than the
//! feature angle (`n_v . n_u > cos alpha_f`). A feature angle of 0 turns it
//! off. Units follow the input (irradiance, W/m^2).

use crate::scene::prep::Csr;
use glam::Vec3;
use rayon::prelude::*;

/// Smooths `values` over one-rings; `angle_deg = 0` returns them unchanged.
pub fn smooth(values: &[Vec3], rings: &Csr, normals: &[Vec3], angle_deg: f32) -> Vec<Vec3> {
    if angle_deg <= 0.0 {
        return values.to_vec();
    }
    let cos_f = angle_deg.to_radians().cos();
    (0..values.len())
        .into_par_iter()
        .map(|v| {
            let mut sum = values[v];
            let mut count = 1.0f32;
            for &u in rings.row(v) {
                if normals[v].dot(normals[u as usize]) > cos_f {
                    sum += values[u as usize];
                    count += 1.0;
                }
            }
            sum / count
        })
        .collect()
}
