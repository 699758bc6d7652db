//! Leaf blocks of the BVH: eight triangles as structure of arrays, tested
//! in one pass of 8-lane operations (AVX2 / AVX-512 builds) with exactly
//! the operations, in the same order, of the scalar watertight test
//! ([`crate::trace::ray::intersect`], Woop, Benthin & Wald 2013), so
//! every lane's `t`, `u`, `v` and facing are bit for bit the scalar ones
//! (Rust never fuses a multiply and an add; division is correctly rounded
//! in both). Lanes whose edge functions hit exactly zero are redone in f64,
//! as the scalar test does. The portable build runs the scalar test per
//! lane.
//!
//! Unused lanes have NaN corners (no comparison with NaN holds, so they
//! never hit) and vertex and triangle ids `u32::MAX`. Lengths in metres.

use crate::trace::ray::{RayShear, intersect};
use crate::trace::ray::KdTriangle;
use glam::Vec3;

/// Triangles per block.
pub const LANES: usize = 8;
/// Id of an unused lane.
pub const UNUSED: u32 = u32::MAX;

/// Eight triangles: corners `v[corner][axis][lane]`, corner vertex ids
/// `corners[corner][lane]` and triangle ids (416 bytes).
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Block8 {
    /// Corners `v[corner][axis][lane]`, metres (NaN in unused lanes).
    pub v: [[[f32; LANES]; 3]; 3],
    /// Solver vertex ids of the corners, `corners[corner][lane]` ([`UNUSED`] in unused lanes).
    pub corners: [[u32; LANES]; 3],
    /// Triangle id per lane ([`UNUSED`] in unused lanes).
    pub tri: [u32; LANES],
}

impl Block8 {
    /// A block with every lane unused.
    pub const EMPTY: Block8 =
        Block8 { v: [[[f32::NAN; LANES]; 3]; 3], corners: [[UNUSED; LANES]; 3], tri: [UNUSED; LANES] };

    /// Corner `c` of lane `lane`.
    #[inline]
    pub fn corner(&self, c: usize, lane: usize) -> Vec3 {
        Vec3::new(self.v[c][0][lane], self.v[c][1][lane], self.v[c][2][lane])
    }

    /// Puts triangle `id` with corner vertices `ids` at `positions` in `lane`.
    pub fn set(&mut self, lane: usize, id: u32, ids: [u32; 3], positions: &[Vec3]) {
        for (c, &vi) in ids.iter().enumerate() {
            let p = positions[vi as usize];
            for k in 0..3 {
                self.v[c][k][lane] = p[k];
            }
            self.corners[c][lane] = vi;
        }
        self.tri[lane] = id;
    }

    /// Mask of lanes whose triangle has `skip` as a corner.
    #[inline(always)]
    fn skipped(&self, skip: u32) -> u32 {
        let mut m = 0;
        for l in 0..LANES {
            m |= ((self.corners[0][l] == skip || self.corners[1][l] == skip || self.corners[2][l] == skip) as u32) << l;
        }
        m
    }
}

/// Lane results of a block test: `mask` bit `i` set where lane `i` hits
/// (and does not touch the skipped vertex).
#[derive(Clone, Copy, Debug)]
pub struct Hits8 {
    /// Bit `i` set where lane `i` hits.
    pub mask: u32,
    /// Hit distance per lane, metres (valid where the lane hits).
    pub t: [f32; LANES],
    /// Barycentric weight of corner 1 per lane.
    pub u: [f32; LANES],
    /// Barycentric weight of corner 2 per lane.
    pub v: [f32; LANES],
    /// Bit `i` set where lane `i` meets the front face.
    pub front: u32,
}

/// The scalar test on every lane (the portable build, and the f64
/// fallback of the SIMD builds for single lanes).
#[inline(always)]
pub(super) fn lane(b: &Block8, l: usize, o: Vec3, s: &RayShear, tmin: f32, tmax: f32) -> Option<(f32, f32, f32, bool)> {
    let tri = KdTriangle {
        v0: b.corner(0, l).into(),
        v1: b.corner(1, l).into(),
        v2: b.corner(2, l).into(),
        ..Default::default()
    };
    intersect(&tri, o, s, tmin, tmax)
}

/// Tests all lanes with the scalar test (portable build).
#[inline(always)]
pub fn intersect8_portable(b: &Block8, o: Vec3, s: &RayShear, skip: u32, tmin: f32, tmax: f32) -> Hits8 {
    let mut h = Hits8 { mask: 0, t: [0.0; LANES], u: [0.0; LANES], v: [0.0; LANES], front: 0 };
    let skipped = b.skipped(skip);
    for l in 0..LANES {
        if b.tri[l] == UNUSED || skipped >> l & 1 == 1 {
            continue;
        }
        if let Some((t, u, v, front)) = lane(b, l, o, s, tmin, tmax) {
            h.mask |= 1 << l;
            h.t[l] = t;
            h.u[l] = u;
            h.v[l] = v;
            h.front |= (front as u32) << l;
        }
    }
    h
}

/// Tests all lanes with 8-lane AVX operations.
///
/// # Safety
/// The CPU must have AVX2 and the caller be built with it enabled (inlined
/// into a `#[target_feature(enable = "avx2")]` walk). The loads are from the
/// 32-byte aligned rows of `Block8` and the stores into local arrays, so
/// nothing else is asked of the arguments.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub unsafe fn intersect8_avx(b: &Block8, o: Vec3, s: &RayShear, skip: u32, tmin: f32, tmax: f32) -> Hits8 {
    use std::arch::x86_64::*;
    // SAFETY: the contract above; aligned loads of `Block8` rows.
    unsafe {
        let (kx, ky, kz) = s.axes();
        let o = o.to_array();
        let p = |c: usize, k: usize| _mm256_sub_ps(_mm256_load_ps(b.v[c][k].as_ptr()), _mm256_set1_ps(o[k]));
        let (akx, aky, akz) = (p(0, kx), p(0, ky), p(0, kz));
        let (bkx, bky, bkz) = (p(1, kx), p(1, ky), p(1, kz));
        let (ckx, cky, ckz) = (p(2, kx), p(2, ky), p(2, kz));
        let (sx, sy) = (_mm256_set1_ps(s.sx()), _mm256_set1_ps(s.sy()));
        let (ax, ay) = (_mm256_sub_ps(akx, _mm256_mul_ps(sx, akz)), _mm256_sub_ps(aky, _mm256_mul_ps(sy, akz)));
        let (bx, by) = (_mm256_sub_ps(bkx, _mm256_mul_ps(sx, bkz)), _mm256_sub_ps(bky, _mm256_mul_ps(sy, bkz)));
        let (cx, cy) = (_mm256_sub_ps(ckx, _mm256_mul_ps(sx, ckz)), _mm256_sub_ps(cky, _mm256_mul_ps(sy, ckz)));
        let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let z = _mm256_setzero_ps();
        let mm = |x: __m256| _mm256_movemask_ps(x) as u32;
        let neg = mm(_mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(u, z), _mm256_cmp_ps::<_CMP_LT_OQ>(v, z)),
            _mm256_cmp_ps::<_CMP_LT_OQ>(w, z),
        ));
        let pos = mm(_mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(u, z), _mm256_cmp_ps::<_CMP_GT_OQ>(v, z)),
            _mm256_cmp_ps::<_CMP_GT_OQ>(w, z),
        ));
        let zero = mm(_mm256_or_ps(
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(u, z), _mm256_cmp_ps::<_CMP_EQ_OQ>(v, z)),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(w, z),
        ));
        let skipped = {
            let sk = _mm256_set1_epi32(skip as i32);
            let load = |c: usize| _mm256_load_si256(b.corners[c].as_ptr() as *const __m256i);
            let eq = _mm256_or_si256(
                _mm256_or_si256(_mm256_cmpeq_epi32(load(0), sk), _mm256_cmpeq_epi32(load(1), sk)),
                _mm256_cmpeq_epi32(load(2), sk),
            );
            mm(_mm256_castsi256_ps(eq))
        };
        let mut h = Hits8 { mask: 0, t: [0.0; LANES], u: [0.0; LANES], v: [0.0; LANES], front: 0 };
        // Most blocks a ray tests hold no triangle it crosses: those leave
        // before the division (the lanes' results would all be rejected).
        // With no edge function zero, a crossed triangle's are all of one
        // sign: `neg ^ pos` (NaN lanes, unused, set neither).
        let inside = (neg ^ pos) & !skipped & !zero & 0xff;
        let redo = zero & !skipped & 0xff;
        if inside == 0 && redo == 0 {
            return h;
        }
        let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
        let t_scaled = _mm256_mul_ps(
            _mm256_set1_ps(s.sz()),
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, akz), _mm256_mul_ps(v, bkz)), _mm256_mul_ps(w, ckz)),
        );
        let inv = _mm256_div_ps(_mm256_set1_ps(1.0), det);
        let t = _mm256_mul_ps(t_scaled, inv);
        let in_range = mm(_mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GE_OQ>(t, _mm256_set1_ps(tmin)),
            _mm256_cmp_ps::<_CMP_LE_OQ>(t, _mm256_set1_ps(tmax)),
        ));
        let det_zero = mm(_mm256_cmp_ps::<_CMP_EQ_OQ>(det, z));
        let mut mask = inside & !det_zero & in_range;
        if mask == 0 && redo == 0 {
            return h;
        }
        _mm256_storeu_ps(h.t.as_mut_ptr(), t);
        _mm256_storeu_ps(h.u.as_mut_ptr(), _mm256_mul_ps(v, inv));
        _mm256_storeu_ps(h.v.as_mut_ptr(), _mm256_mul_ps(w, inv));
        h.front = mm(_mm256_cmp_ps::<_CMP_GT_OQ>(det, z));
        // Lanes with an edge function exactly zero: the scalar test, which
        // redoes them in f64.
        let mut redo = redo;
        while redo != 0 {
            let l = redo.trailing_zeros() as usize;
            redo &= redo - 1;
            if b.tri[l] == UNUSED {
                continue;
            }
            if let Some((tt, uu, vv, front)) = lane(b, l, Vec3::from_array(o), s, tmin, tmax) {
                mask |= 1 << l;
                h.t[l] = tt;
                h.u[l] = uu;
                h.v[l] = vv;
                h.front = h.front & !(1 << l) | (front as u32) << l;
            }
        }
        h.mask = mask;
        h
    }
}
