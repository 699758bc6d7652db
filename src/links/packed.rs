//! The compact link encoding the gathers read (issue 16): every link is its
//! f16 weight ([`super::Links::weights`], 2 bytes) and its target, coded
//! as the gap to the previous target of its group in a byte stream (the
//! Stream VByte layout of Lemire, Kurz and Rupp, "Stream VByte: faster
//! byte-oriented integer compression", 2018, one stream per row).
//!
//! A group's targets are strictly increasing, so link `k`'s gap
//! `t_k - t_(k-1) - 1` (with `t_(-1) = -1`: the first gap is the target
//! itself) is a non-negative integer. Links come in blocks of four: a
//! group of `n` links has `ceil(n / 4)` blocks, the unused slots of the
//! last one code 0. A row is its blocks' control bytes, then their data:
//! a control byte has two bits per link (link `k` of the block in bits
//! `2k..2k+2`), code 0..3 for a gap of 0, 1, 2 or 4 little-endian data bytes
//! (gap 0, the next vertex, takes none). Keeping the control bytes apart
//! from the data is what makes decoding fast: the next control byte's
//! address never waits on the previous block's length (interleaved, the
//! load-to-load chain held a bounce at about 2.5 cycles a link).
//! Rows start at [`PackedTargets::starts`]; the stream ends in [`PAD`]
//! zero bytes, so a 16-byte load at any block's data stays inside it.
//! [`Cursor`] and [`simd::Cursor`] are the decoders.
//!
//! Measured on this project's scenes at 256 rays a vertex (scene vertex
//! order, `cargo test --release --test measured -- --ignored scene_order_keeps_link_targets_compact`):
//! 51-62% of gaps
//! are 0, 28-37% under 256, 1-5% under 65536, 0.1% larger; the targets take
//! 0.79 bytes a link on conference (0.64 on tearoom) with their control
//! bytes, 2.81 (2.66) with the weight and the row offsets and starts
//! ([`super::Links::gather_bytes`]; u32 targets took 6).
//!
//! Deviations from the issue, measured: weights stay IEEE half floats.
//! An 8-bit float per link (4-bit exponent below the group's largest
//! binade, 4-bit mantissa, error diffusion in target order) moved tearoom's
//! E_i by 1.5e-3 RMS and 13% at the worst vertex; 12 bits (8-bit mantissa)
//! by 8e-5 RMS and 1% at the worst vertex (`cargo test --release --test measured -- --ignored
//! eight_bit_link_weights_move_tearoom_e_i`).
//! Half floats keep every weight exactly as merged ([`super::merge`]),
//! convert in one instruction (F16C) and keep a link under 3 bytes with
//! the targets. Vertex order: a Morton order over
//! positions made the gaps larger (conference: 24% instead of 51% zero
//! gaps, 2.08 instead of 1.79 bytes a link with an 8-bit weight; a Hilbert
//! order 30% and 2.01) and the
//! gather 5-10% slower than the scenes' own order
//! (`cargo bench --bench solver -- gather_bounce`) (meshes come in strips
//! of neighbouring vertices), so vertices keep the scene's order unless a
//! mesh comes scrambled ([`crate::scene::order`]).

#[cfg(any(test, feature = "internals"))]
use rayon::prelude::*;

/// Zero bytes after the stream: a 16-byte load at any block's data stays inside.
pub const PAD: usize = 16;

/// Data bytes of a gap of each code.
pub const CODE_BYTES: [u32; 4] = [0, 1, 2, 4];

/// [`CODE_BYTES`] one per byte (code `k` in byte `k`): the WGSL gather's `GAP_BYTES`.
#[cfg(any(test, feature = "internals"))]
pub const GAP_BYTES_WORD: u32 = CODE_BYTES[0] | CODE_BYTES[1] << 8 | CODE_BYTES[2] << 16 | CODE_BYTES[3] << 24;

/// The code of a gap: the fewest bytes that hold it.
#[inline]
pub fn code_of(gap: u32) -> u32 {
    match gap {
        0 => 0,
        1..=0xff => 1,
        0x100..=0xffff => 2,
        _ => 3,
    }
}

/// Target streams of all groups, in row order. Built row by row
/// ([`PackedTargets::push_group`], [`PackedTargets::push_row_of`],
/// [`PackedTargets::append`]) and then [`PackedTargets::finish`]ed, or all
/// at once ([`PackedTargets::encode`]). Byte offsets are u32: a stream
/// holds at most 4 GiB (about 5 G links at 0.8 bytes a target; the CSR
/// link offsets stop at 4 G links first), beyond which building panics
/// with that message.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PackedTargets {
    /// Byte offset of each row's first block (one per row, plus the
    /// stream's end once finished).
    pub starts: Vec<u32>,
    /// Blocks of every row, then (once finished) [`PAD`] zero bytes.
    pub bytes: Vec<u8>,
}

/// A byte offset in the stream as stored (see [`PackedTargets`]).
fn offset(len: usize) -> u32 {
    u32::try_from(len).expect("packed link stream over 4 GiB: its row starts are u32")
}

/// Appends the row of one group's targets (strictly increasing) to `out`.
pub fn encode_group(targets: &[u32], out: &mut Vec<u8>) {
    let ctl_at = out.len();
    out.resize(ctl_at + targets.len().div_ceil(4), 0);
    let mut prev = u32::MAX;
    for (b, block) in targets.chunks(4).enumerate() {
        let mut ctl = 0u8;
        for (k, &t) in block.iter().enumerate() {
            let gap = t.wrapping_sub(prev).wrapping_sub(1);
            prev = t;
            let code = code_of(gap);
            ctl |= (code as u8) << (2 * k);
            out.extend_from_slice(&gap.to_le_bytes()[..CODE_BYTES[code as usize] as usize]);
        }
        out[ctl_at + b] = ctl;
    }
}

/// Masks of a gap's bytes in a little-endian u32, per code.
const GAP_MASKS: [u32; 4] = [0, 0xff, 0xffff, 0xffff_ffff];

/// A decoder's place in one row: the next control byte, the next data
/// byte (indices into [`PackedTargets::bytes`]) and the previous target.
#[derive(Clone, Copy, Debug)]
pub struct Cursor {
    /// Index of the next control byte in [`PackedTargets::bytes`].
    pub ctl: usize,
    /// Index of the next data byte in [`PackedTargets::bytes`].
    pub data: usize,
    /// The previous target decoded (the gaps are added to it).
    pub prev: u32,
}

impl Cursor {
    /// The next four targets (slots past a group's end follow the
    /// next-vertex rule and are to be ignored). Reads up to 16 bytes at
    /// the data position (inside the padding at the stream's end).
    #[inline(always)]
    pub fn block(&mut self, bytes: &[u8]) -> [u32; 4] {
        let ctl = bytes[self.ctl] as usize;
        self.ctl += 1;
        let data = &bytes[self.data..self.data + 16];
        let mut p = 0;
        let mut out = [0u32; 4];
        for (k, o) in out.iter_mut().enumerate() {
            let code = ctl >> (2 * k) & 3;
            let raw = u32::from_le_bytes([data[p], data[p + 1], data[p + 2], data[p + 3]]);
            p += CODE_BYTES[code] as usize;
            self.prev = self.prev.wrapping_add(1).wrapping_add(raw & GAP_MASKS[code]);
            *o = self.prev;
        }
        self.data += p;
        out
    }
}

/// Data bytes after each control byte.
pub const fn block_lengths() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut c = 0;
    while c < 256 {
        let mut k = 0;
        let mut len = 0;
        while k < 4 {
            len += CODE_BYTES[(c >> (2 * k)) & 3];
            k += 1;
        }
        t[c] = len as u8;
        c += 1;
    }
    t
}

/// Byte shuffles (`pshufb`) that move each control byte's gaps into four
/// little-endian u32 lanes (0x80: a zero byte).
pub const fn block_shuffles() -> [[u8; 16]; 256] {
    let mut t = [[0x80u8; 16]; 256];
    let mut c = 0;
    while c < 256 {
        let mut src = 0u8;
        let mut k = 0;
        while k < 4 {
            let len = CODE_BYTES[(c >> (2 * k)) & 3] as usize;
            let mut i = 0;
            while i < len {
                t[c][4 * k + i] = src;
                src += 1;
                i += 1;
            }
            k += 1;
        }
        c += 1;
    }
    t
}

/// Data bytes after each control byte ([`block_lengths`]), for the SIMD decoder.
pub static BLOCK_LENGTHS: [u8; 256] = block_lengths();
/// `pshufb` masks of each control byte ([`block_shuffles`]), for the SIMD decoder.
pub static BLOCK_SHUFFLES: [[u8; 16]; 256] = block_shuffles();

/// SSSE3 block decoding: [`Cursor::block`] in a few instructions (shuffle
/// the gaps into lanes, add one, prefix-sum, add the previous target).
#[cfg(target_arch = "x86_64")]
pub mod simd {
    use std::arch::x86_64::*;

    /// [`super::Cursor`] as pointers, the previous target in every lane.
    pub struct Cursor {
        ctl: *const u8,
        data: *const u8,
        prev: __m128i,
    }

    impl Cursor {
        /// At the start of row `v` (of `count` links) of `p`, or `None`
        /// when the row's blocks could read past the stream whatever its
        /// bytes say (a control byte a block, up to 16 data bytes a block
        /// and a 16-byte load at the last: true only near the stream's end,
        /// or for a stream that does not match the links), so that every
        /// [`Cursor::block`] of the row stays inside the stream.
        ///
        /// # Safety
        /// SSE2 must be available.
        #[inline(always)]
        pub unsafe fn new(p: &super::PackedTargets, v: usize, count: usize) -> Option<Cursor> {
            let blocks = count.div_ceil(4);
            let start = *p.starts.get(v)? as usize;
            if start + 17 * blocks + super::PAD > p.bytes.len() {
                return None;
            }
            let c = p.cursor(v, count);
            let base = p.bytes.as_ptr();
            Some(Cursor { ctl: base.add(c.ctl), data: base.add(c.data), prev: _mm_set1_epi32(-1) })
        }

        /// The next four targets, as [`super::Cursor::block`].
        ///
        /// # Safety
        /// SSSE3 must be available; at most `ceil(count / 4)` blocks of a
        /// cursor made by [`Cursor::new`].
        #[inline(always)]
        pub unsafe fn block(&mut self) -> __m128i {
            let ctl = *self.ctl as usize;
            self.ctl = self.ctl.add(1);
            let raw = _mm_loadu_si128(self.data as *const __m128i);
            let mask = _mm_loadu_si128(super::BLOCK_SHUFFLES[ctl].as_ptr() as *const __m128i);
            let gaps = _mm_add_epi32(_mm_shuffle_epi8(raw, mask), _mm_set1_epi32(1));
            let s = _mm_add_epi32(gaps, _mm_slli_si128::<4>(gaps));
            let s = _mm_add_epi32(s, _mm_slli_si128::<8>(s));
            let t = _mm_add_epi32(s, self.prev);
            self.prev = _mm_shuffle_epi32::<0xff>(t);
            self.data = self.data.add(super::BLOCK_LENGTHS[ctl] as usize);
            t
        }
    }
}

impl PackedTargets {
    /// Encodes the groups of a CSR matrix (`offsets`, `targets`), rows in
    /// parallel.
    #[cfg(any(test, feature = "internals"))]
    pub fn encode(offsets: &[u32], targets: &[u32]) -> PackedTargets {
        let n = offsets.len().saturating_sub(1);
        const ROWS: usize = 1024;
        let parts: Vec<PackedTargets> = (0..n.div_ceil(ROWS))
            .into_par_iter()
            .map(|c| {
                let mut part = PackedTargets::default();
                for v in c * ROWS..((c + 1) * ROWS).min(n) {
                    part.push_group(&targets[offsets[v] as usize..offsets[v + 1] as usize]);
                }
                part
            })
            .collect();
        let total: usize = parts.iter().map(|p| p.bytes.len()).sum();
        let mut out = PackedTargets { starts: Vec::with_capacity(n + 1), bytes: Vec::with_capacity(total + PAD) };
        for part in &parts {
            out.append(part);
        }
        out.finish();
        out
    }

    /// Appends a row holding `targets` (strictly increasing) to an unfinished stream.
    pub fn push_group(&mut self, targets: &[u32]) {
        self.starts.push(offset(self.bytes.len()));
        encode_group(targets, &mut self.bytes);
    }

    /// Appends a copy of row `v` of `other` (finished, or with `v` not its last row).
    pub fn push_row_of(&mut self, other: &PackedTargets, v: usize) {
        self.push_rows_of(other, v..v + 1);
    }

    /// Appends a copy of rows `rows` of `other` (finished, or with
    /// `rows` short of its last row), in one copy.
    pub fn push_rows_of(&mut self, other: &PackedTargets, rows: std::ops::Range<usize>) {
        let (a, b) = (other.starts[rows.start] as usize, other.starts[rows.end] as usize);
        let base = offset(self.bytes.len() + (b - a)) - (b - a) as u32;
        self.starts.extend(other.starts[rows].iter().map(|s| s - a as u32 + base));
        self.bytes.extend_from_slice(&other.bytes[a..b]);
    }

    /// Appends the rows of `other`, an unfinished stream.
    pub fn append(&mut self, other: &PackedTargets) {
        let base = offset(self.bytes.len() + other.bytes.len()) - other.bytes.len() as u32;
        self.starts.extend(other.starts.iter().map(|s| s + base));
        self.bytes.extend_from_slice(&other.bytes);
    }

    /// Closes the stream: the end offset and the padding.
    pub fn finish(&mut self) {
        self.starts.push(offset(self.bytes.len()));
        self.bytes.resize(self.bytes.len() + PAD, 0);
    }

    /// Rows of a finished stream.
    pub fn rows(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// A decoder at the start of row `v`, which holds `count` links.
    #[inline(always)]
    pub fn cursor(&self, v: usize, count: usize) -> Cursor {
        let start = self.starts[v] as usize;
        Cursor { ctl: start, data: start + count.div_ceil(4), prev: u32::MAX }
    }

    /// Row `v`'s `count` targets, appended to `out`.
    pub fn decode_group(&self, v: usize, count: usize, out: &mut Vec<u32>) {
        let mut c = self.cursor(v, count);
        for k in (0..count).step_by(4) {
            let t = c.block(&self.bytes);
            out.extend_from_slice(&t[..(count - k).min(4)]);
        }
    }

    /// Bytes of the stream, padding included, and of the row starts.
    pub fn bytes(&self) -> u64 {
        (self.bytes.len() + 4 * self.starts.len()) as u64
    }

    /// The stream as little-endian u32 words (what the WGSL gather reads),
    /// bytes `first..end` of it, zero-padded to whole words plus [`PAD`].
    pub fn words(&self, first: usize, end: usize) -> Vec<u32> {
        let mut b = self.bytes[first..end].to_vec();
        b.resize((b.len() + PAD).next_multiple_of(4), 0);
        b.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect()
    }

    /// Checks the stream against the CSR `offsets` of `n` target
    /// vertices: every row decodes to exactly its link count of targets,
    /// strictly increasing and below `n`, ending where the next row starts;
    /// the stream is padded.
    pub fn validate(&self, offsets: &[u32], n: usize) -> Result<(), String> {
        let rows = offsets.len().saturating_sub(1);
        if self.rows() != rows {
            return Err(format!("packed targets hold {} rows, the links {rows}", self.rows()));
        }
        if self.bytes.len() != *self.starts.last().unwrap_or(&0) as usize + PAD
            || self.bytes[self.bytes.len() - PAD..].iter().any(|&b| b != 0)
        {
            return Err("packed target stream is not padded".into());
        }
        for v in 0..rows {
            let count = offsets[v + 1].saturating_sub(offsets[v]) as usize;
            let end = self.starts[v + 1] as usize;
            let mut c = self.cursor(v, count);
            let mut last: Option<u32> = None;
            for k in (0..count).step_by(4) {
                if c.data > end {
                    return Err(format!("vertex {v}: packed targets run past the row"));
                }
                let t = c.block(&self.bytes);
                for &t in &t[..(count - k).min(4)] {
                    if t as usize >= n {
                        return Err(format!("vertex {v} links to {t}, but there are {n} vertices"));
                    }
                    if last.is_some_and(|l| l >= t) {
                        return Err(format!("vertex {v}: targets not strictly increasing (unmerged)"));
                    }
                    last = Some(t);
                }
            }
            if c.data != end {
                return Err(format!(
                    "vertex {v}: packed row has {} bytes, its {count} links use {}",
                    end - self.starts[v] as usize,
                    c.data as isize - self.starts[v] as isize
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Groups of every length mod 4, with gaps of every code (including
    /// targets near u32::MAX and a first target of 0).
    fn groups(seed: u64) -> (Vec<u32>, Vec<u32>) {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
        let (mut offsets, mut targets) = (vec![0u32], Vec::new());
        for g in 0..400 {
            let len = g % 13;
            let mut t: u64 = if g % 5 == 0 { 0 } else { rng.random_range(0..1000) };
            for _ in 0..len {
                if t > u32::MAX as u64 {
                    break;
                }
                targets.push(t as u32);
                let code = rng.random_range(0..4);
                t += 1 + match code {
                    0 => 0,
                    1 => rng.random_range(1..256),
                    2 => rng.random_range(256..65536),
                    _ => rng.random_range(65536..1u64 << 31),
                };
            }
            offsets.push(targets.len() as u32);
        }
        (offsets, targets)
    }

    #[test]
    fn round_trip_gives_the_targets() {
        let (offsets, targets) = groups(3);
        let p = PackedTargets::encode(&offsets, &targets);
        p.validate(&offsets, u32::MAX as usize + 1).unwrap();
        let mut out = Vec::new();
        for v in 0..offsets.len() - 1 {
            p.decode_group(v, (offsets[v + 1] - offsets[v]) as usize, &mut out);
        }
        assert_eq!(out, targets);
        // Every code met, so the test covers every path.
        let mut seen = [false; 4];
        for w in targets.windows(2).filter(|w| w[1] > w[0]) {
            seen[code_of(w[1] - w[0] - 1) as usize] = true;
        }
        assert_eq!(seen, [true; 4]);
        // A group ending at u32::MAX.
        let top = [u32::MAX - 300, u32::MAX - 1, u32::MAX];
        let q = PackedTargets::encode(&[0, 3], &top);
        q.validate(&[0, 3], u32::MAX as usize + 1).unwrap();
        let mut out = Vec::new();
        q.decode_group(0, 3, &mut out);
        assert_eq!(out, top);
        // Built row by row: the same stream.
        let mut r = PackedTargets::default();
        let mut tail = PackedTargets::default();
        for v in 0..offsets.len() - 1 {
            let g = &targets[offsets[v] as usize..offsets[v + 1] as usize];
            if v < 100 {
                r.push_group(g)
            } else {
                tail.push_group(g)
            }
        }
        r.append(&tail);
        r.finish();
        assert_eq!(r, p);
        let mut copy = PackedTargets::default();
        for v in 0..offsets.len() - 1 {
            copy.push_row_of(&p, v);
        }
        copy.finish();
        assert_eq!(copy, p);
    }

    #[test]
    fn validate_catches_a_changed_byte() {
        let (offsets, targets) = groups(5);
        let p = PackedTargets::encode(&offsets, &targets);
        let n = u32::MAX as usize + 1;
        // Any changed control byte changes a row's length.
        for v in [3, 50, 399] {
            if offsets[v + 1] > offsets[v] {
                let mut q = p.clone();
                q.bytes[q.starts[v] as usize] ^= 0x40;
                assert!(q.validate(&offsets, n).is_err(), "row {v}");
            }
        }
        // Targets beyond the vertex count.
        let top = *targets.iter().max().unwrap() as usize;
        assert!(p.validate(&offsets, top).is_err());
        p.validate(&offsets, top + 1).unwrap();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_blocks_equal_scalar_blocks() {
        if !std::arch::is_x86_feature_detected!("ssse3") {
            return;
        }
        let (offsets, targets) = groups(11);
        let p = PackedTargets::encode(&offsets, &targets);
        let rows = offsets.len() - 1;
        let mut refused = 0;
        for v in 0..rows {
            let count = (offsets[v + 1] - offsets[v]) as usize;
            let mut c = p.cursor(v, count);
            // SAFETY: SSSE3 is available; blocks of a cursor from `new`.
            unsafe {
                use std::arch::x86_64::*;
                let Some(mut s) = simd::Cursor::new(&p, v, count) else {
                    refused += 1;
                    continue;
                };
                for _ in (0..count).step_by(4) {
                    let want = c.block(&p.bytes);
                    let mut lanes = [0u32; 4];
                    _mm_storeu_si128(lanes.as_mut_ptr() as *mut __m128i, s.block());
                    assert_eq!(lanes, want, "vertex {v}");
                }
            }
        }
        // Only rows near the stream's end are left to the scalar decoder.
        assert!(refused > 0 && refused * 20 < rows, "{refused} of {rows} rows refused");
        // A row start beyond the stream is refused, not read.
        let mut bad = p.clone();
        bad.starts[0] = bad.bytes.len() as u32;
        // SAFETY: SSE2 is available.
        assert!(unsafe { simd::Cursor::new(&bad, 0, 8) }.is_none());
    }
}
