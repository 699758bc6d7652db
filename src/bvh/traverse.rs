//! Closest-hit and any-hit traversal of the 8-wide BVH with an explicit
//! stack, children visited nearest first.
//!
//! Node test: the eight slabs of each axis in one SIMD operation, near and
//! far planes picked per ray by the direction's sign, so
//! `t_near = max(t_min, (near - o) / d)` and
//! `t_far = min(t_best, (far - o) / d) * (1 + 2 gamma_3)` (pbrt's robust
//! bound, which keeps rounding from culling a box the ray touches; ties at
//! `t_best` are visited since equal distances are ordered by triangle id).
//! A zero direction component is replaced by `±1e-30`, so no `0 * inf`
//! NaN arises. Three builds of the same arithmetic, chosen once per call by
//! [`Isa::detect`]: AVX-512 (mask compares, and compress to pack the hit
//! children), AVX2 (movemask), and portable loops. min and max are exact
//! and Rust never fuses a multiply and an add, so all three find the same
//! boxes and return the same hits.
//!
//! Leaves test blocks of four triangles with the kd-tree's watertight
//! [`intersect4`], skipping triangles with the ray's `skip` vertex as a
//! corner; nearest `t` wins, ties go to the lower triangle id (as the
//! kd-tree and brute force do). Distances in metres along unit directions.

use super::{is_leaf, leaf_range, Bvh, Node8, EMPTY};
use crate::kdtree::triangle::{intersect4, Hit, RayShear};
use crate::kdtree::Ray;
use glam::Vec3;

/// `1 + 2 gamma_3` (pbrt), with `gamma_n = n eps / (1 - n eps)` for
/// `eps = 2^-24`: scales far distances so rounding never culls a touched box.
const ROBUST: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Entries of the traversal stack (7 per level at most; the build keeps
/// binary depth far below this).
const STACK: usize = 512;

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
            if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl") {
                return Isa::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
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
            Isa::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }
}

/// Per-ray constants of the node test.
#[derive(Clone, Copy, Debug)]
struct RayPre {
    o: [f32; 3],
    inv: [f32; 3],
    /// Row of `Node8::bounds` holding the near (far) plane of each axis.
    near: [usize; 3],
    far: [usize; 3],
    tmin: f32,
}

impl RayPre {
    #[inline(always)]
    fn new(ray: &Ray) -> RayPre {
        let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
        let mut inv = [0f32; 3];
        let (mut near, mut far) = ([0usize; 3], [0usize; 3]);
        for a in 0..3 {
            let da = if d[a].abs() < 1e-30 { 1e-30f32.copysign(d[a]) } else { d[a] };
            inv[a] = 1.0 / da;
            (near[a], far[a]) = if inv[a] >= 0.0 { (a, a + 3) } else { (a + 3, a) };
        }
        RayPre { o, inv, near, far, tmin: ray.tmin }
    }
}

/// The children of a node a ray enters: `count` of them, packed, with their near distances.
struct Entered {
    count: usize,
    child: [u32; 8],
    t: [f32; 8],
}

/// One build of the node test.
trait NodeTest {
    fn test(node: &Node8, r: &RayPre, tbest: f32) -> Entered;
}

/// Packs the children set in `mask`.
#[inline(always)]
fn pack(node: &Node8, mask: u32, t: &[f32; 8]) -> Entered {
    let mut e = Entered { count: 0, child: [EMPTY; 8], t: [0.0; 8] };
    let mut m = mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        m &= m - 1;
        e.child[e.count] = node.child[i];
        e.t[e.count] = t[i];
        e.count += 1;
    }
    e
}

struct Portable;

impl NodeTest for Portable {
    #[inline(always)]
    fn test(node: &Node8, r: &RayPre, tbest: f32) -> Entered {
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
        let mut mask = 0u32;
        for i in 0..8 {
            mask |= ((tn[i] <= tf[i] * ROBUST) as u32) << i;
        }
        pack(node, mask, &tn)
    }
}

#[cfg(target_arch = "x86_64")]
struct Avx2;

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx2 {
    #[inline(always)]
    fn test(node: &Node8, r: &RayPre, tbest: f32) -> Entered {
        use std::arch::x86_64::*;
        // SAFETY: only reached from functions built with AVX2 enabled, which
        // run only where the CPU has it ([`Isa::supported`]); loads are
        // from 32-byte aligned rows of `Node8`.
        unsafe {
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
            let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
            let mut t = [0f32; 8];
            _mm256_storeu_ps(t.as_mut_ptr(), tn);
            pack(node, mask, &t)
        }
    }
}

#[cfg(target_arch = "x86_64")]
struct Avx512;

#[cfg(target_arch = "x86_64")]
impl NodeTest for Avx512 {
    #[inline(always)]
    fn test(node: &Node8, r: &RayPre, tbest: f32) -> Entered {
        use std::arch::x86_64::*;
        // SAFETY: only reached from functions built with AVX-512 F + VL
        // enabled, which run only where the CPU has them; loads are from
        // 32-byte aligned rows of `Node8`, stores into local arrays.
        unsafe {
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
            let mask = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(tn, tf);
            let mut e = Entered { count: mask.count_ones() as usize, child: [EMPTY; 8], t: [0.0; 8] };
            let kids = _mm256_loadu_si256(node.child.as_ptr() as *const __m256i);
            _mm256_mask_compressstoreu_epi32(e.child.as_mut_ptr() as *mut i32, mask, kids);
            _mm256_mask_compressstoreu_ps(e.t.as_mut_ptr(), mask, tn);
            e
        }
    }
}

/// Nearer of two hits: smaller `t`, ties by triangle id.
#[inline(always)]
fn closer(t: f32, tri: u32, best: &Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && tri < b.tri),
    }
}

impl Bvh {
    /// Tests a leaf's blocks; returns true on a hit when `ANY`.
    #[inline(always)]
    fn test_leaf<const ANY: bool>(&self, child: u32, ray: &Ray, shear: &RayShear, best: &mut Option<Hit>) -> bool {
        let (first, count) = leaf_range(child);
        for blk in &self.blocks[first as usize..(first + count) as usize] {
            let tmax = best.map_or(ray.tmax, |b| b.t);
            let h = intersect4(&blk.tri, 0b1111, ray.origin, shear, ray.tmin, tmax);
            let mut m = h.mask;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let [ia, ib, ic, id] = blk.lanes[i];
                if ia == ray.skip || ib == ray.skip || ic == ray.skip {
                    continue;
                }
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

    #[inline(always)]
    fn walk<N: NodeTest, const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() || !(ray.tmin <= ray.tmax) {
            return None;
        }
        let pre = RayPre::new(ray);
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let mut stack = [(0u32, 0f32); STACK];
        let mut sp = 0usize;
        // The root is node 0 (never a leaf word).
        let mut cur = 0u32;
        loop {
            if is_leaf(cur) {
                if self.test_leaf::<ANY>(cur, ray, &shear, &mut best) {
                    return best;
                }
            } else {
                let tbest = best.map_or(ray.tmax, |b| b.t);
                let e = N::test(&self.nodes[cur as usize], &pre, tbest);
                if e.count == 1 {
                    cur = e.child[0];
                    continue;
                }
                if e.count > 1 {
                    // Nearest first: sort the (at most eight) entered
                    // children by distance, push the others farthest first.
                    let (mut c, mut t) = (e.child, e.t);
                    for i in 1..e.count {
                        let (ci, ti) = (c[i], t[i]);
                        let mut j = i;
                        while j > 0 && t[j - 1] > ti {
                            c[j] = c[j - 1];
                            t[j] = t[j - 1];
                            j -= 1;
                        }
                        c[j] = ci;
                        t[j] = ti;
                    }
                    if sp + e.count > STACK {
                        // Cannot happen for trees this builder makes (see `STACK`).
                        debug_assert!(false, "BVH stack overflow");
                        return self.walk_unbounded::<ANY>(ray);
                    }
                    for i in (1..e.count).rev() {
                        stack[sp] = (c[i], t[i]);
                        sp += 1;
                    }
                    cur = c[0];
                    continue;
                }
            }
            // Pop the nearest pending child that can still hold a nearer hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, t) = stack[sp];
                if t <= best.map_or(ray.tmax, |b| b.t) * ROBUST {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// The same search with a growable stack (the fallback for trees
    /// deeper than `STACK` allows; portable node tests).
    #[cold]
    fn walk_unbounded<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        let pre = RayPre::new(ray);
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let mut stack = vec![0u32];
        while let Some(c) = stack.pop() {
            if is_leaf(c) {
                if self.test_leaf::<ANY>(c, ray, &shear, &mut best) {
                    return best;
                }
                continue;
            }
            let e = Portable::test(&self.nodes[c as usize], &pre, best.map_or(ray.tmax, |b| b.t));
            stack.extend_from_slice(&e.child[..e.count]);
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
    #[target_feature(enable = "avx2")]
    fn walk_avx2<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        self.walk::<Avx2, ANY>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
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

    /// Nearest hits of rays leaving `origin` along `dirs`, skipping `skip`.
    pub fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
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

    #[inline(always)]
    fn origin_rays<N: NodeTest>(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        for (d, o) in dirs.iter().zip(out.iter_mut()) {
            *o = self.walk::<N, false>(&Ray { origin, dir: *d, tmin: 0.0, tmax: f32::INFINITY, skip });
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn origin_avx2(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.origin_rays::<Avx2>(origin, skip, dirs, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn origin_avx512(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.origin_rays::<Avx512>(origin, skip, dirs, out)
    }

    /// Visibility of a run of shadow rays (`true`: free).
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

    #[inline(always)]
    fn visible_rays<N: NodeTest>(&self, rays: &[Ray], out: &mut [bool]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.walk::<N, true>(r).is_none();
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn visible_avx2(&self, rays: &[Ray], out: &mut [bool]) {
        self.visible_rays::<Avx2>(rays, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn visible_avx512(&self, rays: &[Ray], out: &mut [bool]) {
        self.visible_rays::<Avx512>(rays, out)
    }
}

/// Nearest hit by testing every block of every leaf (test oracle of the BVH's own layout).
pub fn brute_force(bvh: &Bvh, ray: &Ray) -> Option<Hit> {
    let shear = RayShear::new(ray.dir);
    let mut best = None;
    for blk in &bvh.blocks {
        let h = intersect4(&blk.tri, 0b1111, ray.origin, &shear, ray.tmin, ray.tmax);
        for i in 0..4 {
            let [ia, ib, ic, id] = blk.lanes[i];
            if h.mask >> i & 1 == 0 || ia == ray.skip || ib == ray.skip || ic == ray.skip {
                continue;
            }
            if closer(h.t[i], id, &best) {
                best = Some(Hit { tri: id, u: h.u[i], v: h.v[i], t: h.t[i], front: h.front >> i & 1 == 1 });
            }
        }
    }
    best
}
