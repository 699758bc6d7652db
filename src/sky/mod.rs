//! Sky light (docs/DESIGN.md §4): radiance arriving from the directions in
//! which a vertex's rays leave the scene.
//!
//! A sky is a radiance function over directions, W/(m^2 sr) per channel:
//! uniform, a simple analytic gradient (zenith, horizon, ground), or an
//! equirectangular image ([`envmap`]), turned about +y by `rotate_deg` and
//! scaled by `intensity`. Each vertex keeps which of its link rays missed
//! ([`visibility`]: one bit a ray); `E_sky` is the rays' estimate
//! `pi / n * sum_{missed} L(w_k)`, evaluated again whenever the sky
//! changes, with the missed directions regenerated from the seed. So
//! changing, rescaling or rotating the sky is a gather-only update, and its
//! result is exactly what re-shooting every ray with the new sky gives (no
//! truncation: any sky, sharp features included). A sharp sun in an image
//! is sampled by the rays like everything else (noisy at few rays): put
//! the sun in as a directional light and keep the image for the sky.
//!
//! Where a vertex sees the sky through a small opening its estimate is
//! noisy: sky portals over the openings ([`portal`]) send rays toward
//! them, and cells of the ray grid on an edge of the sky get more rays
//! ([`refine`]). What noise is left the solver smooths with the noise-aware filter of `E_i`, with
//! the variance of its own samples ([`crate::exchange::SmoothParams::sky`]).
//!
//! `E_sky` is direct light: reported and exported on its own and added to
//! the source of the bounces like `E_d` (docs/DESIGN.md §4). Rays that
//! leave the scene after a bounce are not traced (the links end at the
//! first hit): sky light reaches other vertices through the vertices that
//! see it, like any direct light.

pub mod envmap;
pub mod portal;
pub mod rays;
pub mod refine;
pub mod visibility;

pub use envmap::EnvMap;
pub use portal::{Portal, PortalParams, PortalSamples};
pub use rays::SkyRays;
pub use refine::{SkyRefineParams, SkyRefinement};
pub use visibility::SkyVisibility;

use glam::Vec3;
use std::path::PathBuf;
use std::sync::Arc;

/// The radiance model of a sky (before rotation and intensity).
#[derive(Clone, Debug)]
pub enum SkyModel {
    /// The same radiance in every direction, W/(m^2 sr).
    Uniform {
        /// Radiance per channel, W/(m^2 sr).
        radiance: Vec3,
    },
    /// Above the horizon `horizon + (zenith - horizon) * cos(theta)`
    /// (theta from +y), below it `ground`; W/(m^2 sr).
    Gradient {
        /// Radiance straight up, W/(m^2 sr) per channel.
        zenith: Vec3,
        /// Radiance at the horizon, W/(m^2 sr) per channel.
        horizon: Vec3,
        /// Radiance below the horizon, W/(m^2 sr) per channel.
        ground: Vec3,
    },
    /// An equirectangular image ([`EnvMap`]); `path` as given in the scene file.
    Image {
        /// The image file, as the scene file names it.
        path: PathBuf,
        /// The loaded image.
        map: Arc<EnvMap>,
    },
}

impl PartialEq for SkyModel {
    fn eq(&self, o: &Self) -> bool {
        match (self, o) {
            (SkyModel::Uniform { radiance: a }, SkyModel::Uniform { radiance: b }) => a == b,
            (
                SkyModel::Gradient { zenith: a, horizon: b, ground: c },
                SkyModel::Gradient { zenith: x, horizon: y, ground: z },
            ) => (a, b, c) == (x, y, z),
            (SkyModel::Image { path: p, map: a }, SkyModel::Image { path: q, map: b }) => {
                p == q && (Arc::ptr_eq(a, b) || a == b)
            }
            _ => false,
        }
    }
}

/// A sky: a model, turned about +y and scaled.
#[derive(Clone, Debug, PartialEq)]
pub struct Sky {
    /// The radiance model, before rotation and intensity.
    pub model: SkyModel,
    /// Rotation about +y, degrees: counter-clockwise seen from above (+x
    /// toward -z, the right-hand rule, as a mesh's `rotate_deg` turns it).
    /// An image's columns run the other way (`envmap`), so what faced the
    /// direction of column `c` of `w` faces that of `c - w rotate_deg / 360`:
    /// seen from inside, the sky slides to the left as the angle grows.
    pub rotate_deg: f32,
    /// Multiplier of the model's radiance (unitless, >= 0).
    pub intensity: f32,
    /// Openings through which the scene sees this sky (`portal`); none:
    /// the link rays alone find it.
    pub portals: Vec<Portal>,
}

impl Sky {
    /// A uniform sky of `radiance`, W/(m^2 sr).
    pub fn uniform(radiance: Vec3) -> Sky {
        Sky { model: SkyModel::Uniform { radiance }, rotate_deg: 0.0, intensity: 1.0, portals: Vec::new() }
    }

    /// A gradient sky (see [`SkyModel::Gradient`]).
    pub fn gradient(zenith: Vec3, horizon: Vec3, ground: Vec3) -> Sky {
        Sky {
            model: SkyModel::Gradient { zenith, horizon, ground },
            rotate_deg: 0.0,
            intensity: 1.0,
            portals: Vec::new(),
        }
    }

    /// An image sky.
    pub fn image(path: PathBuf, map: EnvMap) -> Sky {
        Sky {
            model: SkyModel::Image { path, map: Arc::new(map) },
            rotate_deg: 0.0,
            intensity: 1.0,
            portals: Vec::new(),
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
        for (i, p) in self.portals.iter().enumerate() {
            p.validate().map_err(|m| format!("sky portal {i}: {m}"))?;
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
        self.radiance_fn()(d)
    }

    /// [`Sky::radiance`] with the rotation's sine and cosine computed once.
    pub fn radiance_fn(&self) -> impl Fn(Vec3) -> Vec3 + Sync + '_ {
        let (s, c) = self.rotate_deg.to_radians().sin_cos();
        move |d: Vec3| {
            // R^-1 d: turn by -rotate_deg.
            let local = Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
            self.model_radiance(local) * self.intensity
        }
    }

    /// A description for messages and panels; every parameter of the
    /// radiance but an image's pixels is in it (the rasterizer keys its
    /// baked sky map on it, the reference cache its sky); not the portals,
    /// which change how the sky is sampled, not what it is.
    pub fn describe(&self) -> String {
        let m = match &self.model {
            SkyModel::Uniform { radiance } => format!("uniform {radiance}"),
            SkyModel::Gradient { zenith, horizon, ground } => {
                format!("gradient zenith {zenith} horizon {horizon} ground {ground}")
            }
            SkyModel::Image { path, map } => format!("image {} ({} x {})", path.display(), map.width, map.height),
        };
        format!("{m}, x{} turned {} deg", self.intensity, self.rotate_deg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_turns_the_sky_counter_clockwise_seen_from_above() {
        // A sky bright toward +x only.
        let (w, h) = (64, 32);
        let probe = EnvMap { width: w, height: h, pixels: vec![Vec3::ZERO; w * h] };
        let pixels = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| Vec3::splat(probe.direction(i, j).x.max(0.0)));
        let mut sky = Sky::image("x".into(), EnvMap::new(w, h, pixels.collect()).unwrap());
        assert!(sky.radiance(Vec3::X).x > 0.9 && sky.radiance(Vec3::NEG_Z).x < 0.1);
        // Turned by 90 degrees, +x goes to -z (as `turn_y` turns meshes).
        sky.rotate_deg = 90.0;
        assert!(sky.radiance(Vec3::NEG_Z).x > 0.9 && sky.radiance(Vec3::X).x < 0.1);
        sky.intensity = 3.0;
        assert!(sky.radiance(Vec3::NEG_Z).x > 2.7);
    }

    #[test]
    fn gradient_sky_values() {
        let sky = Sky::gradient(Vec3::splat(3.0), Vec3::ONE, Vec3::splat(0.25));
        assert_eq!(sky.radiance(Vec3::Y), Vec3::splat(3.0));
        assert_eq!(sky.radiance(Vec3::X), Vec3::ONE);
        assert_eq!(sky.radiance(Vec3::NEG_Y), Vec3::splat(0.25));
        assert!(sky.validate().is_ok());
        assert!(Sky::uniform(Vec3::new(1.0, f32::NAN, 0.0)).validate().is_err());
    }
}
