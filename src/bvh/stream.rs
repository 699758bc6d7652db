//! Several rays in flight at once: the rays of one origin (a vertex's link
//! rays), runs of closest-hit rays and runs of shadow rays are walked [`IN_FLIGHT`] at a time, each
//! advanced by one node or leaf in turn, and a finished ray's slot takes
//! the next ray. A single ray's walk is a chain of dependent loads and
//! compares (on tearoom's link rays about 10 node steps and 4 leaf tests a
//! ray at 4.1 M rays/s on one thread: some 17 ns a step); independent
//! walks interleaved let the out-of-order core overlap those chains. General
//! tracers answering one call per ray (Embree's `rtcIntersect1`) cannot
//! do this; a batch of a vertex's 256 rays can. Hits are those of
//! [`Bvh::intersect`] / [`Bvh::occluded`] for each ray (the walks share
//! nothing but the tree).

#[cfg(target_arch = "x86_64")]
use super::traverse::{Avx2, Avx512};
use super::traverse::{NodeTest, Portable, Walker};
use super::{Bvh, Isa, EMPTY};
use crate::trace::ray::{Hit, Ray};
use glam::Vec3;

/// Rays walked at once. Measured on this project's 2-core Zen 4 VM,
/// tearoom's link rays on one thread (noise about 5%): 1: 4.15, 2: 3.84,
/// 4: 4.6, 8: 4.38 M rays/s.
pub const IN_FLIGHT: usize = 4;

impl Bvh {
    /// Walks rays `0..n` (`ray(i)`), [`IN_FLIGHT`] at a time, handing each
    /// result to `out(i, hit)`.
    #[inline(always)]
    fn interleaved<N: NodeTest, const ANY: bool>(
        &self,
        n: usize,
        ray: impl Fn(usize) -> Ray,
        mut out: impl FnMut(usize, Option<Hit>),
    ) {
        if self.nodes.is_empty() {
            (0..n).for_each(|i| out(i, None));
            return;
        }
        let mut ws: [Walker; IN_FLIGHT] = std::array::from_fn(|_| Walker::new());
        let mut ids = [usize::MAX; IN_FLIGHT];
        let mut next = 0usize;
        // The leaf of the last hit: consecutive shadow rays (one vertex's
        // oversampling points towards one light) mostly meet the same
        // occluder, so each new any-hit ray tests that leaf first.
        let mut hint = EMPTY;
        let mut live = 0;
        for k in 0..IN_FLIGHT {
            live += self.refill::<N, ANY>(&mut ws[k], &mut ids[k], &mut next, hint, n, &ray, &mut out) as usize;
        }
        while live > 0 {
            for k in 0..IN_FLIGHT {
                if ids[k] == usize::MAX {
                    continue;
                }
                if self.advance::<N, ANY>(&mut ws[k]) {
                    out(ids[k], self.finish::<ANY>(&ws[k]));
                    if ANY && ws[k].hit_leaf != EMPTY {
                        hint = ws[k].hit_leaf;
                    }
                    if !self.refill::<N, ANY>(&mut ws[k], &mut ids[k], &mut next, hint, n, &ray, &mut out) {
                        live -= 1;
                    }
                }
            }
        }
    }

    /// Starts the next ray that needs a walk in `w`; false when none is left.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn refill<N: NodeTest, const ANY: bool>(
        &self,
        w: &mut Walker,
        id: &mut usize,
        next: &mut usize,
        hint: u32,
        n: usize,
        ray: &impl Fn(usize) -> Ray,
        out: &mut impl FnMut(usize, Option<Hit>),
    ) -> bool {
        while *next < n {
            let i = *next;
            *next += 1;
            let r = ray(i);
            if !(r.tmin <= r.tmax) {
                out(i, None);
                continue;
            }
            w.start(&r);
            // Closest-hit walks gained nothing from it (measured: the same
            // node visits per ray on tearoom), so only any-hit walks use it.
            if ANY && hint != EMPTY && self.prime_any::<N>(w, hint) {
                out(i, w.best);
                continue;
            }
            *id = i;
            return true;
        }
        *id = usize::MAX;
        false
    }

    #[inline(always)]
    fn origin_rays<N: NodeTest>(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.interleaved::<N, false>(
            dirs.len(),
            |i| Ray { origin, dir: dirs[i], tmin: 0.0, tmax: f32::INFINITY, skip },
            |i, h| out[i] = h,
        );
    }

    #[inline(always)]
    fn visible_rays<N: NodeTest>(&self, rays: &[Ray], out: &mut [bool]) {
        self.interleaved::<N, true>(rays.len(), |i| rays[i], |i, h| out[i] = h.is_none());
    }

    /// Nearest hits of rays leaving `origin` along `dirs` (unit), skipping
    /// `skip`, into `out[i]` for `dirs[i]`: with AVX-512, walked in
    /// same-origin packets ([`super::packet`]; tearoom's link rays 1.19x,
    /// conference's 1.03x on one Zen 4 thread); otherwise as single rays,
    /// [`IN_FLIGHT`] at a time. The same hits either way.
    pub fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => self.intersect_packets(origin, skip, dirs, out),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                // SAFETY: as above.
                unsafe { self.origin_avx2(origin, skip, dirs, out) }
            }
            _ => self.origin_rays::<Portable>(origin, skip, dirs, out),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt")]
    fn origin_avx2(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.origin_rays::<Avx2>(origin, skip, dirs, out)
    }

    /// [`Bvh::intersect_origin`] as single rays in flight whatever the
    /// build (the walk packets are measured against).
    #[cfg(any(test, feature = "internals"))]
    pub fn intersect_origin_single(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                // SAFETY: `self.isa` is only ever a build the CPU supports (`Bvh::set_isa`).
                unsafe { self.origin_avx512(origin, skip, dirs, out) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                // SAFETY: as above.
                unsafe { self.origin_avx2(origin, skip, dirs, out) }
            }
            _ => self.origin_rays::<Portable>(origin, skip, dirs, out),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt,avx512f,avx512vl")]
    #[cfg(any(test, feature = "internals"))]
    fn origin_avx512(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.origin_rays::<Avx512>(origin, skip, dirs, out)
    }

    /// Nearest hits of a run of rays (any origins and directions), walked
    /// [`IN_FLIGHT`] at a time: `out[i]` for `rays[i]`, the hits of
    /// [`Bvh::intersect`].
    pub fn intersect_run(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                // SAFETY: `self.isa` is only ever a build the CPU supports.
                unsafe { self.run_avx512(rays, out) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                // SAFETY: as above.
                unsafe { self.run_avx2(rays, out) }
            }
            _ => self.run_rays::<Portable>(rays, out),
        }
    }

    #[inline(always)]
    fn run_rays<N: NodeTest>(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.interleaved::<N, false>(rays.len(), |i| rays[i], |i, h| out[i] = h);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt")]
    fn run_avx2(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.run_rays::<Avx2>(rays, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt,avx512f,avx512vl")]
    fn run_avx512(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        self.run_rays::<Avx512>(rays, out)
    }

    /// Visibility of a run of shadow rays (`true`: nothing on the segment).
    pub fn visible_run(&self, rays: &[Ray], out: &mut [bool]) {
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                // SAFETY: `self.isa` is only ever a build the CPU supports.
                unsafe { self.visible_avx512(rays, out) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                // SAFETY: as above.
                unsafe { self.visible_avx2(rays, out) }
            }
            _ => self.visible_rays::<Portable>(rays, out),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt")]
    fn visible_avx2(&self, rays: &[Ray], out: &mut [bool]) {
        self.visible_rays::<Avx2>(rays, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt,avx512f,avx512vl")]
    fn visible_avx512(&self, rays: &[Ray], out: &mut [bool]) {
        self.visible_rays::<Avx512>(rays, out)
    }
}
