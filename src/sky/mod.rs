//! Sky light (docs/DESIGN.md §4b): radiance arriving from directions in
//! which a vertex's rays leave the scene.
//!
//! A sky is a radiance function over directions, W/(m^2 sr) per channel:
//! uniform, a simple analytic gradient (zenith, horizon, ground), or an
//! equirectangular image ([`envmap`]), turned about +y by `rotate_deg` and
//! scaled by `intensity`. The link solver never evaluates it per ray: a
//! sky is projected onto 16 spherical-harmonic coefficients ([`sh`],
//! bands 0..=3), each vertex keeps the projection of its missed ray
//! directions ([`visibility`]), and `E_sky` per vertex is their dot
//! product. Changing, rescaling or rotating the sky is therefore a
//! gather-only update (rotation about +y turns the coefficients exactly).
//!
//! Accuracy: exact for the sky's band-limited part. [`SkyProjection::max_truncation`]
//! bounds `|L - L_trunc|` over the sphere, so `E_sky` differs from a
//! re-shoot with the full sky by at most `pi * (missed fraction) * max_truncation`
//! at every vertex. A uniform sky is band-limited (error 0); the gradient
//! sky's kink at the horizon costs a few percent of its contrast; a sharp
//! sun in an image is blurred to a broad lobe, so put the sun in as a
//! directional light and keep the image for the sky.
//!
//! `E_sky` is direct light: reported and exported on its own and added to
//! the source of the bounces like `E_d` (docs/DESIGN.md §4).

pub mod envmap;
pub mod sh;
pub mod visibility;

pub use envmap::EnvMap;
pub use visibility::SkyVisibility;

use glam::Vec3;
use sh::COEFFS;
use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

/// The radiance model of a sky (before rotation and intensity).
#[derive(Clone, Debug)]
pub enum SkyModel {
    /// The same radiance in every direction, W/(m^2 sr).
    Uniform { radiance: Vec3 },
    /// Above the horizon `horizon + (zenith - horizon) * cos(theta)`
    /// (theta from +y), below it `ground`; W/(m^2 sr).
    Gradient { zenith: Vec3, horizon: Vec3, ground: Vec3 },
    /// An equirectangular image ([`EnvMap`]); `path` as given in the scene file.
    Image { path: PathBuf, map: Arc<EnvMap>, projection: Arc<OnceLock<SkyProjection>> },
}

impl PartialEq for SkyModel {
    fn eq(&self, o: &Self) -> bool {
        match (self, o) {
            (SkyModel::Uniform { radiance: a }, SkyModel::Uniform { radiance: b }) => a == b,
            (
                SkyModel::Gradient { zenith: a, horizon: b, ground: c },
                SkyModel::Gradient { zenith: x, horizon: y, ground: z },
            ) => (a, b, c) == (x, y, z),
            (SkyModel::Image { path: p, map: a, .. }, SkyModel::Image { path: q, map: b, .. }) => {
                p == q && (Arc::ptr_eq(a, b) || a == b)
            }
            _ => false,
        }
    }
}

/// A sky: a model, turned about +y and scaled.
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    pub model: SkyModel,
    /// Rotation about +y, degrees (counter-clockwise seen from above: +x toward -z).
    pub rotate_deg: f32,
    /// Multiplier of the model's radiance (unitless, >= 0).
    pub intensity: f32,
}

/// A sky's spherical-harmonic coefficients (rotation and intensity
/// applied), W/(m^2 sr), and the largest deviation of the band-limited
/// sky from the sky over the sphere, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyProjection {
    pub coeffs: [Vec3; COEFFS],
    pub max_truncation: Vec3,
}

/// Quadrature resolution (rows in cos(theta)) of analytic skies.
const ANALYTIC_ROWS: usize = 256;

impl Sky {
    /// A uniform sky of `radiance`, W/(m^2 sr).
    pub fn uniform(radiance: Vec3) -> Sky {
        Sky { model: SkyModel::Uniform { radiance }, rotate_deg: 0.0, intensity: 1.0 }
    }

    /// A gradient sky (see [`SkyModel::Gradient`]).
    pub fn gradient(zenith: Vec3, horizon: Vec3, ground: Vec3) -> Sky {
        Sky { model: SkyModel::Gradient { zenith, horizon, ground }, rotate_deg: 0.0, intensity: 1.0 }
    }

    /// An image sky.
    pub fn image(path: PathBuf, map: EnvMap) -> Sky {
        Sky {
            model: SkyModel::Image { path, map: Arc::new(map), projection: Arc::new(OnceLock::new()) },
            rotate_deg: 0.0,
            intensity: 1.0,
        }
    }

    /// Checks values: finite, non-negative radiance and intensity, finite rotation.
    pub fn validate(&self) -> Result<(), String> {
        let ok = |v: Vec3| v.is_finite() && v.min_element() >= 0.0;
        match &self.model {
            SkyModel::Uniform { radiance } if !ok(*radiance) => {
                return Err(format!("sky radiance {radiance} must be finite and non-negative"))
            }
            SkyModel::Gradient { zenith, horizon, ground } if !(ok(*zenith) && ok(*horizon) && ok(*ground)) => {
                return Err(format!(
                    "sky zenith {zenith}, horizon {horizon}, ground {ground} must be finite and non-negative"
                ))
            }
            _ => {}
        }
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return Err(format!("sky intensity {} must be finite and non-negative", self.intensity));
        }
        if !self.rotate_deg.is_finite() {
            return Err(format!("sky rotate_deg {} is not finite", self.rotate_deg));
        }
        Ok(())
    }

    /// The model's radiance along unit direction `d` (no rotation, no intensity).
    fn model_radiance(&self, d: Vec3) -> Vec3 {
        match &self.model {
            SkyModel::Uniform { radiance } => *radiance,
            SkyModel::Gradient { zenith, horizon, ground } => {
                if d.y >= 0.0 {
                    *horizon + (*zenith - *horizon) * d.y
                } else {
                    *ground
                }
            }
            SkyModel::Image { map, .. } => map.lookup(d),
        }
    }

    /// Radiance arriving from direction `d` (unit, pointing away from the
    /// receiver toward the sky), rotation and intensity applied, W/(m^2 sr).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let (s, c) = self.rotate_deg.to_radians().sin_cos();
        // R^-1 d: turn by -rotate_deg.
        let local = Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
        self.model_radiance(local) * self.intensity
    }

    /// The model's projection before rotation and intensity (cached for images).
    fn model_projection(&self) -> SkyProjection {
        let analytic = |sky: &Sky| {
            let coeffs = sh::project(|d| sky.model_radiance(d), ANALYTIC_ROWS);
            let max_truncation = sh::sphere_quadrature(ANALYTIC_ROWS / 2).fold(Vec3::ZERO, |m, (d, _)| {
                m.max((sky.model_radiance(d) - sh::eval(&coeffs, d)).abs())
            });
            SkyProjection { coeffs, max_truncation }
        };
        match &self.model {
            SkyModel::Uniform { radiance } => {
                let mut coeffs = [Vec3::ZERO; COEFFS];
                // Only Y_00 = 1 / sqrt(4 pi): L_00 = L sqrt(4 pi).
                coeffs[0] = *radiance * (4.0 * std::f32::consts::PI).sqrt();
                SkyProjection { coeffs, max_truncation: Vec3::ZERO }
            }
            SkyModel::Gradient { .. } => analytic(self),
            SkyModel::Image { map, projection, .. } => *projection.get_or_init(|| project_map(map)),
        }
    }

    /// The sky's coefficients with rotation and intensity applied.
    pub fn projection(&self) -> SkyProjection {
        let p = self.model_projection();
        let coeffs = sh::rotate_y(&p.coeffs, self.rotate_deg).map(|c| c * self.intensity);
        SkyProjection { coeffs, max_truncation: p.max_truncation * self.intensity }
    }

    /// A short description for messages and panels.
    pub fn describe(&self) -> String {
        let m = match &self.model {
            SkyModel::Uniform { radiance } => format!("uniform {radiance}"),
            SkyModel::Gradient { zenith, horizon, .. } => format!("gradient zenith {zenith} horizon {horizon}"),
            SkyModel::Image { path, map, .. } => format!("image {} ({} x {})", path.display(), map.width, map.height),
        };
        format!("{m}, x{} turned {} deg", self.intensity, self.rotate_deg)
    }
}

/// Projection of an image by its pixels (each weighted by its solid
/// angle), and the largest deviation at pixel centres.
fn project_map(map: &EnvMap) -> SkyProjection {
    use rayon::prelude::*;
    let rows: Vec<[[f64; 3]; COEFFS]> = (0..map.height)
        .into_par_iter()
        .map(|j| {
            let mut acc = [[0f64; 3]; COEFFS];
            let w = map.pixel_solid_angle(j);
            for i in 0..map.width {
                let v = map.pixels[j * map.width + i] * w;
                for (a, y) in acc.iter_mut().zip(sh::basis(map.direction(i, j))) {
                    a[0] += (v.x * y) as f64;
                    a[1] += (v.y * y) as f64;
                    a[2] += (v.z * y) as f64;
                }
            }
            acc
        })
        .collect();
    let mut acc = [[0f64; 3]; COEFFS];
    for r in rows {
        for (a, b) in acc.iter_mut().zip(r) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
    }
    let coeffs = acc.map(|a| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32));
    let max_truncation = (0..map.height)
        .into_par_iter()
        .map(|j| {
            (0..map.width).fold(Vec3::ZERO, |m, i| {
                m.max((map.pixels[j * map.width + i] - sh::eval(&coeffs, map.direction(i, j))).abs())
            })
        })
        .reduce(|| Vec3::ZERO, Vec3::max);
    SkyProjection { coeffs, max_truncation }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_sky_projects_exactly() {
        let s = Sky::uniform(Vec3::new(1.0, 2.0, 0.5));
        let p = s.projection();
        for (d, _) in sh::sphere_quadrature(5) {
            assert!((sh::eval(&p.coeffs, d) - Vec3::new(1.0, 2.0, 0.5)).abs().max_element() < 1e-5);
        }
        assert_eq!(p.max_truncation, Vec3::ZERO);
    }

    #[test]
    fn image_sky_matches_its_analytic_source() {
        // An image of a smooth function: its projection approaches the
        // function's, and lookups return the function at pixel centres.
        let f = |d: Vec3| Vec3::new(1.0 + 0.5 * d.x, 1.0 + d.y * d.y, 2.0 - d.z);
        let (w, h) = (256, 128);
        let probe = EnvMap { width: w, height: h, pixels: vec![Vec3::ZERO; w * h] };
        let pixels = (0..h).flat_map(|j| (0..w).map(move |i| (i, j))).map(|(i, j)| f(probe.direction(i, j))).collect();
        let map = EnvMap::new(w, h, pixels).unwrap();
        for (i, j) in [(0, 0), (17, 40), (255, 127), (128, 64)] {
            assert!((map.lookup(map.direction(i, j)) - f(map.direction(i, j))).abs().max_element() < 1e-4);
        }
        let img = Sky::image("synthetic".into(), map).projection();
        let want = sh::project(f, 256);
        for (a, b) in img.coeffs.iter().zip(&want) {
            assert!((*a - *b).abs().max_element() < 5e-3, "{a} vs {b}");
        }
        assert!(img.max_truncation.max_element() < 0.02, "{}", img.max_truncation);
    }

    #[test]
    fn rotated_sky_radiance_turns_with_the_coefficients() {
        let mut s = Sky::gradient(Vec3::ONE, Vec3::splat(0.2), Vec3::ZERO);
        // Gradient skies are symmetric about +y: rotation changes nothing.
        let p0 = s.projection();
        s.rotate_deg = 70.0;
        let p1 = s.projection();
        for (a, b) in p0.coeffs.iter().zip(&p1.coeffs) {
            assert!((*a - *b).abs().max_element() < 1e-5);
        }
        let m = p0.max_truncation.max_element();
        assert!(m > 0.0 && m < 0.2, "{m}");
    }
}
