//! Maps from the unit square to the disc and the hemisphere: Shirley and
//! Chiu's concentric map and Malley's cosine lift (`pdf = cos / pi` per
//! steradian), their inverses, and an orthonormal basis about a normal.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
#[cfg(test)]
use std::f32::consts::PI;

/// Concentric map from `[0,1)^2` to the unit disc.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Inverse of [`concentric_disk`].
#[cfg(test)]
pub fn concentric_disk_inverse(p: Vec2) -> Vec2 {
    let r = p.length();
    if r == 0.0 {
        return Vec2::splat(0.5);
    }
    let mut phi = p.y.atan2(p.x);
    if phi < -FRAC_PI_4 {
        phi += 2.0 * PI;
    }
    // Octant pairs: |x| > |y| regions are phi in [-pi/4, pi/4) and [3pi/4, 5pi/4).
    let (a, b) = if phi < FRAC_PI_4 {
        (r, r * phi / FRAC_PI_4)
    } else if phi < 3.0 * FRAC_PI_4 {
        (-r * (phi - FRAC_PI_2) / FRAC_PI_4, r)
    } else if phi < 5.0 * FRAC_PI_4 {
        (-r, -r * (phi - PI) / FRAC_PI_4)
    } else {
        (r * (phi - 3.0 * FRAC_PI_2) / FRAC_PI_4, -r)
    };
    (Vec2::new(a, b) + Vec2::ONE) * 0.5
}

/// Cosine-weighted direction about +z from a point of the unit square.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] per steradian.
#[cfg(test)]
pub fn cosine_hemisphere_pdf(w: Vec3) -> f32 {
    w.z.max(0.0) / PI
}

/// Inverse of [`cosine_hemisphere`]: the unit-square point that maps to `w`.
#[cfg(test)]
pub fn cosine_hemisphere_inverse(w: Vec3) -> Vec2 {
    concentric_disk_inverse(Vec2::new(w.x, w.y))
}

/// Orthonormal basis `(t, b)` with `t x b = n` (Duff et al. 2017).
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let s = 1f32.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x), Vec3::new(b, s + n.y * n.y * a, -n.y))
}
