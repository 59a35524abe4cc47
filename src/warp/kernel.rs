//! Applying a remap table to one output row: every output pixel is a weighted sum of 2×2
//! source blocks ([`Quad`]s) with integer weights, so the result is exact integer arithmetic:
//! the scalar and SIMD paths give the same bytes on every machine. The table stores a row's
//! blocks in groups of [`LANES`] pixels ([`Round`]s), the layout the SIMD kernels load.

/// Fixed-point bits of a weight: a pixel's weights sum to `1 << WEIGHT_BITS` when all of its
/// samples lie inside the source. 14 bits keep every weight a positive i16 (for
/// `_mm_madd_epi16`) and every sum (at most 255 · 2^14) well inside an i32.
pub(super) const WEIGHT_BITS: u32 = 14;
pub(super) const WEIGHT_ONE: i32 = 1 << WEIGHT_BITS;
const HALF: i32 = 1 << (WEIGHT_BITS - 1);

/// A 2×2 block of source pixels and its weights: what the build makes of a pixel's taps.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C)]
pub(super) struct Quad {
    /// Index of the top-left source pixel; the block spans +1 column and +1 row.
    pub offset: u32,
    /// Weights of top-left, bottom-left, top-right, bottom-right in 1/WEIGHT_ONE (this order
    /// is what the SSE2 kernel multiplies after interleaving the top and bottom rows).
    pub w: [i16; 4],
}

/// Pixels of a group: a table row is applied [`LANES`] consecutive pixels at a time.
pub(super) const LANES: usize = 8;

/// One block of each pixel of a group, offsets apart from weights (12 bytes a block, as a
/// [`Quad`]), so that one load brings the weights of four pixels. A group has as many rounds
/// as its pixel with the most blocks; a pixel with fewer has zero-weight blocks at its first
/// block's offset in the rounds it lacks, and so have the lanes past the end of a row: they
/// add nothing, so every pixel's sum is its own blocks' exactly. Pixels' block counts change
/// only at the supersampled sides of a frame, so groups of mixed counts (and their padding
/// blocks) are few.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C)]
pub(super) struct Round {
    /// Each lane's block's top-left source pixel, as a byte index (pixel index × 3: a source
    /// has at most `codec::MAX_PIXELS` pixels, far below 2^32 / 3).
    pub offset: [u32; LANES],
    /// Each lane's block's weights, as [`Quad::w`].
    pub w: [[i16; 4]; LANES],
}

/// Bytes a SIMD kernel reads from a block's top-left and bottom-left pixel (6 used): one
/// 16-byte load a row, which x86 folds into the instruction that pairs two blocks.
pub(super) const SIMD_READ: usize = 16;

/// Which kernel applies a table.
#[doc(hidden)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// The fastest the CPU has (what `apply` uses).
    Auto,
    /// Portable scalar code (the only one off x86_64).
    Scalar,
    /// SSE2 without AVX2 (x86_64 only; elsewhere the scalar one).
    Sse2,
    /// AVX2 without AVX-512 (where the CPU has AVX2; elsewhere SSE2 or the scalar one).
    Avx2,
}

/// Resamples one output row. `rounds` are the row's groups' rounds, `depth` how many rounds
/// each group has (one entry per group of [`LANES`] pixels of `out`); `reach` is the largest
/// block offset of the row, which bounds every read once for the whole row.
pub(super) fn apply_row(
    rounds: &[Round],
    depth: &[u8],
    data: &[u8],
    stride: usize,
    reach: u32,
    out: &mut [u8],
    kernel: Kernel,
) {
    assert_eq!(
        depth.len(),
        (out.len() / 3).div_ceil(LANES),
        "groups of the row"
    );
    let stride3 = stride * 3;
    let end = reach as usize * 3 + stride3;
    #[cfg(not(target_arch = "x86_64"))]
    let _ = kernel;
    #[cfg(target_arch = "x86_64")]
    if kernel != Kernel::Scalar && end + SIMD_READ <= data.len() {
        // SAFETY: every block of the row has its top-left pixel at or before reach, so each
        // 16-byte load at it and a row below ends at or before end + 16 <= data.len(); AVX2
        // and AVX-512 are used only where the CPU has them.
        unsafe {
            if kernel == Kernel::Auto && avx512::available() {
                avx512::apply_row(rounds, depth, data, stride3, out);
            } else if kernel != Kernel::Sse2 && std::arch::is_x86_feature_detected!("avx2") {
                avx2::apply_row(rounds, depth, data, stride3, out);
            } else {
                sse2::apply_row(rounds, depth, data, stride3, out);
            }
        }
        return;
    }
    if end + 6 <= data.len() {
        apply_row_scalar(rounds, depth, out, |o, w| sum_plain(data, stride3, o, w));
    } else {
        // Only for sources one row high (the block's lower row does not exist) or the
        // last pixels of the source: read the pixels with a weight, checked.
        apply_row_scalar(rounds, depth, out, |o, w| sum_checked(data, stride3, o, w));
    }
}

/// Rounds a pixel's sum to its 8-bit value.
fn finish(acc: [i32; 3]) -> [u8; 3] {
    acc.map(|v| ((v + HALF) >> WEIGHT_BITS) as u8)
}

/// Each group's pixels, each the sum of its lane of the group's rounds.
fn apply_row_scalar(
    rounds: &[Round],
    depth: &[u8],
    out: &mut [u8],
    sum: impl Fn(u32, &[i16; 4]) -> [i32; 3],
) {
    let mut r = 0;
    for (pixels, &k) in out.chunks_mut(3 * LANES).zip(depth) {
        let group = &rounds[r..r + k as usize];
        r += k as usize;
        for (lane, px) in pixels.chunks_exact_mut(3).enumerate() {
            let mut acc = [0i32; 3];
            for round in group {
                let s = sum(round.offset[lane], &round.w[lane]);
                for c in 0..3 {
                    acc[c] += s[c];
                }
            }
            px.copy_from_slice(&finish(acc));
        }
    }
}

/// Weighted sum of a block whose four pixels are known to be inside `data`.
#[inline(always)]
fn sum_plain(data: &[u8], stride3: usize, offset: u32, w: &[i16; 4]) -> [i32; 3] {
    let base = offset as usize;
    let top: &[u8; 6] = data[base..base + 6].try_into().expect("6 bytes");
    let bottom: &[u8; 6] = data[base + stride3..base + stride3 + 6]
        .try_into()
        .expect("6 bytes");
    let [tl, bl, tr, br] = w.map(i32::from);
    std::array::from_fn(|c| {
        top[c] as i32 * tl
            + bottom[c] as i32 * bl
            + top[c + 3] as i32 * tr
            + bottom[c + 3] as i32 * br
    })
}

/// As [`sum_plain`], reading only the pixels with a nonzero weight (which exist).
fn sum_checked(data: &[u8], stride3: usize, offset: u32, w: &[i16; 4]) -> [i32; 3] {
    let base = offset as usize;
    let mut acc = [0i32; 3];
    for (w, at) in w.iter().zip([0, stride3, 3, stride3 + 3]) {
        if *w != 0 {
            for (c, a) in acc.iter_mut().enumerate() {
                *a += data[base + at + c] as i32 * *w as i32;
            }
        }
    }
    acc
}

/// How far ahead of the round being applied the SIMD kernels prefetch the table: it streams
/// from memory (megabytes a frame), and between two rows the decoder and the encoder run, so
/// the hardware's own prefetch loses the stream at each row's start (`panoconv kitti`: the
/// remap 0.78 ms a frame without, 0.58 with; 2 KB and 12 KB did worse than 6).
#[cfg(target_arch = "x86_64")]
const PREFETCH: usize = 6 * 1024;

/// Prefetches the two cache lines `PREFETCH` bytes past `round` (a round is 96 bytes; past
/// the table's end the address is a harmless hint).
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "sse")]
fn prefetch_ahead(round: &Round) {
    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
    let ahead = (round as *const Round as *const i8).wrapping_add(PREFETCH);
    _mm_prefetch::<_MM_HINT_T0>(ahead);
    _mm_prefetch::<_MM_HINT_T0>(ahead.wrapping_add(64));
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    //! SSE2 (baseline on x86_64, so no runtime detection): one block is two 8-byte loads,
    //! the rows interleaved so that `_mm_madd_epi16` forms top·w + bottom·w per channel.
    use super::{Round, HALF, LANES, WEIGHT_BITS};
    use std::arch::x86_64::*;

    /// The block's (r, g, b, junk) weighted sums.
    ///
    /// # Safety
    ///
    /// `data + offset` and `data + offset + stride3` must have 8 readable bytes.
    #[inline]
    #[target_feature(enable = "sse2")]
    pub(super) unsafe fn quad_sum(
        data: *const u8,
        stride3: usize,
        offset: u32,
        w: &[i16; 4],
    ) -> __m128i {
        let base = offset as usize;
        // SAFETY: the caller's contract; the weights are 8 bytes.
        let (top, bottom, w) = unsafe {
            (
                _mm_loadl_epi64(data.add(base) as *const __m128i),
                _mm_loadl_epi64(data.add(base + stride3) as *const __m128i),
                _mm_loadl_epi64(w.as_ptr() as *const __m128i),
            )
        };
        let zero = _mm_setzero_si128();
        // t0 b0 t1 b1 ... for the bytes r g b r' g' b' of the two columns
        let tb = _mm_unpacklo_epi8(top, bottom);
        let lo = _mm_unpacklo_epi8(tb, zero); // r g b of the left column, r' of the right
        let hi = _mm_unpackhi_epi8(tb, zero); // g' b' of the right column, then junk
                                              // w as i32 lanes: (tl, bl), (tr, br); lo needs left, left, left, right; hi right.
        let a = _mm_madd_epi16(lo, _mm_shuffle_epi32::<0b01_00_00_00>(w));
        let b = _mm_madd_epi16(hi, _mm_shuffle_epi32::<0b01_01_01_01>(w));
        // lanes: [r + r', g + g', b + b', junk]
        _mm_add_epi32(
            _mm_add_epi32(a, _mm_bslli_si128::<4>(b)),
            _mm_bsrli_si128::<12>(a),
        )
    }

    #[inline]
    #[target_feature(enable = "sse2")]
    pub(super) fn finish(acc: __m128i) -> [u8; 3] {
        let r = _mm_srai_epi32::<{ WEIGHT_BITS as i32 }>(_mm_add_epi32(acc, _mm_set1_epi32(HALF)));
        let p = _mm_packus_epi16(_mm_packs_epi32(r, r), r);
        let v = (_mm_cvtsi128_si32(p) as u32).to_le_bytes();
        [v[0], v[1], v[2]]
    }

    /// # Safety
    ///
    /// Every block's reads (see [`quad_sum`]) must lie inside `data`.
    #[target_feature(enable = "sse2")]
    pub(super) unsafe fn apply_row(
        rounds: &[Round],
        depth: &[u8],
        data: &[u8],
        stride3: usize,
        out: &mut [u8],
    ) {
        let p = data.as_ptr();
        let mut r = 0;
        for (pixels, &k) in out.chunks_mut(3 * LANES).zip(depth) {
            let group = &rounds[r..r + k as usize];
            r += k as usize;
            for (lane, px) in pixels.chunks_exact_mut(3).enumerate() {
                let mut acc = _mm_setzero_si128();
                for round in group {
                    // SAFETY: the caller's contract.
                    let s = unsafe { quad_sum(p, stride3, round.offset[lane], &round.w[lane]) };
                    acc = _mm_add_epi32(acc, s);
                }
                px.copy_from_slice(&finish(acc));
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! AVX2 (where the CPU has it): the arithmetic of the SSE2 kernel on two pixels at once,
    //! one per 128-bit lane, so each shuffle and multiply serves two pixels. Same integer
    //! results.
    use super::{Round, HALF, LANES, WEIGHT_BITS};
    use std::arch::x86_64::*;

    /// The (r, g, b, junk) sums of the blocks at `oa` (low lane) and `ob` (high lane), whose
    /// weights are those of the low (`HIGH` false) or high quad of each lane of `w`.
    ///
    /// Byte shuffles put each row's left and right pixel side by side as 16-bit values
    /// (r r' g g' b b' 0 0) and the weights beside them (tl tr ... and bl br ...), so two
    /// `madd`s and one add give the sums.
    ///
    /// # Safety
    ///
    /// `data + o` and `data + o + stride3` must have 16 readable bytes, for both
    /// blocks.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn pair_sum<const HIGH: bool>(
        data: *const u8,
        stride3: usize,
        oa: u32,
        ob: u32,
        w: __m256i,
    ) -> __m256i {
        let (oa, ob) = (oa as usize, ob as usize);
        // SAFETY: the caller's contract.
        let load = |at: usize| unsafe { _mm_loadu_si128(data.add(at) as *const __m128i) };
        let top = _mm256_set_m128i(load(ob), load(oa));
        let bottom = _mm256_set_m128i(load(ob + stride3), load(oa + stride3));
        // -1 (0x80 set) writes a zero byte
        #[rustfmt::skip]
        let pixels = _mm256_setr_epi8(
            0, -1, 3, -1, 1, -1, 4, -1, 2, -1, 5, -1, 15, -1, -1, -1,
            0, -1, 3, -1, 1, -1, 4, -1, 2, -1, 5, -1, 15, -1, -1, -1,
        );
        // A quad's w is tl bl tr br (16-bit): top weights tl tr, bottom weights bl br,
        // three times, from the lane's low quad (bytes 0-7) or high quad (8-15).
        let h = if HIGH { 8 } else { 0 };
        #[rustfmt::skip]
        let top_w = _mm256_setr_epi8(
            h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, -1, -1, -1, -1,
            h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, -1, -1, -1, -1,
        );
        #[rustfmt::skip]
        let bottom_w = _mm256_setr_epi8(
            h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7,
            -1, -1, -1, -1,
            h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7,
            -1, -1, -1, -1,
        );
        _mm256_add_epi32(
            _mm256_madd_epi16(
                _mm256_shuffle_epi8(top, pixels),
                _mm256_shuffle_epi8(w, top_w),
            ),
            _mm256_madd_epi16(
                _mm256_shuffle_epi8(bottom, pixels),
                _mm256_shuffle_epi8(w, bottom_w),
            ),
        )
    }

    /// A round's sums: pixels (0, 2), (1, 3), (4, 6), (5, 7) of the group, low lane first.
    ///
    /// # Safety
    ///
    /// As [`pair_sum`], for every block of the round.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn round_sums(data: *const u8, stride3: usize, round: &Round) -> [__m256i; 4] {
        let o = &round.offset;
        // SAFETY: 32 bytes each: the weights of lanes 0-3 and 4-7.
        let (w0, w1) = unsafe {
            (
                _mm256_loadu_si256(round.w[..4].as_ptr() as *const __m256i),
                _mm256_loadu_si256(round.w[4..].as_ptr() as *const __m256i),
            )
        };
        // SAFETY: the caller's contract.
        unsafe {
            [
                pair_sum::<false>(data, stride3, o[0], o[2], w0),
                pair_sum::<true>(data, stride3, o[1], o[3], w0),
                pair_sum::<false>(data, stride3, o[4], o[6], w1),
                pair_sum::<true>(data, stride3, o[5], o[7], w1),
            ]
        }
    }

    /// A group's eight pixels, rounded, as 24 bytes: pixels 0-3 in the low 12 bytes of the
    /// low lane, 4-7 in the high lane's, each lane's last 4 bytes junk.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn finish_eight(acc: [__m256i; 4]) -> __m256i {
        let half = _mm256_set1_epi32(HALF);
        let [a, b, c, d] =
            acc.map(|x| _mm256_srai_epi32::<{ WEIGHT_BITS as i32 }>(_mm256_add_epi32(x, half)));
        // words, per lane: (0, 1 | 2, 3) and (4, 5 | 6, 7); then bytes (0 1 4 5 | 2 3 6 7)
        let bytes = _mm256_packus_epi16(_mm256_packs_epi32(a, b), _mm256_packs_epi32(c, d));
        let ordered = _mm256_permutevar8x32_epi32(bytes, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7));
        #[rustfmt::skip]
        let squeeze = _mm256_setr_epi8(
            0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1,
            0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1,
        );
        _mm256_shuffle_epi8(ordered, squeeze)
    }

    /// # Safety
    ///
    /// Every block's reads (see [`pair_sum`]) must lie inside `data`, and the CPU
    /// must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn apply_row(
        rounds: &[Round],
        depth: &[u8],
        data: &[u8],
        stride3: usize,
        out: &mut [u8],
    ) {
        let p = data.as_ptr();
        let mut r = 0;
        for (g, &k) in depth.iter().enumerate() {
            let group = &rounds[r..r + k as usize];
            for round in group {
                super::prefetch_ahead(round);
            }
            r += k as usize;
            // SAFETY: the caller's contract.
            let mut acc = unsafe { round_sums(p, stride3, &group[0]) };
            for round in &group[1..] {
                // SAFETY: the caller's contract.
                let s = unsafe { round_sums(p, stride3, round) };
                for (a, s) in acc.iter_mut().zip(s) {
                    *a = _mm256_add_epi32(*a, s);
                }
            }
            let px = finish_eight(acc);
            let at = 3 * LANES * g;
            if at + 28 <= out.len() {
                // SAFETY: bytes at..at + 28 are inside `out`; the junk of each store is
                // overwritten by the next pixels.
                unsafe {
                    let o = out.as_mut_ptr().add(at);
                    _mm_storeu_si128(o as *mut __m128i, _mm256_castsi256_si128(px));
                    _mm_storeu_si128(o.add(12) as *mut __m128i, _mm256_extracti128_si256::<1>(px));
                }
            } else {
                let mut buf = [0u8; 32];
                // SAFETY: 32 bytes of `buf`.
                unsafe {
                    _mm_storeu_si128(buf.as_mut_ptr() as *mut __m128i, _mm256_castsi256_si128(px));
                    _mm_storeu_si128(
                        buf.as_mut_ptr().add(12) as *mut __m128i,
                        _mm256_extracti128_si256::<1>(px),
                    );
                }
                let n = out.len() - at;
                out[at..].copy_from_slice(&buf[..n]);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    //! AVX-512 (where the CPU has F, BW, VBMI and VNNI): four pixels a register, one per
    //! 128-bit lane, with the byte shuffles of the AVX2 kernel; `vpdpwssd` multiplies and
    //! accumulates in one step (the rounding half is the accumulator's start) and one
    //! two-register byte permute (`vpermt2b`) turns a group's eight sums into its 24 bytes.
    //! Same integer results.
    use super::{Round, HALF, LANES, WEIGHT_BITS};
    use std::arch::x86_64::*;

    /// Whether the CPU has what this kernel uses.
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512vbmi")
            && std::arch::is_x86_feature_detected!("avx512vnni")
    }

    /// 16 bytes at `data + o[i]` (+ `row`) in lane i.
    ///
    /// # Safety
    ///
    /// Each of those 16 bytes must be readable.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn rows(data: *const u8, o: [u32; 4], row: usize) -> __m512i {
        // SAFETY: the caller's contract.
        let load =
            |i: usize| unsafe { _mm_loadu_si128(data.add(o[i] as usize + row) as *const __m128i) };
        let v = _mm512_castsi128_si512(load(0));
        let v = _mm512_inserti32x4::<1>(v, load(1));
        let v = _mm512_inserti32x4::<2>(v, load(2));
        _mm512_inserti32x4::<3>(v, load(3))
    }

    /// `acc` plus the (r, g, b, junk) sums of the blocks at `o` (one a lane), whose weights
    /// are those of the low (`HIGH` false) or high quad of each lane of `w`.
    ///
    /// # Safety
    ///
    /// `data + o[i]` and `data + o[i] + stride3` must have 16 readable bytes.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw,avx512vnni")]
    unsafe fn four_sums<const HIGH: bool>(
        acc: __m512i,
        data: *const u8,
        stride3: usize,
        o: [u32; 4],
        w: __m512i,
    ) -> __m512i {
        // SAFETY: the caller's contract.
        let (top, bottom) = unsafe { (rows(data, o, 0), rows(data, o, stride3)) };
        // as the AVX2 kernel's `pair_sum`: r r' g g' b b' 0 0 against tl tr ... or bl br ...
        #[rustfmt::skip]
        let pixels = _mm512_broadcast_i32x4(_mm_setr_epi8(
            0, -1, 3, -1, 1, -1, 4, -1, 2, -1, 5, -1, 15, -1, -1, -1,
        ));
        let h = if HIGH { 8 } else { 0 };
        #[rustfmt::skip]
        let top_w = _mm512_broadcast_i32x4(_mm_setr_epi8(
            h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, h, h + 1, h + 4, h + 5, -1, -1, -1, -1,
        ));
        #[rustfmt::skip]
        let bottom_w = _mm512_broadcast_i32x4(_mm_setr_epi8(
            h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7, h + 2, h + 3, h + 6, h + 7,
            -1, -1, -1, -1,
        ));
        let acc = _mm512_dpwssd_epi32(
            acc,
            _mm512_shuffle_epi8(top, pixels),
            _mm512_shuffle_epi8(w, top_w),
        );
        _mm512_dpwssd_epi32(
            acc,
            _mm512_shuffle_epi8(bottom, pixels),
            _mm512_shuffle_epi8(w, bottom_w),
        )
    }

    /// # Safety
    ///
    /// Every block's reads (see [`four_sums`]) must lie inside `data`, and the CPU
    /// must have what [`available`] checks.
    #[target_feature(enable = "avx512f,avx512bw,avx512vbmi,avx512vnni")]
    pub(super) unsafe fn apply_row(
        rounds: &[Round],
        depth: &[u8],
        data: &[u8],
        stride3: usize,
        out: &mut [u8],
    ) {
        let p = data.as_ptr();
        // Output byte 3i + c is channel c of pixel i: pixel 2k is lane k of the even sums
        // (bytes 0-63 of the pair), pixel 2k + 1 lane k of the odd ones (64-127).
        let squeeze = _mm512_loadu_si512(
            std::array::from_fn::<u8, 64, _>(|b| {
                let (i, c) = (b / 3, b % 3);
                if i < LANES {
                    ((i % 2) * 64 + (i / 2) * 16 + 4 * c) as u8
                } else {
                    0
                }
            })
            .as_ptr() as *const _,
        );
        let half = _mm512_set1_epi32(HALF);
        let mut r = 0;
        for (g, &k) in depth.iter().enumerate() {
            let group = &rounds[r..r + k as usize];
            for round in group {
                super::prefetch_ahead(round);
            }
            r += k as usize;
            let (mut even, mut odd) = (half, half);
            for round in group {
                let o = round.offset;
                // SAFETY: 64 bytes: the weights of the eight lanes.
                let w = unsafe { _mm512_loadu_si512(round.w.as_ptr() as *const _) };
                // SAFETY: the caller's contract.
                unsafe {
                    even = four_sums::<false>(even, p, stride3, [o[0], o[2], o[4], o[6]], w);
                    odd = four_sums::<true>(odd, p, stride3, [o[1], o[3], o[5], o[7]], w);
                }
            }
            let even = _mm512_srai_epi32::<WEIGHT_BITS>(even);
            let odd = _mm512_srai_epi32::<WEIGHT_BITS>(odd);
            let px = _mm512_permutex2var_epi8(even, squeeze, odd);
            let at = 3 * LANES * g;
            if at + 32 <= out.len() {
                // SAFETY: bytes at..at + 32 are inside `out`; the 8 past the group's are
                // overwritten by the next group.
                unsafe {
                    _mm256_storeu_si256(
                        out.as_mut_ptr().add(at) as *mut __m256i,
                        _mm512_castsi512_si256(px),
                    )
                };
            } else {
                let n = (out.len() - at).min(3 * LANES);
                // SAFETY: the mask writes bytes at..at + n only, inside `out`.
                unsafe {
                    _mm512_mask_storeu_epi8(out.as_mut_ptr().add(at) as *mut i8, (1 << n) - 1, px)
                };
            }
        }
    }
}
