//! Same-origin packets (issue 35): up to [`PACKET`] rays that leave one
//! point walk the tree together. A vertex's link rays share their origin
//! and come in 4x4 blocks of nearby directions ([`crate::sampling`]), so a
//! block mostly enters the same nodes: each node's eight child boxes are
//! loaded once for the packet and tested against all its rays at once (one
//! 16-lane operation per child and axis in the AVX-512 build), and the
//! stack holds a child with the mask of the rays that entered it.
//!
//! Hits equal the single-ray walk's ([`Bvh::intersect`]) bit for bit: a
//! ray's box test is the single-ray test's arithmetic on its own lane
//! (`t_near = max(t_min, (near - o) / d)`,
//! `t_far = min(t_best * CULL, (far - o) / d) * ROBUST`,
//! [`super::traverse`]), leaves are tested per ray with the single-ray
//! leaf test, and the nearest hit with ties to the lower triangle id does
//! not depend on the order leaves are met in. A ray can only be walked
//! into more boxes than alone (the children are ordered for the packet's
//! first ray, and a popped child is not culled per ray), never fewer, and
//! a box it enters in vain holds nothing nearer than its best. A child
//! entered by at most `SPLIT` of the packet's rays is walked by each of
//! them alone from there (the single-ray walk of that subtree, starting
//! with the ray's best so far).

#[cfg(target_arch = "x86_64")]
use super::traverse::{Avx2, Avx512};
use super::traverse::{NodeTest, Portable, Walker, CULL, ROBUST, STACK};
use super::{is_leaf, Bvh, Isa, EMPTY};
use crate::kdtree::traverse::closer;
use crate::trace::ray::{Hit, RayShear};
use crate::trace::ray::Ray;
use glam::Vec3;

/// Rays walked together: a 4x4 block of a vertex's direction set.
pub const PACKET: usize = 16;

/// A child entered by at most this many of a packet's rays is walked by
/// each of them alone (single-ray walks of the subtree).
const SPLIT: u32 = 3;

/// The rays of one packet and their walk state, lane by lane.
struct Packet {
    n: usize,
    o: [f32; 3],
    /// Per axis: `1 / d` per lane (a zero component as `±1e-30`, as
    /// the single-ray test does).
    inv: [[f32; PACKET]; 3],
    /// Per axis: the lanes whose direction component is negative (near plane = box max).
    neg: [u16; 3],
    tmin: f32,
    rays: [Ray; PACKET],
    shears: [RayShear; PACKET],
    best: [Option<Hit>; PACKET],
    /// Shift of the first ray's octant in `Node8::perm`.
    perm_shift: u32,
    /// Per lane: the shear constants of [`RayShear`] (`sx`, `sy`, `sz`).
    shear: [[f32; PACKET]; 3],
    /// Per lane: the sheared axes `(kx, ky, kz)` coded `kx + 3 ky + 9 kz`.
    axes: [u8; PACKET],
    /// Per axis: the least and greatest `1 / d` over the packet's rays.
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    /// Per axis: 0 where every ray's component is positive, 1 where every
    /// one is negative, 2 where they differ.
    cone_sign: [u8; 3],
}

impl Packet {
    fn new(origin: Vec3, skip: u32, dirs: &[Vec3]) -> Packet {
        let n = dirs.len().min(PACKET);
        let ray0 = Ray { origin, dir: Vec3::Z, tmin: 0.0, tmax: f32::INFINITY, skip };
        let mut p = Packet {
            n,
            o: origin.to_array(),
            inv: [[1.0; PACKET]; 3],
            neg: [0; 3],
            tmin: 0.0,
            rays: [ray0; PACKET],
            shears: [RayShear::new(Vec3::Z); PACKET],
            best: [None; PACKET],
            perm_shift: 0,
            shear: [[0.0; PACKET]; 3],
            axes: [0; PACKET],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            cone_sign: [2; 3],
        };
        for (l, d) in dirs[..n].iter().enumerate() {
            p.rays[l].dir = *d;
            let sh = RayShear::new(*d);
            p.shears[l] = sh;
            let (kx, ky, kz) = sh.axes();
            p.axes[l] = (kx + 3 * ky + 9 * kz) as u8;
            (p.shear[0][l], p.shear[1][l], p.shear[2][l]) = (sh.sx(), sh.sy(), sh.sz());
            for (a, &da) in d.to_array().iter().enumerate() {
                let da = if da.abs() < 1e-30 { 1e-30f32.copysign(da) } else { da };
                p.inv[a][l] = 1.0 / da;
                p.neg[a] |= ((p.inv[a][l] < 0.0) as u16) << l;
            }
        }
        let all = ((1u32 << n) - 1) as u16;
        for a in 0..3 {
            let lanes = &p.inv[a][..n];
            p.inv_lo[a] = lanes.iter().copied().fold(f32::INFINITY, f32::min);
            p.inv_hi[a] = lanes.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            p.cone_sign[a] = match p.neg[a] & all {
                0 => 0,
                m if m == all => 1,
                _ => 2,
            };
        }
        let octant = (0..3).fold(0, |o, a| o | ((p.neg[a] & 1) as u32) << a);
        p.perm_shift = 3 * octant;
        p
    }

    fn active(&self) -> u16 {
        ((1u32 << self.n) - 1) as u16
    }
}

/// The packet's box test: per child slot, the lanes of `mask` whose ray
/// enters it, with the lanes' cull distances `tbest` kept in registers
/// where the build has them (a lane's scalar store followed by a vector
/// load of all lanes would stall on store forwarding at every node).
trait PacketTest {
    type Leaf: NodeTest;
    /// The lanes' cull distance bases (best `t` or `tmax`).
    type Lanes: Copy;
    fn lanes(t: &[f32; PACKET]) -> Self::Lanes;
    fn set(v: Self::Lanes, l: usize, t: f32) -> Self::Lanes;
    fn masks(node: &super::Node8, p: &Packet, tbest: Self::Lanes, mask: u16) -> [u16; 8];
    /// Tests leaf `c` for the rays of `mask` together where this build
    /// can (all of them sheared alike); false where it did not.
    #[inline(always)]
    fn shared_leaf(_bvh: &Bvh, _c: u32, _p: &mut Packet, _mask: u16, _tbest: &mut Self::Lanes) -> bool {
        false
    }
}

struct PortablePacket;

impl PacketTest for PortablePacket {
    type Leaf = Portable;
    type Lanes = [f32; PACKET];

    #[inline(always)]
    fn lanes(t: &[f32; PACKET]) -> Self::Lanes {
        *t
    }

    #[inline(always)]
    fn set(mut v: Self::Lanes, l: usize, t: f32) -> Self::Lanes {
        v[l] = t;
        v
    }

    #[inline(always)]
    fn masks(node: &super::Node8, p: &Packet, tbest: Self::Lanes, mask: u16) -> [u16; 8] {
        let b = &node.bounds;
        let mut out = [0u16; 8];
        for (i, m) in out.iter_mut().enumerate() {
            let mut bits = mask;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let mut tn = p.tmin;
                let mut tf = tbest[l] * CULL;
                for a in 0..3 {
                    let (near, far) =
                        if p.neg[a] >> l & 1 == 1 { (b[a + 3][i], b[a][i]) } else { (b[a][i], b[a + 3][i]) };
                    tn = tn.max((near - p.o[a]) * p.inv[a][l]);
                    tf = tf.min((far - p.o[a]) * p.inv[a][l]);
                }
                if tn <= tf * ROBUST {
                    *m |= 1 << l;
                }
            }
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
struct Avx512Packet;

#[cfg(target_arch = "x86_64")]
impl PacketTest for Avx512Packet {
    type Leaf = Avx512;
    type Lanes = std::arch::x86_64::__m512;

    #[inline(always)]
    fn lanes(t: &[f32; PACKET]) -> Self::Lanes {
        // SAFETY: AVX-512 F builds only (as `masks`); reads 16 floats.
        unsafe { std::arch::x86_64::_mm512_loadu_ps(t.as_ptr()) }
    }

    #[inline(always)]
    fn set(v: Self::Lanes, l: usize, t: f32) -> Self::Lanes {
        use std::arch::x86_64::*;
        // SAFETY: AVX-512 F builds only (as `masks`).
        unsafe { _mm512_mask_broadcastss_ps(v, 1 << l, _mm_set_ss(t)) }
    }

    #[inline(always)]
    fn shared_leaf(bvh: &Bvh, c: u32, p: &mut Packet, mask: u16, tbest: &mut Self::Lanes) -> bool {
        if mask.count_ones() < SHARE {
            return false;
        }
        let code = p.axes[mask.trailing_zeros() as usize];
        let mut bits = mask;
        while bits != 0 {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if p.axes[l] != code {
                return false;
            }
        }
        // SAFETY: AVX-512 F builds only (as `masks`).
        unsafe { Self::leaf_rays(bvh, c, p, mask, tbest) };
        true
    }

    #[inline(always)]
    fn masks(node: &super::Node8, p: &Packet, tbest: Self::Lanes, mask: u16) -> [u16; 8] {
        use std::arch::x86_64::*;
        // SAFETY: only reached from functions built with AVX-512 F + VL
        // enabled, which run only where the CPU has them; the loads read
        // whole `[f32; 16]` and `[f32; 8]` arrays.
        unsafe {
            let b = &node.bounds;
            // The planes' offsets from the shared origin, once per node
            // (`near - o` of a lane is one of them, bit for bit).
            let mut rel = [[0f32; 8]; 6];
            for (k, r) in rel.iter_mut().enumerate() {
                let d = _mm256_sub_ps(_mm256_load_ps(b[k].as_ptr()), _mm256_set1_ps(p.o[k % 3]));
                _mm256_storeu_ps(r.as_mut_ptr(), d);
            }
            // Arrays built element by element: `[_; 3].map` went through
            // a call and copies on the stack (1.8% of the link stage).
            let inv = [
                _mm512_loadu_ps(p.inv[0].as_ptr()),
                _mm512_loadu_ps(p.inv[1].as_ptr()),
                _mm512_loadu_ps(p.inv[2].as_ptr()),
            ];
            let tb = _mm512_mul_ps(tbest, _mm512_set1_ps(CULL));
            let tmin = _mm512_set1_ps(p.tmin);
            let robust = _mm512_set1_ps(ROBUST);
            // Per axis: 0 all lanes positive, 1 all negative, 2 mixed.
            let sign_of = |a: usize| match p.neg[a] & mask {
                0 => 0,
                m if m == mask => 1,
                _ => 2,
            };
            let sign = [sign_of(0), sign_of(1), sign_of(2)];
            // The packet's cone first: per axis of one sign, the least
            // entry and the greatest exit distance over the lanes of `mask`
            // bound every lane's (the product is monotone in `1 / d`, and
            // rounding is monotone), eight children a vector. A child whose
            // bound entry lies beyond its bound exit is entered by no lane.
            let mut lb = _mm256_set1_ps(p.tmin);
            let mut ub = _mm256_set1_ps(_mm512_mask_reduce_max_ps(mask, tb));
            for a in 0..3 {
                if p.cone_sign[a] == 2 {
                    continue;
                }
                let (lo, hi) = (_mm256_set1_ps(p.inv_lo[a]), _mm256_set1_ps(p.inv_hi[a]));
                let (k_near, k_far) = if p.cone_sign[a] == 0 { (a, a + 3) } else { (a + 3, a) };
                let near = _mm256_loadu_ps(rel[k_near].as_ptr());
                let far = _mm256_loadu_ps(rel[k_far].as_ptr());
                // Least `near / d` (at the least `1 / d` where near >= 0),
                // greatest `far / d` (at the greatest where far >= 0).
                let tn = _mm256_blendv_ps(_mm256_mul_ps(near, lo), _mm256_mul_ps(near, hi), near);
                let tf = _mm256_blendv_ps(_mm256_mul_ps(far, hi), _mm256_mul_ps(far, lo), far);
                lb = _mm256_max_ps(lb, tn);
                ub = _mm256_min_ps(ub, tf);
            }
            let live = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(lb, _mm256_mul_ps(ub, _mm256_set1_ps(ROBUST))));
            let mut out = [0u16; 8];
            let mut bits = live as u32;
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let m = &mut out[i];
                let mut tn = tmin;
                let mut tf = tb;
                for a in 0..3 {
                    let (lo, hi) = (_mm512_set1_ps(rel[a][i]), _mm512_set1_ps(rel[a + 3][i]));
                    let (near, far) = match sign[a] {
                        0 => (lo, hi),
                        1 => (hi, lo),
                        _ => (_mm512_mask_blend_ps(p.neg[a], lo, hi), _mm512_mask_blend_ps(p.neg[a], hi, lo)),
                    };
                    tn = _mm512_max_ps(tn, _mm512_mul_ps(near, inv[a]));
                    tf = _mm512_min_ps(tf, _mm512_mul_ps(far, inv[a]));
                }
                *m = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(mask, tn, _mm512_mul_ps(tf, robust));
            }
            out
        }
    }
}

/// Rays a leaf must be entered by for the shared test to pay (below,
/// each ray's own 8-lane block test is cheaper than eight 16-lane ones).
const SHARE: u32 = 6;

#[cfg(target_arch = "x86_64")]
impl Avx512Packet {
    /// The watertight test of [`super::leaf::intersect8_avx`] transposed:
    /// lanes are the packet's rays (all with the same sheared axes), one
    /// triangle at a time, the same operations per lane in the same order
    /// (so the same `t`, `u`, `v` bit for bit); lanes with an edge function
    /// exactly zero take the scalar test, as there.
    ///
    /// # Safety
    /// The CPU must have AVX-512 F and VL (the packet walks that call it
    /// are built with them and run only where [`Isa::supported`] says so);
    /// `c` is a leaf child of `bvh`.
    #[inline(always)]
    unsafe fn leaf_rays(bvh: &Bvh, c: u32, p: &mut Packet, mask: u16, tbest: &mut std::arch::x86_64::__m512) {
        use std::arch::x86_64::*;
        let code = p.axes[mask.trailing_zeros() as usize] as usize;
        let (kx, ky, kz) = (code % 3, code / 3 % 3, code / 9);
        let (sx, sy, sz) = (
            _mm512_loadu_ps(p.shear[0].as_ptr()),
            _mm512_loadu_ps(p.shear[1].as_ptr()),
            _mm512_loadu_ps(p.shear[2].as_ptr()),
        );
        let z = _mm512_setzero_ps();
        let skip = p.rays[0].skip;
        let (first, count) = super::leaf_range(c);
        for blk in &bvh.blocks[first as usize..(first + count) as usize] {
            for i in 0..super::leaf::LANES {
                let id = blk.tri[i];
                if id == super::leaf::UNUSED || (0..3).any(|k| blk.corners[k][i] == skip) {
                    continue;
                }
                let q = |corner: usize, k: usize| _mm512_set1_ps(blk.v[corner][k][i] - p.o[k]);
                let (akx, aky, akz) = (q(0, kx), q(0, ky), q(0, kz));
                let (bkx, bky, bkz) = (q(1, kx), q(1, ky), q(1, kz));
                let (ckx, cky, ckz) = (q(2, kx), q(2, ky), q(2, kz));
                let (ax, ay) = (_mm512_sub_ps(akx, _mm512_mul_ps(sx, akz)), _mm512_sub_ps(aky, _mm512_mul_ps(sy, akz)));
                let (bx, by) = (_mm512_sub_ps(bkx, _mm512_mul_ps(sx, bkz)), _mm512_sub_ps(bky, _mm512_mul_ps(sy, bkz)));
                let (cx, cy) = (_mm512_sub_ps(ckx, _mm512_mul_ps(sx, ckz)), _mm512_sub_ps(cky, _mm512_mul_ps(sy, ckz)));
                let u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
                let v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
                let w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
                let lt = |x: __m512| _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(mask, x, z);
                let gt = |x: __m512| _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(mask, x, z);
                let eq = |x: __m512| _mm512_mask_cmp_ps_mask::<_CMP_EQ_OQ>(mask, x, z);
                let neg = lt(u) | lt(v) | lt(w);
                let pos = gt(u) | gt(v) | gt(w);
                let zero = eq(u) | eq(v) | eq(w);
                let inside = (neg ^ pos) & !zero & mask;
                let redo = zero & mask;
                if inside == 0 && redo == 0 {
                    continue;
                }
                let det = _mm512_add_ps(_mm512_add_ps(u, v), w);
                let t_scaled = _mm512_mul_ps(
                    sz,
                    _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(u, akz), _mm512_mul_ps(v, bkz)), _mm512_mul_ps(w, ckz)),
                );
                let inv = _mm512_div_ps(_mm512_set1_ps(1.0), det);
                let t = _mm512_mul_ps(t_scaled, inv);
                let in_range = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(t, _mm512_set1_ps(p.tmin))
                    & _mm512_cmp_ps_mask::<_CMP_LE_OQ>(t, *tbest);
                let det_zero = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(det, z);
                let hit = inside & !det_zero & in_range;
                if hit != 0 {
                    let (mut ts, mut us, mut vs) = ([0f32; PACKET], [0f32; PACKET], [0f32; PACKET]);
                    _mm512_storeu_ps(ts.as_mut_ptr(), t);
                    _mm512_storeu_ps(us.as_mut_ptr(), _mm512_mul_ps(v, inv));
                    _mm512_storeu_ps(vs.as_mut_ptr(), _mm512_mul_ps(w, inv));
                    let front = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(det, z);
                    let mut bits = hit;
                    while bits != 0 {
                        let l = bits.trailing_zeros() as usize;
                        bits &= bits - 1;
                        if closer(ts[l], id, &p.best[l]) {
                            p.best[l] = Some(Hit { tri: id, u: us[l], v: vs[l], t: ts[l], front: front >> l & 1 == 1 });
                            *tbest = Self::set(*tbest, l, ts[l]);
                        }
                    }
                }
                let mut bits = redo;
                while bits != 0 {
                    let l = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let tmax = p.best[l].map_or(p.rays[l].tmax, |h| h.t);
                    if let Some((tt, uu, vv, front)) =
                        super::leaf::lane(blk, i, p.rays[l].origin, &p.shears[l], p.tmin, tmax)
                    {
                        if closer(tt, id, &p.best[l]) {
                            p.best[l] = Some(Hit { tri: id, u: uu, v: vv, t: tt, front });
                            *tbest = Self::set(*tbest, l, tt);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
struct Avx2Packet;

#[cfg(target_arch = "x86_64")]
impl PacketTest for Avx2Packet {
    type Leaf = Avx2;
    type Lanes = [f32; PACKET];

    #[inline(always)]
    fn lanes(t: &[f32; PACKET]) -> Self::Lanes {
        *t
    }

    #[inline(always)]
    fn set(v: Self::Lanes, l: usize, t: f32) -> Self::Lanes {
        PortablePacket::set(v, l, t)
    }

    #[inline(always)]
    fn masks(node: &super::Node8, p: &Packet, tbest: Self::Lanes, mask: u16) -> [u16; 8] {
        PortablePacket::masks(node, p, tbest, mask)
    }
}

impl Bvh {
    /// Walks packet `p` to the end (`stack`: scratch, reused between packets).
    #[inline(always)]
    fn walk_packet<T: PacketTest>(&self, p: &mut Packet, stack: &mut [(u32, u16); STACK], walker: &mut Walker) {
        // Every ray of a packet runs to infinity (`Packet::new`).
        let mut tbest = T::lanes(&[f32::INFINITY; PACKET]);
        let mut sp = 0;
        let mut cur = (0u32, p.active());
        loop {
            let (c, mask) = cur;
            if is_leaf(c) {
                let mut bits = if T::shared_leaf(self, c, p, mask, &mut tbest) { 0 } else { mask };
                while bits != 0 {
                    let l = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    self.test_leaf::<T::Leaf, false>(c, &p.rays[l], &p.shears[l], &mut p.best[l]);
                    tbest = T::set(tbest, l, p.best[l].map_or(p.rays[l].tmax, |h| h.t));
                }
            } else if sp + 8 > STACK {
                // Cannot happen for trees this builder makes (see `STACK`):
                // the lanes left finish on their own.
                for l in 0..p.n {
                    p.best[l] = self.intersect(&p.rays[l]);
                }
                return;
            } else {
                let node = &self.nodes[c as usize];
                let masks = T::masks(node, p, tbest, mask);
                // Front to back for the first ray's octant: the nearest is pushed last.
                for i in 0..8 {
                    let slot = (node.perm[i] >> p.perm_shift & 7) as usize;
                    if masks[slot] != 0 && node.child[slot] != EMPTY {
                        stack[sp] = (node.child[slot], masks[slot]);
                        sp += 1;
                    }
                }
            }
            // Pop; a child entered by few rays is left to their single walks.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let (c, m) = stack[sp];
                if m.count_ones() > SPLIT {
                    cur = (c, m);
                    break;
                }
                let mut bits = m;
                while bits != 0 {
                    let l = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    walker.start_at(&p.rays[l], c, p.best[l]);
                    while !self.advance::<T::Leaf, false>(walker) {}
                    p.best[l] = self.finish::<false>(walker);
                    tbest = T::set(tbest, l, p.best[l].map_or(p.rays[l].tmax, |h| h.t));
                }
            }
        }
    }

    #[inline(always)]
    fn packets<T: PacketTest>(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        let mut stack = [(0u32, 0u16); STACK];
        let mut walker = Walker::new();
        for (d, o) in dirs.chunks(PACKET).zip(out.chunks_mut(PACKET)) {
            let mut p = Packet::new(origin, skip, d);
            if !self.nodes.is_empty() {
                self.walk_packet::<T>(&mut p, &mut stack, &mut walker);
            }
            o.copy_from_slice(&p.best[..d.len()]);
        }
    }

    /// Nearest hits of rays leaving `origin` along `dirs` (unit), skipping
    /// `skip`, into `out[i]` for `dirs[i]`, walked in packets of
    /// [`PACKET`] consecutive rays with the node tests of `isa` (the
    /// portable build where the CPU lacks it): the hits of
    /// [`Bvh::intersect`], bit for bit.
    pub fn intersect_packets_with(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>], isa: Isa) {
        match isa {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 if isa.supported() => {
                // SAFETY: the CPU has AVX-512 F + VL (checked just above).
                unsafe { self.packets_avx512(origin, skip, dirs, out) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 if isa.supported() => {
                // SAFETY: the CPU has AVX2 (checked just above).
                unsafe { self.packets_avx2(origin, skip, dirs, out) }
            }
            _ => self.packets::<PortablePacket>(origin, skip, dirs, out),
        }
    }

    /// [`Bvh::intersect_packets_with`] with this tree's node tests.
    pub fn intersect_packets(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.intersect_packets_with(origin, skip, dirs, out, self.isa)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt")]
    fn packets_avx2(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.packets::<Avx2Packet>(origin, skip, dirs, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,bmi1,bmi2,popcnt,lzcnt,avx512f,avx512vl")]
    fn packets_avx512(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        self.packets::<Avx512Packet>(origin, skip, dirs, out)
    }
}
