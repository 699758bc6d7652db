//! Closest-hit and any-hit traversal of the 8-wide BVH with an explicit
//! stack, children visited front to back in the order the build stored for
//! the ray's direction octant ([`super::Node8::perm`], as tinybvh's BVH8_CPU
//! does): the entered children are packed and pushed in one step with no
//! sort and no branch on their count, and the nearest is taken from
//! registers. A popped child whose entry distance lies beyond the nearest
//! hit so far is skipped.
//!
//! Node test: the eight slabs of each axis in one SIMD operation, near and
//! far planes picked per ray by the direction's sign, so
//! `t_near = max(t_min, (near - o) / d)` and
//! `t_far = min(t_best * (1 + 1e-5), (far - o) / d) * (1 + 2 gamma_3)`
//! (pbrt's robust bound keeps rounding from culling a box the ray touches;
//! the margin on `t_best` keeps boxes holding a hit tied with the best,
//! since equal distances are ordered by triangle id: see `CULL`).
//! A zero direction component is replaced by `±1e-30`, so no `0 * inf`
//! NaN arises. Three builds of the same arithmetic, picked per tree
//! ([`Bvh::isa`], [`Isa::detect`] by default): AVX-512 (mask compares, and compress to pack the hit
//! children), AVX2 (movemask), and portable loops. min and max are exact
//! and Rust never fuses a multiply and an add, so all three find the same
//! boxes and return the same hits.
//!
//! Leaves test blocks of eight triangles ([`super::leaf`]) with the
//! kd-tree's watertight test, skipping triangles with the ray's `skip`
//! vertex as a corner; nearest `t` wins, ties go to the lower triangle id (as the
//! kd-tree and brute force do). Distances in metres along unit directions.

use super::leaf::{intersect8_portable, Block8, Hits8};
use super::{is_leaf, leaf_range, Bvh, Node8};
use crate::kdtree::traverse::closer;
use crate::trace::ray::{Hit, RayShear};
use crate::trace::ray::Ray;
use glam::Vec3;
use std::mem::MaybeUninit;

/// `1 + 2 gamma_3` (pbrt), with `gamma_n = n eps / (1 - n eps)` for
/// `eps = 2^-24`: scales far distances so rounding never culls a touched box.
pub(crate) const ROBUST: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Margin on the nearest hit's distance when culling boxes: a triangle's
/// computed `t` can lie a few ulps below its box's exact entry distance
/// (the two are computed differently), and a box holding a triangle tied
/// with the best hit (equal `t`, lower id wins) must still be entered.
/// Measured: coincident triangles lost their lowest-id tie with no margin.
pub(crate) const CULL: f32 = 1.0 + 1e-5;

/// Entries of the traversal stack (7 per 8-wide level at most: 36 levels;
/// a deeper tree falls back to a growable stack).
pub(super) const STACK: usize = 256;

/// Which SIMD build runs the node tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// AVX-512 F + VL (16-lane masks, compress).
    Avx512,
    /// AVX2 (8-lane compares, movemask).
    Avx2,
    /// Loops over arrays, any CPU.
    Portable,
}

impl Isa {
    /// The best build this CPU runs.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if Isa::Avx512.supported() {
                return Isa::Avx512;
            }
            if Isa::Avx2.supported() {
                return Isa::Avx2;
            }
        }
        Isa::Portable
    }

    /// True if this CPU can run the build.
    pub fn supported(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                use std::arch::is_x86_feature_detected as has;
                has!("avx2") && has!("bmi1") && has!("bmi2") && has!("popcnt") && has!("lzcnt")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                use std::arch::is_x86_feature_detected as has;
                Isa::Avx2.supported() && has!("avx512f") && has!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }
}

/// Per-ray constants of the node test.
#[derive(Clone, Copy, Debug)]
pub(super) struct RayPre {
    o: [f32; 3],
    inv: [f32; 3],
    /// Row of `Node8::bounds` holding the near (far) plane of each axis.
    near: [usize; 3],
    far: [usize; 3],
    tmin: f32,
    /// Shift selecting the ray's octant in `Node8::perm` (3 bits per octant).
    perm_shift: u32,
}

impl RayPre {
    #[inline(always)]
    fn new(ray: &Ray) -> RayPre {
        let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
        let mut inv = [0f32; 3];
        let (mut near, mut far) = ([0usize; 3], [0usize; 3]);
        let mut octant = 0;
        for a in 0..3 {
            let da = if d[a].abs() < 1e-30 { 1e-30f32.copysign(d[a]) } else { d[a] };
            inv[a] = 1.0 / da;
            (near[a], far[a]) = if inv[a] >= 0.0 { (a, a + 3) } else { (a + 3, a) };
            octant |= ((inv[a] < 0.0) as u32) << a;
        }
        RayPre { o, inv, near, far, tmin: ray.tmin, perm_shift: 3 * octant }
    }
}

/// The traversal stack: children and their entry distances. Eight slack
/// entries let a node push all its children with whole-vector stores.
///
/// The entries are `MaybeUninit`: a stack is made per ray and zeroing its
/// 2 KB measured 5% of the walk's time; an entry is read only below `sp`,
/// where [`Stack::push`] or a vector store wrote it.
pub(super) struct Stack {
    child: [MaybeUninit<u32>; STACK + 8],
    t: [MaybeUninit<f32>; STACK + 8],
    sp: usize,
}

impl Stack {
    #[inline(always)]
    pub(super) fn new() -> Stack {
        Stack {
            child: [const { MaybeUninit::uninit() }; STACK + 8],
            t: [const { MaybeUninit::uninit() }; STACK + 8],
            sp: 0,
        }
    }

    /// Pushes child `c` entered at distance `t`.
    #[inline(always)]
    fn push(&mut self, c: u32, t: f32) {
        self.child[self.sp].write(c);
        self.t[self.sp].write(t);
        self.sp += 1;
    }

    /// Pops the top entry (`sp > 0`): its child if its entry distance is
    /// at most `limit`, else `None` (the child is read only then).
    #[inline(always)]
    fn pop_within(&mut self, limit: f32) -> Option<u32> {
        self.sp -= 1;
        // SAFETY: every entry below `sp` was written by `push` or by a
        // vector store of `push_packed`, which advances `sp` only over
        // the entries it stored.
        unsafe { (self.t[self.sp].assume_init() <= limit).then(|| self.child[self.sp].assume_init()) }
    }

    /// The children pushed, bottom first.
    fn children(&self) -> Vec<u32> {
        // SAFETY: as in `pop`: the entries below `sp` were written.
        self.child[..self.sp].iter().map(|c| unsafe { c.assume_init() }).collect()
    }
}

/// One ray's traversal state.
pub(super) struct Walker {
    pub(super) ray: Ray,
    pre: RayPre,
    shear: RayShear,
    pub(super) best: Option<Hit>,
    tbest: f32,
    cur: u32,
    /// Any-hit walks: the leaf that answered the ray (a leaf word), or `EMPTY`.
    pub(super) hit_leaf: u32,
    overflow: bool,
    st: Stack,
}

impl Walker {
    #[inline(always)]
    pub(super) fn new() -> Walker {
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        let st = Stack::new();
        Walker {
            ray,
            pre: RayPre::new(&ray),
            shear: RayShear::new(ray.dir),
            best: None,
            tbest: 0.0,
            cur: 0,
            hit_leaf: super::EMPTY,
            overflow: false,
            st,
        }
    }

    /// Continues `ray` from `node` (a node or leaf word) with the best hit
    /// found so far elsewhere in the tree (a packet's lane handed over to
    /// a single walk of the subtree, [`super::packet`]).
    #[inline(always)]
    pub(super) fn start_at(&mut self, ray: &Ray, node: u32, best: Option<Hit>) {
        self.start(ray);
        self.cur = node;
        self.best = best;
        self.tbest = best.map_or(ray.tmax, |b| b.t);
    }

    /// Starts `ray` at the root (node 0, never a leaf word).
    #[inline(always)]
    pub(super) fn start(&mut self, ray: &Ray) {
        self.ray = *ray;
        self.pre = RayPre::new(ray);
        self.shear = RayShear::new(ray.dir);
        self.best = None;
        self.tbest = ray.tmax;
        self.cur = 0;
        self.hit_leaf = super::EMPTY;
        self.overflow = false;
        self.st.sp = 0;
    }
}

/// One build of the node step and the block test.
pub(super) trait NodeTest {
    /// Tests the node's eight boxes; pushes the entered children except
    /// the nearest (farthest deepest) and returns the nearest, or `None`.
    /// The caller keeps `sp + 8 <= STACK`.
    fn step(node: &Node8, r: &RayPre, tbest: f32, st: &mut Stack) -> Option<u32>;
    /// The block test of this build.
    fn block(b: &Block8, ray: &Ray, s: &RayShear, tmax: f32) -> Hits8;
}

pub(super) struct Portable;

impl NodeTest for Portable {
    #[inline(always)]
    fn step(node: &Node8, r: &RayPre, tbest: f32, st: &mut Stack) -> Option<u32> {
        let b = &node.bounds;
        let mut tn = [r.tmin; 8];
        let mut tf = [tbest; 8];
        for a in 0..3 {
            let (near, far) = (&b[r.near[a]], &b[r.far[a]]);
            for i in 0..8 {
                tn[i] = tn[i].max((near[i] - r.o[a]) * r.inv[a]);
                tf[i] = tf[i].min((far[i] - r.o[a]) * r.inv[a]);
            }
        }
        let mut last = None;
        for i in 0..8 {
            let slot = (node.perm[i] >> r.perm_shift & 7) as usize;
            if tn[slot] <= tf[slot] * ROBUST {
                if let Some((c, t)) = last.replace((node.child[slot], tn[slot])) {
                    st.push(c, t);
                }
            }
        }
        last.map(|l| l.0)
    }

    #[inline(always)]
    fn block(b: &Block8, ray: &Ray, s: &RayShear, tmax: f32) -> Hits8 {
        intersect8_portable(b, ray.origin, s, ray.skip, ray.tmin, tmax)
    }
}

/// The slab distances of the eight boxes, in the ray octant's order.
///
/// # Safety
/// The CPU must have AVX2 (the loads are from `Node8`'s 32-byte aligned rows).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn slabs(
    node: &Node8,
    r: &RayPre,
    tbest: f32,
) -> (std::arch::x86_64::__m256, std::arch::x86_64::__m256, std::arch::x86_64::__m256i) {
    use std::arch::x86_64::*;
    let b = &node.bounds;
    let mut tn = _mm256_set1_ps(r.tmin);
    let mut tf = _mm256_set1_ps(tbest);
    for a in 0..3 {
        let (o, inv) = (_mm256_set1_ps(r.o[a]), _mm256_set1_ps(r.inv[a]));
        let near = _mm256_load_ps(b[r.near[a]].as_ptr());
        let far = _mm256_load_ps(b[r.far[a]].as_ptr());
        tn = _mm256_max_ps(tn, _mm256_mul_ps(_mm256_sub_ps(near, o), inv));
        tf = _mm256_min_ps(tf, _mm256_mul_ps(_mm256_sub_ps(far, o), inv));
    }
    let tf = _mm256_mul_ps(tf, _mm256_set1_ps(ROBUST));
    let perm = _mm256_and_si256(
        _mm256_srlv_epi32(
            _mm256_load_si256(node.perm.as_ptr() as *const __m256i),
            _mm256_set1_epi32(r.perm_shift as i32),
        ),
        _mm256_set1_epi32(7),
    );
    let kids = _mm256_load_si256(node.child.as_ptr() as *const __m256i);
    (_mm256_permutevar8x32_ps(tn, perm), _mm256_permutevar8x32_ps(tf, perm), _mm256_permutevar8x32_epi32(kids, perm))
}

/// Stores packed children and distances on the stack (whole vectors) and
/// returns the last, the nearest.
///
/// # Safety
/// The CPU must have AVX2, and `st.sp + 8 <= STACK` (the stack's eight
/// slack entries take the whole-vector stores); `n <= 8`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn push_packed(
    c: std::arch::x86_64::__m256i,
    t: std::arch::x86_64::__m256,
    n: usize,
    st: &mut Stack,
) -> Option<u32> {
    use std::arch::x86_64::*;
    if n == 0 {
        return None;
    }
    _mm256_storeu_si256(st.child.as_mut_ptr().add(st.sp) as *mut __m256i, c);
    _mm256_storeu_ps(st.t.as_mut_ptr().add(st.sp) as *mut f32, t);
    st.sp += n - 1;
    // The nearest straight from the register (a load from the store just
    // made could wait for it).
    let top = _mm256_permutevar8x32_epi32(c, _mm256_set1_epi32(n as i32 - 1));
    Some(_mm256_cvtsi256_si32(top) as u32)
}

#[cfg(target_arch = "x86_64")]
pub(super) struct Avx2;

/// For every 8-bit mask, the lanes set in it, packed low (3 bits each;
/// AVX2 has no compress instruction).
#[cfg(target_arch = "x86_64")]
static PACK: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut v, mut k, mut i) = (0u32, 0u32, 0u32);
        while i < 8 {
            if m >> i & 1 == 1 {
                v |= i << (3 * k);
                k += 1;
            }
            i += 1;
        }
        t[m] = v;
        m += 1;
    }
    t
};

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx2 {
    #[inline(always)]
    fn step(node: &Node8, r: &RayPre, tbest: f32, st: &mut Stack) -> Option<u32> {
        use std::arch::x86_64::*;
        // SAFETY: only reached from functions built with AVX2 enabled, which
        // run only where the CPU has it ([`Isa::supported`]); loads are
        // from 32-byte aligned rows of `Node8`; stores stay within the
        // stack's eight slack entries (the caller keeps `sp + 8 <= STACK`).
        unsafe {
            let (tn, tf, kids) = slabs(node, r, tbest);
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as usize;
            let idx =
                _mm256_srlv_epi32(_mm256_set1_epi32(PACK[mask] as i32), _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21));
            let idx = _mm256_and_si256(idx, _mm256_set1_epi32(7));
            let c = _mm256_permutevar8x32_epi32(kids, idx);
            let t = _mm256_permutevar8x32_ps(tn, idx);
            push_packed(c, t, mask.count_ones() as usize, st)
        }
    }

    #[inline(always)]
    fn block(b: &Block8, ray: &Ray, s: &RayShear, tmax: f32) -> Hits8 {
        // SAFETY: as `step`: only reached from walks built with AVX2 that
        // run where the CPU has it.
        unsafe { super::leaf::intersect8_avx(b, ray.origin, s, ray.skip, ray.tmin, tmax) }
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) struct Avx512;

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx512 {
    #[inline(always)]
    fn step(node: &Node8, r: &RayPre, tbest: f32, st: &mut Stack) -> Option<u32> {
        use std::arch::x86_64::*;
        // SAFETY: only reached from functions built with AVX-512 F + VL
        // enabled, which run only where the CPU has them; as for `Avx2`.
        unsafe {
            let (tn, tf, kids) = slabs(node, r, tbest);
            let mask = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(tn, tf);
            let c = _mm256_maskz_compress_epi32(mask, kids);
            let t = _mm256_maskz_compress_ps(mask, tn);
            push_packed(c, t, mask.count_ones() as usize, st)
        }
    }

    /// The AVX2 block test (AVX-512 adds nothing to eight lanes).
    #[inline(always)]
    fn block(b: &Block8, ray: &Ray, s: &RayShear, tmax: f32) -> Hits8 {
        Avx2::block(b, ray, s, tmax)
    }
}

impl Bvh {
    /// Tests a leaf's blocks; returns true on a hit when `ANY`.
    #[inline(always)]
    pub(super) fn test_leaf<N: NodeTest, const ANY: bool>(
        &self,
        child: u32,
        ray: &Ray,
        shear: &RayShear,
        best: &mut Option<Hit>,
    ) -> bool {
        let (first, count) = leaf_range(child);
        for blk in &self.blocks[first as usize..(first + count) as usize] {
            let tmax = best.map_or(ray.tmax, |b| b.t);
            let h = N::block(blk, ray, shear, tmax);
            let mut m = h.mask;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let id = blk.tri[i];
                if closer(h.t[i], id, best) {
                    *best = Some(Hit { tri: id, u: h.u[i], v: h.v[i], t: h.t[i], front: h.front >> i & 1 == 1 });
                    if ANY {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Advances `w` by one node or leaf; returns true when its ray is done.
    #[inline(always)]
    pub(super) fn advance<N: NodeTest, const ANY: bool>(&self, w: &mut Walker) -> bool {
        if is_leaf(w.cur) {
            if self.test_leaf::<N, ANY>(w.cur, &w.ray, &w.shear, &mut w.best) {
                w.hit_leaf = w.cur;
                return true;
            }
            w.tbest = w.best.map_or(w.ray.tmax, |b| b.t);
        } else {
            if w.st.sp + 8 > STACK {
                // Cannot happen for trees this builder makes (see `STACK`).
                w.overflow = true;
                return true;
            }
            if let Some(next) = N::step(&self.nodes[w.cur as usize], &w.pre, w.tbest * CULL, &mut w.st) {
                w.cur = next;
                return false;
            }
        }
        // Pop the nearest pending child that can still hold a nearer hit.
        loop {
            if w.st.sp == 0 {
                return true;
            }
            if let Some(c) = w.st.pop_within(w.tbest * CULL) {
                w.cur = c;
                return false;
            }
        }
    }

    /// Any-hit walks: tests `leaf` (a leaf word: the leaf that answered a
    /// nearby ray) before the walk; true when it answers this ray too.
    /// Otherwise nothing changed and the walk runs as without the hint.
    #[inline(always)]
    pub(super) fn prime_any<N: NodeTest>(&self, w: &mut Walker, leaf: u32) -> bool {
        if self.test_leaf::<N, true>(leaf, &w.ray, &w.shear, &mut w.best) {
            w.hit_leaf = leaf;
            return true;
        }
        false
    }

    /// The result of a finished walker.
    #[inline(always)]
    pub(super) fn finish<const ANY: bool>(&self, w: &Walker) -> Option<Hit> {
        if w.overflow {
            self.walk_unbounded::<ANY>(&w.ray)
        } else {
            w.best
        }
    }

    #[inline(always)]
    fn walk<N: NodeTest, const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() || !(ray.tmin <= ray.tmax) {
            return None;
        }
        let mut w = Walker::new();
        w.start(ray);
        while !self.advance::<N, ANY>(&mut w) {}
        self.finish::<ANY>(&w)
    }

    /// The same search with a growable stack (the fallback for trees
    /// deeper than `STACK` allows; portable node tests).
    #[cold]
    fn walk_unbounded<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        let pre = RayPre::new(ray);
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let mut stack = vec![0u32];
        let mut st = Stack::new();
        while let Some(c) = stack.pop() {
            if is_leaf(c) {
                if self.test_leaf::<Portable, ANY>(c, ray, &shear, &mut best) {
                    return best;
                }
                continue;
            }
            st.sp = 0;
            if let Some(n) =
                Portable::step(&self.nodes[c as usize], &pre, best.map_or(ray.tmax, |b| b.t) * CULL, &mut st)
            {
                stack.extend(st.children());
                stack.push(n);
            }
        }
        best
    }

    /// Nearest hit of `ray` with the node tests of `isa` (which this CPU
    /// must support: [`Isa::supported`]; otherwise the portable build runs).
    pub fn intersect_with(&self, ray: &Ray, isa: Isa) -> Option<Hit> {
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 if isa.supported() => {
                // SAFETY: the CPU has AVX-512 F + VL (checked just above).
                unsafe { self.walk_avx512::<false>(ray) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 if isa.supported() => {
                // SAFETY: the CPU has AVX2 (checked just above).
                unsafe { self.walk_avx2::<false>(ray) }
            }
            _ => self.walk::<Portable, false>(ray),
        }
    }

    /// True if anything lies on the segment, with the node tests of `isa`.
    pub fn occluded_with(&self, ray: &Ray, isa: Isa) -> bool {
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 if isa.supported() => {
                // SAFETY: as in `intersect_with`.
                unsafe { self.walk_avx512::<true>(ray).is_some() }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 if isa.supported() => {
                // SAFETY: as in `intersect_with`.
                unsafe { self.walk_avx2::<true>(ray).is_some() }
            }
            _ => self.walk::<Portable, true>(ray).is_some(),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt")]
    fn walk_avx2<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        self.walk::<Avx2, ANY>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt,avx512f,avx512vl")]
    fn walk_avx512<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        self.walk::<Avx512, ANY>(ray)
    }

    /// Nearest hit (front or back face) along the ray, with the best node test this CPU has.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_with(ray, self.isa)
    }

    /// True if anything (front or back face) lies on the ray segment.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, self.isa)
    }
}
