//! Automatic exposure: the photographic key of Reinhard et al. (2002,
//! "Photographic tone reproduction for digital images", eq. 1-2), before
//! the ACES curve of [`super::tone_map`].
//!
//! The log-average luminance of what is shown,
//! `L_avg = exp(mean(ln Y))` over the values with `Y > 0`, where
//! `Y = 0.2126 R + 0.7152 G + 0.0722 B` (Rec. 709 luminance of linear
//! radiance, W/(m^2 sr)), is mapped to middle grey [`KEY`]: the exposure is
//! `ACES_INPUT_SCALE * KEY / L_avg`. [`ACES_INPUT_SCALE`] is the 0.6 with
//! which Narkowicz's ACES fit is meant to be fed (and the fixed exposure
//! linkgi used before, [`super::DEFAULT_EXPOSURE`]), so a scene whose
//! log-average is already middle grey keeps its old picture.
//!
//! Deviations: values that are exactly zero (pixels that see nothing, a
//! black sky, full shadow with no indirect light) are left out rather than
//! offset by a small `delta`, so the exposure scales exactly as `1 / L`:
//! the same scene with every light 1000 times stronger gets the same
//! picture. Nothing shown, or nothing but zeros, keeps the default.
//! Multiplying radiance by the exposure gives display units (1 = white
//! before the curve's shoulder).

use super::HdrImage;
use glam::Vec3;

/// Middle grey: the display value the log-average luminance is mapped to.
pub const KEY: f32 = 0.18;

/// The input scale of Narkowicz's ACES fit (the old fixed exposure).
pub const ACES_INPUT_SCALE: f32 = 0.6;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The exposure that maps the log-average luminance of `radiances` (W/(m^2
/// sr); zeros, negative and non-finite values left out) to [`KEY`];
/// `None` when no value is positive.
pub fn key_exposure(radiances: impl IntoIterator<Item = Vec3>) -> Option<f32> {
    let (mut sum, mut n) = (0f64, 0u64);
    for c in radiances {
        let y = luminance(c);
        if y > 0.0 && y.is_finite() {
            sum += (y as f64).ln();
            n += 1;
        }
    }
    if n == 0 {
        return None;
    }
    let l_avg = (sum / n as f64).exp();
    let e = (ACES_INPUT_SCALE as f64 * KEY as f64 / l_avg) as f32;
    (e.is_finite() && e > 0.0).then_some(e)
}

/// `key_exposure` of an image's pixels, or `super::DEFAULT_EXPOSURE`
/// when it shows nothing.
pub fn auto_exposure(img: &HdrImage) -> f32 {
    key_exposure(img.pixels.iter().copied()).unwrap_or(super::DEFAULT_EXPOSURE)
}

/// The viewer's adaptation: the exposure moves toward `target` in log
/// space, halving the remaining ratio every `half_life_s` seconds, so a
/// change of light fades in rather than jumps.
#[cfg(any(feature = "viewer", feature = "internals"))]
pub fn adapt(current: f32, target: f32, dt_s: f32, half_life_s: f32) -> f32 {
    if !(current.is_finite() && current > 0.0) {
        return target;
    }
    let keep = 0.5f32.powf(dt_s.max(0.0) / half_life_s.max(1e-6));
    (current.ln() * keep + target.ln() * (1.0 - keep)).exp()
}

/// The viewer's automatic exposure: a target measured from small probe
/// renders ([`key_exposure`]), followed smoothly ([`adapt`]), and held
/// while lights are being moved so a moving light brightens and darkens
/// the picture instead of being compensated away.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg(any(feature = "viewer", feature = "internals"))]
pub struct AutoExposure {
    /// The exposure shown now.
    pub current: f32,
    /// What the last probe asked for (`None` before the first).
    pub target: Option<f32>,
    /// Seconds between probes. Default 0.5.
    pub probe_every_s: f32,
    /// Seconds after the last light edit before probes count again. Default 1.
    pub hold_s: f32,
    /// Half-life of the adaptation, seconds. Default 0.4.
    pub half_life_s: f32,
    since_probe_s: f32,
    since_edit_s: f32,
}

#[cfg(any(feature = "viewer", feature = "internals"))]
impl AutoExposure {
    /// Starts at `initial` (used until the first probe).
    pub fn new(initial: f32) -> AutoExposure {
        AutoExposure {
            current: initial,
            target: None,
            probe_every_s: 0.5,
            hold_s: 1.0,
            half_life_s: 0.4,
            since_probe_s: f32::INFINITY,
            since_edit_s: f32::INFINITY,
        }
    }

    /// A light was edited: hold the exposure for [`AutoExposure::hold_s`].
    pub fn hold(&mut self) {
        self.since_edit_s = 0.0;
    }

    /// True when a probe render should be made now.
    pub fn wants_probe(&self) -> bool {
        self.since_probe_s >= self.probe_every_s && self.since_edit_s >= self.hold_s
    }

    /// The probe's radiances: the new target (the first one is taken at once).
    pub fn probed(&mut self, radiances: impl IntoIterator<Item = Vec3>) {
        self.since_probe_s = 0.0;
        if let Some(t) = key_exposure(radiances) {
            if self.target.is_none() {
                self.current = t;
            }
            self.target = Some(t);
        }
    }

    /// Advances by `dt_s` seconds; returns the exposure to show.
    pub fn step(&mut self, dt_s: f32) -> f32 {
        self.since_probe_s += dt_s;
        self.since_edit_s += dt_s;
        if let (Some(t), true) = (self.target, self.since_edit_s >= self.hold_s) {
            self.current = adapt(self.current, t, dt_s, self.half_life_s);
        }
        self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_scales_as_one_over_radiance_and_skips_zeros() {
        let px = vec![Vec3::new(0.1, 0.2, 0.3), Vec3::ZERO, Vec3::new(2.0, 1.0, 0.5), Vec3::splat(0.04)];
        let e = key_exposure(px.iter().copied()).unwrap();
        let e_k = key_exposure(px.iter().map(|p| *p * 1000.0)).unwrap();
        assert!((e / e_k - 1000.0).abs() < 1e-2, "{e} {e_k}");
        // Middle grey everywhere maps to the old default.
        let e_grey = key_exposure([Vec3::splat(KEY), Vec3::ZERO]).unwrap();
        assert!((e_grey - ACES_INPUT_SCALE).abs() < 1e-5, "{e_grey}");
        assert_eq!(key_exposure([Vec3::ZERO, Vec3::splat(f32::NAN)]), None);
    }

    #[test]
    fn viewer_exposure_is_steady_while_a_light_moves_then_adapts() {
        let mut a = AutoExposure::new(0.6);
        assert!(a.wants_probe());
        a.probed([Vec3::splat(0.18)]);
        assert!((a.step(0.016) - 0.6).abs() < 1e-5);
        // A light moves: the scene gets 10x brighter while it is dragged.
        let mut t = 0.0;
        while t < 0.9 {
            a.hold();
            t += 0.1;
            if a.wants_probe() {
                a.probed([Vec3::splat(1.8)]);
            }
            assert!((a.step(0.1) - 0.6).abs() < 1e-5, "exposure moved while the light moved");
        }
        // The light rests: the next probes count, and the exposure fades to 0.06.
        let mut seen = Vec::new();
        for _ in 0..60 {
            if a.wants_probe() {
                a.probed([Vec3::splat(1.8)]);
            }
            seen.push(a.step(0.1));
        }
        assert!(seen.windows(2).all(|w| w[1] <= w[0] + 1e-6), "not monotone: {seen:?}");
        assert!(seen.windows(2).all(|w| w[1] >= 0.5 * w[0]), "jumped: {seen:?}");
        assert!((seen.last().unwrap() - 0.06).abs() < 1e-3, "{seen:?}");
    }

    #[test]
    fn adaptation_moves_toward_the_target_and_reaches_it() {
        let half = adapt(1.0, 4.0, 0.5, 0.5);
        assert!((half - 2.0).abs() < 1e-5, "{half}");
        assert!((adapt(1.0, 4.0, 100.0, 0.5) - 4.0).abs() < 1e-4);
        assert_eq!(adapt(3.0, 3.0, 0.1, 0.5), 3.0);
    }
}
