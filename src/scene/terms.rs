//! Which terms of a solve are on ([`Terms`]): the one switch of every
//! optional part of the method (docs/DESIGN.md §4). Every term is on by
//! default; a scene file turns terms off in its `[settings]` with
//! `off = ["near_gather", "reconstruct"]`, the command line with
//! `--off near_gather,reconstruct`. Turning a term off trades accuracy for
//! time; `docs/ACCURACY.md` has what each buys on the built-in scenes.
//! (Counts such as rays a near hit are parameters of their stage and at
//! least 1; a term is switched off here, never by a count of 0.)
//!
//! The near-field terms of [`Terms::DECIDED`] are decided per scene: a
//! solve traces each on a sample of its near hits and keeps it only where
//! it changes the light by enough ([`crate::solver::SolveParams::pay_share`],
//! `src/solver/decide.rs`). `on = ["near_emitters"]` (`--on`) forces such a
//! term on; `off` still forces any term off.

/// The optional terms of a solve (module doc); `true`: on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Terms {
    /// `emitter_links`: next-event estimation toward emissive surfaces.
    /// Off: their light reaches the vertices through the vertex links
    /// only, as any radiosity (noisier for small emitters).
    pub emitter_links: bool,
    /// `emitter_cv`: the emitter groups as a control variate of the first
    /// bounce (needs the emitter links).
    pub emitter_cv: bool,
    /// `near`: every near-hit correction (near hits are not recorded; the
    /// three below go with it).
    pub near: bool,
    /// `near_emitters`: the emitters' light at near hits.
    pub near_emitters: bool,
    /// `near_sky`: the sky's light at near hits.
    pub near_sky: bool,
    /// `near_gather`: the final gather at near hits (later bounces).
    pub near_gather: bool,
    /// `reconstruct`: gradient-corrected radiosity at link hits.
    pub reconstruct: bool,
    /// `hidden`: hidden vertices replaced as link targets by their visible neighbours.
    pub hidden: bool,
    /// `sky_refine`: more rays where a vertex's view of the sky has an edge.
    pub sky_refine: bool,
    /// `sky_portals`: rays toward the sky's portals.
    pub sky_portals: bool,
    /// `noise_check`: the noise estimate calibrated on the scene (off: the model's ratio).
    pub noise_check: bool,
    /// `smoothing`: the noise-aware smoothing of `E_i` (also off with a feature angle of 0).
    pub smoothing: bool,
    /// `sky_smoothing`: `E_sky` smoothed with its own noise.
    pub sky_smoothing: bool,
}

impl Default for Terms {
    fn default() -> Self {
        Terms::ALL
    }
}

impl Terms {
    /// Every term on.
    pub const ALL: Terms = Terms {
        emitter_links: true,
        emitter_cv: true,
        near: true,
        near_emitters: true,
        near_sky: true,
        near_gather: true,
        reconstruct: true,
        hidden: true,
        sky_refine: true,
        sky_portals: true,
        noise_check: true,
        smoothing: true,
        sky_smoothing: true,
    };

    /// Every term off: as a set of names, none (the terms forced on by
    /// default, [`crate::scene::Settings::forced`]).
    pub const NONE: Terms = Terms {
        emitter_links: false,
        emitter_cv: false,
        near: false,
        near_emitters: false,
        near_sky: false,
        near_gather: false,
        reconstruct: false,
        hidden: false,
        sky_refine: false,
        sky_portals: false,
        noise_check: false,
        smoothing: false,
        sky_smoothing: false,
    };

    /// The terms a solve may switch off by itself where a sample of their
    /// work says they change too little ([`crate::solver::SolveParams::pay_share`]);
    /// `on = [...]` in `[settings]` or `--on` forces one on.
    pub const DECIDED: [&'static str; 3] = ["near_emitters", "near_sky", "near_gather"];

    /// The terms' names, as the scene file and the command line write them.
    pub const NAMES: [&'static str; 13] = [
        "emitter_links",
        "emitter_cv",
        "near",
        "near_emitters",
        "near_sky",
        "near_gather",
        "reconstruct",
        "hidden",
        "sky_refine",
        "sky_portals",
        "noise_check",
        "smoothing",
        "sky_smoothing",
    ];

    fn field(&mut self, name: &str) -> Option<&mut bool> {
        Some(match name {
            "emitter_links" => &mut self.emitter_links,
            "emitter_cv" => &mut self.emitter_cv,
            "near" => &mut self.near,
            "near_emitters" => &mut self.near_emitters,
            "near_sky" => &mut self.near_sky,
            "near_gather" => &mut self.near_gather,
            "reconstruct" => &mut self.reconstruct,
            "hidden" => &mut self.hidden,
            "sky_refine" => &mut self.sky_refine,
            "sky_portals" => &mut self.sky_portals,
            "noise_check" => &mut self.noise_check,
            "smoothing" => &mut self.smoothing,
            "sky_smoothing" => &mut self.sky_smoothing,
            _ => return None,
        })
    }

    /// Whether term `name` is on; `None` for an unknown name.
    pub fn get(&self, name: &str) -> Option<bool> {
        let mut t = *self;
        t.field(name).map(|f| *f)
    }

    /// Turns term `name` on or off; an unknown name is an error listing the known ones.
    pub fn set(&mut self, name: &str, on: bool) -> Result<(), String> {
        match self.field(name.trim()) {
            Some(f) => {
                *f = on;
                Ok(())
            }
            None => Err(format!("unknown term {name:?} (terms: {})", Terms::NAMES.join(", "))),
        }
    }

    /// Every term on but `off`.
    pub fn with_off<'a>(off: impl IntoIterator<Item = &'a str>) -> Result<Terms, String> {
        let mut t = Terms::ALL;
        for name in off {
            t.set(name, false)?;
        }
        Ok(t)
    }

    /// As a set of names: `on` and nothing else (`Terms::NONE` with them set).
    pub fn with_on<'a>(on: impl IntoIterator<Item = &'a str>) -> Result<Terms, String> {
        let mut t = Terms::NONE;
        for name in on {
            t.set(name, true)?;
        }
        Ok(t)
    }

    /// The names of the terms that are on.
    pub fn on(&self) -> Vec<&'static str> {
        Terms::NAMES.into_iter().filter(|n| self.get(n) == Some(true)).collect()
    }

    /// The names of the terms that are off.
    pub fn off(&self) -> Vec<&'static str> {
        Terms::NAMES.into_iter().filter(|n| self.get(n) == Some(false)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_switches_its_own_term_only() {
        for name in Terms::NAMES {
            let t = Terms::with_off([name]).unwrap();
            assert_eq!(t.off(), vec![name]);
            assert_eq!(t.get(name), Some(false));
        }
        assert!(Terms::with_off(["near_gathr"]).unwrap_err().contains("near_gather"));
        assert_eq!(Terms::default().off(), Vec::<&str>::new());
    }
}
