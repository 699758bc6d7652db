//! Real spherical harmonics of bands 0..=3 (16 coefficients) with the
//! world's up axis (+y) as polar axis, so turning a function about +y
//! turns each `(m, -m)` coefficient pair by `m` times the angle.
//!
//! Basis: the standard real SH with the Condon-Shortley phase (the
//! polynomials of Sloan, "Stupid spherical harmonics tricks", 2008),
//! evaluated in the local frame `x' = x, y' = -z, z' = y` (right-handed,
//! `z'` up). Orthonormal over the sphere: `integral Y_i Y_j dw = delta_ij`.
//! A function `f` is projected as `f_i = integral f Y_i dw` and
//! reconstructed, band-limited, as `f_trunc(w) = sum_i f_i Y_i(w)`.
//! Directions are unit vectors; coefficients carry the function's units.

use glam::Vec3;

/// Bands kept (0..BANDS).
pub const BANDS: usize = 4;
/// Coefficients per function, `BANDS^2`.
pub const COEFFS: usize = BANDS * BANDS;

/// The 16 basis functions at unit direction `d` (world coordinates).
#[inline]
pub fn basis(d: Vec3) -> [f32; COEFFS] {
    // Local frame: z up.
    let (x, y, z) = (d.x, -d.z, d.y);
    let (x2, y2, z2) = (x * x, y * y, z * z);
    [
        0.282_094_8,
        -0.488_602_5 * y,
        0.488_602_5 * z,
        -0.488_602_5 * x,
        1.092_548_4 * x * y,
        -1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z2 - 1.0),
        -1.092_548_4 * x * z,
        0.546_274_2 * (x2 - y2),
        -0.590_043_6 * y * (3.0 * x2 - y2),
        2.890_611_4 * x * y * z,
        -0.457_045_8 * y * (4.0 * z2 - x2 - y2),
        0.373_176_33 * z * (2.0 * z2 - 3.0 * x2 - 3.0 * y2),
        -0.457_045_8 * x * (4.0 * z2 - x2 - y2),
        1.445_305_7 * z * (x2 - y2),
        -0.590_043_6 * x * (x2 - 3.0 * y2),
    ]
}

/// Index of coefficient `(l, m)`, `-l <= m <= l`.
#[inline]
pub const fn index(l: usize, m: i32) -> usize {
    l * l + (l as i32 + m) as usize
}

/// RGB coefficients of a function turned by `deg` degrees about +y
/// (counter-clockwise seen from above: +x turns toward -z), i.e. the
/// projection of `w -> f(R^-1 w)`. Exact: rotation about the polar axis
/// mixes only the `(m, -m)` pairs of a band.
pub fn rotate_y(c: &[Vec3; COEFFS], deg: f32) -> [Vec3; COEFFS] {
    let mut out = *c;
    let theta = (deg as f64).to_radians();
    for l in 1..BANDS {
        for m in 1..=l as i32 {
            let (s, co) = ((m as f64) * theta).sin_cos();
            let (s, co) = (s as f32, co as f32);
            let (cos_i, sin_i) = (index(l, m), index(l, -m));
            let (a, b) = (c[cos_i], c[sin_i]);
            out[cos_i] = a * co - b * s;
            out[sin_i] = a * s + b * co;
        }
    }
    out
}

/// Quadrature directions over the whole sphere with their solid angles
/// (sr, summing to 4 pi): midpoints of an `n_z x 2 n_z` grid, uniform in
/// `cos(theta)` and in azimuth, so every cell has the same solid angle.
pub fn sphere_quadrature(n_z: usize) -> impl Iterator<Item = (Vec3, f32)> {
    let n_phi = 2 * n_z;
    let w = (4.0 * std::f64::consts::PI / (n_z * n_phi) as f64) as f32;
    (0..n_z).flat_map(move |i| {
        let y = 1.0 - 2.0 * (i as f64 + 0.5) / n_z as f64;
        let r = (1.0 - y * y).max(0.0).sqrt();
        (0..n_phi).map(move |j| {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
            (Vec3::new((r * phi.cos()) as f32, y as f32, (-r * phi.sin()) as f32), w)
        })
    })
}

/// Coefficients of the RGB function `f` by the quadrature of
/// [`sphere_quadrature`]`(n_z)`, summed in f64.
pub fn project(f: impl Fn(Vec3) -> Vec3, n_z: usize) -> [Vec3; COEFFS] {
    let mut acc = [[0f64; 3]; COEFFS];
    for (d, w) in sphere_quadrature(n_z) {
        let v = f(d) * w;
        for (a, y) in acc.iter_mut().zip(basis(d)) {
            a[0] += (v.x * y) as f64;
            a[1] += (v.y * y) as f64;
            a[2] += (v.z * y) as f64;
        }
    }
    acc.map(|a| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32))
}

/// The band-limited reconstruction `sum_i c_i Y_i(d)`.
pub fn eval(c: &[Vec3; COEFFS], d: Vec3) -> Vec3 {
    c.iter().zip(basis(d)).map(|(c, y)| *c * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal() {
        let mut gram = [[0f64; COEFFS]; COEFFS];
        for (d, w) in sphere_quadrature(200) {
            let y = basis(d);
            for i in 0..COEFFS {
                for j in 0..COEFFS {
                    gram[i][j] += (y[i] * y[j] * w) as f64;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((g - want).abs() < 2e-3, "<Y{i}, Y{j}> = {g}");
            }
        }
    }

    #[test]
    fn band_limited_functions_are_reproduced() {
        // Degree-3 polynomial in the direction: exactly in bands 0..=3.
        let f = |d: Vec3| Vec3::new(1.0 + d.y, d.x * d.z + 0.3 * d.y * d.y * d.y, 2.0 - d.x * d.x);
        let c = project(f, 256);
        for (d, _) in sphere_quadrature(7) {
            assert!((eval(&c, d) - f(d)).abs().max_element() < 2e-3, "{d}: {} vs {}", eval(&c, d), f(d));
        }
    }

    #[test]
    fn rotation_about_up_equals_projecting_the_turned_function() {
        let f = |d: Vec3| Vec3::new((3.0 * d.x).exp(), (d.x - 2.0 * d.z).max(0.0), 1.0 + d.x * d.y - d.z);
        for deg in [0.0f32, 17.0, 90.0, -123.0, 400.0] {
            let (s, c) = deg.to_radians().sin_cos();
            // R^-1: turn by -deg (turn_y convention: p' = (c x + s z, y, -s x + c z)).
            let inv = |d: Vec3| Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
            let want = project(|d| f(inv(d)), 128);
            let got = rotate_y(&project(f, 128), deg);
            for (a, b) in got.iter().zip(&want) {
                assert!((*a - *b).abs().max_element() < 1e-3 * (1.0 + b.abs().max_element()), "{deg}: {a} vs {b}");
            }
        }
    }
}
