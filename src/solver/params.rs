//! The parameters of a solve: every stage's, with their defaults, in one
//! struct ([`SolveParams`]); the scene's `[settings]` applied by
//! [`SolveParams::from_settings`]; presets as functions
//! ([`SolveParams::preview`], [`SolveParams::reference`]).
//!
//! One seed: the links' ([`SolveParams::seed`]); every other random
//! number derives from it through a named stream
//! ([`crate::sampling::Stream`]). Each stage's struct documents its fields
//! (effect, unit, trade-off); the measurements behind the defaults are in
//! `docs/ACCURACY.md` and `docs/PERFORMANCE.md`.

use crate::bvh::BvhBuildParams;
use crate::exchange::{
    EmitterLinkParams, GatherParams, HiddenParams, LightLinkParams, NearEmitterParams, NearGatherParams, NearSkyParams,
    SmoothParams,
};
use crate::kdtree::KdBuildParams;
use crate::links::LinkParams;
use crate::scene::terms::Terms;
use crate::scene::{Settings, TracerKind};

/// All stage parameters, defaults as listed in docs/DESIGN.md, "Defaults".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveParams {
    /// Which optional terms are on (all by default): the one switch of
    /// every optional stage ([`Terms`]), which each stage reads (a count
    /// of 0 never switches a term off: [`SolveParams::validate`]).
    pub terms: Terms,
    /// Terms kept on whatever a sample of their work says (none by default).
    pub forced: Terms,
    /// The least RMS share by which a term of [`Terms::DECIDED`] must move
    /// the light of a sample of the vertices with near hits to be traced
    /// for all of them (`solver/decide.rs`); 0 keeps every term. Higher:
    /// faster solves of scenes whose near field changes little, and small
    /// local errors left where a term would have corrected them.
    pub pay_share: f32,
    /// The structure rays go through ([`TracerKind`]): on the CPU the BVH
    /// or the kd-tree; on a GPU the same BVH walked with a short stack, the
    /// rope kd-tree (`kd_gpu`) or hardware ray queries.
    pub tracer: TracerKind,
    /// The wide BVH of `tracer = bvh`.
    pub bvh: BvhBuildParams,
    /// kd-tree of `tracer = kd` on the CPU.
    pub kd: KdBuildParams,
    /// kd-tree for the GPU path, whose shader tests one triangle per step
    /// ([`KdBuildParams::for_gpu`]); the hits are the same.
    pub kd_gpu: KdBuildParams,
    /// The vertex links: rays per vertex (accuracy against time and memory,
    /// both linear in it), the one seed, near-hit recording.
    pub links: LinkParams,
    /// Light links: the lights' visibility at the vertices, optional
    /// one-ring oversampling, the bounce source.
    pub light: LightLinkParams,
    /// Next-event estimation toward emissive surfaces (`crate::exchange::sources::emitter_links`).
    pub emitter: EmitterLinkParams,
    /// The emitters' light at near hits (`crate::exchange::near::emitters`).
    pub near_emitter: NearEmitterParams,
    /// The sky's light at near hits (`crate::exchange::near::sky`).
    pub near_sky: NearSkyParams,
    /// The later bounces' light at near hits (`crate::exchange::near::gather`).
    pub near_gather: NearGatherParams,
    /// The bounces: count or `auto` with its tolerance.
    pub gather: GatherParams,
    /// Correction of hidden vertices as link targets (`crate::exchange::bounce::hidden`).
    pub hidden: HiddenParams,
    /// More rays where a vertex's view of the sky has an edge (`crate::sky::refine`).
    pub sky: crate::sky::SkyRefineParams,
    /// Feature angle of smoothing, degrees, in [0, 180]: neighbours whose
    /// normals differ by more are left out (0 leaves every neighbour out:
    /// nothing is smoothed). Read through [`SolveParams::smoothing_angle`],
    /// which the `smoothing` term sets to 0.
    pub smoothing_angle_deg: f32,
    /// The smoothing filter (noise-aware by default, `crate::exchange::denoise::smooth`).
    pub smoothing: SmoothParams,
}

impl SolveParams {
    /// Whether `other` traces through the same structures: the tracer and
    /// the parameters of every tree it may build. A deformation refits
    /// them only then.
    pub fn same_structures(&self, other: &SolveParams) -> bool {
        self.tracer == other.tracer && self.bvh == other.bvh && self.kd == other.kd && self.kd_gpu == other.kd_gpu
    }

    /// Whether `other` shoots the same link rays through the same
    /// structures: a deformation then keeps the recorded hits and re-traces
    /// only what moved.
    pub fn same_links(&self, other: &SolveParams) -> bool {
        self.same_structures(other) && self.links == other.links && self.terms.near == other.terms.near
    }

    /// Whether `other` traces everything as these do (links, lights,
    /// emitters, sky, the near field, the noise check): the one rule of
    /// what a parameter change retraces; anything else takes effect at the
    /// next solve.
    pub fn same_traced(&self, other: &SolveParams) -> bool {
        // A traced term: on in both with the same parameters, or off in both.
        fn same<T: PartialEq>(on: (bool, bool), a: &T, b: &T) -> bool {
            on.0 == on.1 && (!on.0 || a == b)
        }
        let (a, b) = (&self.terms, &other.terms);
        let near = |x: bool, y: bool| (a.near && x, b.near && y);
        self.same_links(other)
            && self.light == other.light
            && same((a.emitter_links, b.emitter_links), &self.emitter, &other.emitter)
            && same(near(a.near_emitters, b.near_emitters), &self.near_emitter, &other.near_emitter)
            && same(near(a.near_sky, b.near_sky), &self.near_sky, &other.near_sky)
            && same(near(a.near_gather, b.near_gather), &self.near_gather, &other.near_gather)
            && same((a.sky_refine, b.sky_refine), &self.sky.sub, &other.sky.sub)
            && same((a.sky_portals, b.sky_portals), &self.sky.portal, &other.sky.portal)
            && same(
                (a.noise_check, b.noise_check),
                &self.smoothing.noise.check_vertices,
                &other.smoothing.noise.check_vertices,
            )
    }
}

impl SolveParams {
    /// The defaults, as listed in docs/DESIGN.md, "Defaults" (each field's
    /// doc gives its effect); `const`, as the presets built from it.
    pub const DEFAULT: SolveParams = SolveParams {
        terms: Terms::ALL,
        forced: Terms::NONE,
        pay_share: 0.02,
        tracer: TracerKind::Auto,
        bvh: BvhBuildParams::DEFAULT,
        kd: KdBuildParams::DEFAULT,
        kd_gpu: KdBuildParams::for_gpu(),
        links: LinkParams::DEFAULT,
        light: LightLinkParams::DEFAULT,
        emitter: EmitterLinkParams::DEFAULT,
        near_emitter: NearEmitterParams::DEFAULT,
        near_sky: NearSkyParams::DEFAULT,
        near_gather: NearGatherParams::DEFAULT,
        gather: GatherParams::DEFAULT,
        hidden: HiddenParams::DEFAULT,
        sky: crate::sky::SkyRefineParams::DEFAULT,
        smoothing_angle_deg: 0.0,
        smoothing: SmoothParams::DEFAULT,
    };
}

impl Default for SolveParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl SolveParams {
    /// Parameters with the scene's settings applied.
    pub fn from_settings(s: &Settings) -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = s.rays_per_vertex;
        p.links.seed = s.seed;
        p.terms = s.terms;
        p.forced = s.forced;
        // Emitters' direct light as many rays as the links (at least 64): its noise falls with theirs.
        p.emitter.samples = s.rays_per_vertex.max(64);
        // Sky portals' rays likewise scale with the links'.
        p.sky.portal = crate::sky::PortalParams::for_link_rays(s.rays_per_vertex);
        p.tracer = s.tracer;
        p.gather.bounces = s.bounces;
        p.smoothing_angle_deg = s.smoothing_angle_deg;
        p.links.near.max_share = s.near_share;
        p
    }

    /// The feature angle the smoothing of `E_i` runs with, degrees: 0
    /// (nothing smoothed) when the `smoothing` term is off, else
    /// [`SolveParams::smoothing_angle_deg`].
    pub fn smoothing_angle(&self) -> f32 {
        if self.terms.smoothing {
            self.smoothing_angle_deg
        } else {
            0.0
        }
    }

    /// The feature angle `E_sky` is smoothed with, degrees: 0 when the
    /// `sky_smoothing` term (or `smoothing`) is off.
    pub fn sky_smoothing_angle(&self) -> f32 {
        if self.terms.sky_smoothing {
            self.smoothing_angle()
        } else {
            0.0
        }
    }

    /// Checks every stage's range: counts of rays and samples at least 1
    /// (a term is switched off by [`SolveParams::terms`], never by a count
    /// of 0), link rays a square number, angles and shares in range, every
    /// float finite. An error names the parameter and its value.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |what: &str, v: &dyn std::fmt::Debug, want: &str| {
            Err(crate::Error::Setting(format!("{what} = {v:?} is not {want}")))
        };
        let rays = self.links.rays_per_vertex;
        let k = (rays as f64).sqrt().round() as u64;
        if rays == 0 || k * k != rays as u64 {
            return bad("links.rays_per_vertex", &rays, "a non-zero square number (k*k)");
        }
        let counts: [(&str, u32); 9] = [
            ("emitter.samples", self.emitter.samples),
            ("near_emitter.samples", self.near_emitter.samples),
            ("near_sky.samples", self.near_sky.samples),
            ("near_sky.portal_samples", self.near_sky.portal_samples),
            ("near_gather.rays", self.near_gather.rays),
            ("sky.portal.rays", self.sky.portal.rays),
            ("smoothing.noise.check_vertices", self.smoothing.noise.check_vertices),
            ("smoothing.passes", self.smoothing.passes),
            ("links.batch_vertices", self.links.batch_vertices.min(1 << 31) as u32),
        ];
        for (what, v) in counts {
            if v == 0 {
                return bad(what, &v, "at least 1 (switch a term off in `terms` instead)");
            }
        }
        if !(1..=crate::sky::refine::MAX_SUB).contains(&self.sky.sub) {
            return bad("sky.sub", &self.sky.sub, &format!("in 1..={}", crate::sky::refine::MAX_SUB));
        }
        let a = self.smoothing_angle_deg;
        if !(a.is_finite() && (0.0..=180.0).contains(&a)) {
            return bad("smoothing_angle_deg", &a, "in [0, 180]");
        }
        let near = &self.links.near;
        if !(near.factor.is_finite() && near.factor > 0.0) {
            return bad("links.near.factor", &near.factor, "finite and above 0");
        }
        if !(near.max_share > 0.0 && near.max_share <= 1.0) {
            return bad("links.near.max_share", &near.max_share, "in (0, 1]");
        }
        if !(self.pay_share.is_finite() && self.pay_share >= 0.0) {
            return bad("pay_share", &self.pay_share, "finite and at least 0");
        }
        if !(self.links.nudge.is_finite() && self.links.nudge >= 0.0) {
            return bad("links.nudge", &self.links.nudge, "finite and at least 0");
        }
        if self.gather.bounces == crate::scene::Bounces::Fixed(0) {
            return bad("gather.bounces", &self.gather.bounces, "at least 1 (or auto)");
        }
        if !(self.gather.tolerance.is_finite() && self.gather.tolerance > 0.0) {
            return bad("gather.tolerance", &self.gather.tolerance, "finite and above 0");
        }
        Ok(())
    }

    /// The seed of every sample the solve draws (the link directions' and,
    /// through named streams, all others').
    pub fn seed(&self) -> u64 {
        self.links.seed
    }

    /// What a refinement round that may still mark edges traces with
    /// (`crate::solver::adaptive`): these parameters with half the link
    /// directions along each axis (a quarter of the rays, at least 16) and
    /// a quarter of the emitter links' samples (at least 16). A round's
    /// marks compare an edge's ends to a tolerance of 25%, above the noise
    /// of 64 rays; the final mesh is traced with these parameters
    /// unchanged. Measured on Šibenik (docs/REAL_SCENES.md): marking
    /// rounds at 64 link rays instead of 256 take 9.2 s instead of 17.2 s
    /// and split 5,356 edges instead of 6,704, for the same image error
    /// against the path tracer (8.5% and 9.1% block error).
    pub fn marking(mut self) -> SolveParams {
        self.emitter.samples = (self.emitter.samples / 4).max(16).min(self.emitter.samples);
        let k = (self.links.rays_per_vertex as f64).sqrt().round() as u32;
        let half = k.div_ceil(2).max(4);
        if half < k {
            self.links.rays_per_vertex = half * half;
        }
        self
    }

    /// A quick preview: 16 rays a vertex, no near-field terms, no noise
    /// check, emitter links at 16 samples; for a first picture in well
    /// under a second on scenes of 100k vertices.
    pub const fn preview() -> SolveParams {
        let mut p = SolveParams::DEFAULT;
        p.links.rays_per_vertex = 16;
        p.terms.near = false;
        p.terms.noise_check = false;
        p.emitter.samples = 16;
        p.sky.portal = crate::sky::PortalParams::for_link_rays(16);
        p
    }

    /// Reference quality: 1024 rays a vertex, auto bounces, every
    /// correction on (none decided off), emitter links with as many samples as link rays.
    pub const fn reference() -> SolveParams {
        let mut p = SolveParams::DEFAULT;
        p.links.rays_per_vertex = 1024;
        p.emitter.samples = 1024;
        p.pay_share = 0.0;
        p.gather.bounces = crate::scene::Bounces::Auto;
        p.sky.portal = crate::sky::PortalParams::for_link_rays(1024);
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The retrace rule: a structure's parameters change every level, the
    /// link rays the last two, an emitter's samples only the last, the
    /// bounces and the smoothing none.
    #[test]
    fn what_a_parameter_change_retraces() {
        let a = SolveParams::default();
        let mut tree = a;
        tree.bvh.bins += 1;
        assert!(!a.same_structures(&tree) && !a.same_links(&tree) && !a.same_traced(&tree));
        let mut rays = a;
        rays.links.rays_per_vertex = 4 * a.links.rays_per_vertex;
        assert!(a.same_structures(&rays) && !a.same_links(&rays) && !a.same_traced(&rays));
        let mut emitter = a;
        emitter.emitter.samples += 1;
        assert!(a.same_links(&emitter) && !a.same_traced(&emitter));
        let mut solve_only = a;
        solve_only.gather.max_bounces += 1;
        solve_only.smoothing_angle_deg += 5.0;
        assert!(a.same_traced(&solve_only));
    }

    /// A traced term switched on or off retraces; a switched-off term's
    /// own parameters retrace nothing; a solve-only term (smoothing,
    /// reconstruct) never retraces.
    #[test]
    fn a_term_retraces_as_its_parameters_do() {
        let a = SolveParams::default();
        for name in ["emitter_links", "near_emitters", "near_sky", "near_gather", "sky_refine", "sky_portals", "noise_check"] {
            let mut off = a;
            off.terms.set(name, false).unwrap();
            assert!(!a.same_traced(&off), "{name}");
        }
        let mut near_off = a;
        near_off.terms.near = false;
        assert!(!a.same_links(&near_off));
        let mut other = near_off;
        other.near_gather.rays += 1;
        other.near_emitter.samples += 1;
        assert!(near_off.same_traced(&other), "near-field parameters of a near field that is off");
        assert!(!a.same_traced(&SolveParams { near_gather: other.near_gather, ..a }));
        let mut solve_only = a;
        (solve_only.terms.smoothing, solve_only.terms.reconstruct, solve_only.terms.hidden) = (false, false, false);
        assert!(a.same_traced(&solve_only));
    }

    /// The smoothing terms read through one accessor each.
    #[test]
    fn switched_off_smoothing_has_no_angle() {
        let mut p = SolveParams { smoothing_angle_deg: 30.0, ..SolveParams::default() };
        assert_eq!((p.smoothing_angle(), p.sky_smoothing_angle()), (30.0, 30.0));
        p.terms.sky_smoothing = false;
        assert_eq!((p.smoothing_angle(), p.sky_smoothing_angle()), (30.0, 0.0));
        (p.terms.sky_smoothing, p.terms.smoothing) = (true, false);
        assert_eq!((p.smoothing_angle(), p.sky_smoothing_angle()), (0.0, 0.0));
    }

    /// The presets and the settings' parameters pass; a count of 0 (the
    /// old way to switch a term off), rays that are not a square and
    /// values out of range fail, naming the parameter.
    #[test]
    fn validate_names_what_is_wrong() {
        for p in [SolveParams::default(), SolveParams::preview(), SolveParams::reference()] {
            p.validate().unwrap();
        }
        SolveParams::from_settings(&Settings::default()).validate().unwrap();
        type Edit = fn(&mut SolveParams);
        let cases: [(&str, Edit); 12] = [
            ("links.rays_per_vertex", |p| p.links.rays_per_vertex = 200),
            ("links.rays_per_vertex", |p| p.links.rays_per_vertex = 0),
            ("emitter.samples", |p| p.emitter.samples = 0),
            ("near_emitter.samples", |p| p.near_emitter.samples = 0),
            ("near_sky.portal_samples", |p| p.near_sky.portal_samples = 0),
            ("near_gather.rays", |p| p.near_gather.rays = 0),
            ("sky.portal.rays", |p| p.sky.portal.rays = 0),
            ("sky.sub", |p| p.sky.sub = 0),
            ("smoothing.noise.check_vertices", |p| p.smoothing.noise.check_vertices = 0),
            ("smoothing_angle_deg", |p| p.smoothing_angle_deg = f32::NAN),
            ("links.near.factor", |p| p.links.near.factor = 0.0),
            ("pay_share", |p| p.pay_share = -1.0),
        ];
        for (name, edit) in cases {
            let mut p = SolveParams::default();
            edit(&mut p);
            let e = p.validate().expect_err(name).to_string();
            assert!(e.contains(name), "{name}: {e}");
        }
    }

    /// The presets are `const fn` (usable in a `const`), and the portal
    /// rays they derive from the link rays stay within `64..=256`.
    #[test]
    fn presets_are_const() {
        const PREVIEW: SolveParams = SolveParams::preview();
        const REFERENCE: SolveParams = SolveParams::reference();
        assert_eq!((PREVIEW.links.rays_per_vertex, PREVIEW.sky.portal.rays), (16, 64));
        assert_eq!((REFERENCE.links.rays_per_vertex, REFERENCE.sky.portal.rays), (1024, 256));
        assert_eq!(crate::sky::PortalParams::for_link_rays(400).rays, 100);
        assert!(!PREVIEW.terms.near && REFERENCE.terms.near);
        assert_eq!(SolveParams::default(), SolveParams::DEFAULT);
    }
}
