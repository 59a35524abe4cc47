//! Applying a remap table to one output row: every output pixel is a weighted sum of 2×2
//! source blocks ([`Quad`]s) with integer weights, so the result is exact integer arithmetic:
//! the scalar and SIMD paths give the same bytes on every machine.

/// Fixed-point bits of a weight: a pixel's weights sum to `1 << WEIGHT_BITS` when all of its
/// samples lie inside the source. 14 bits keep every weight a positive i16 (for
/// `_mm_madd_epi16`) and every sum (at most 255 · 2^14) well inside an i32.
pub(super) const WEIGHT_BITS: u32 = 14;
pub(super) const WEIGHT_ONE: i32 = 1 << WEIGHT_BITS;
const HALF: i32 = 1 << (WEIGHT_BITS - 1);

/// A 2×2 block of source pixels and its weights, 12 bytes (the table is streamed each frame).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[repr(C)]
pub(super) struct Quad {
    /// Index of the top-left source pixel; the block spans +1 column and +1 row.
    pub offset: u32,
    /// Weights of top-left, bottom-left, top-right, bottom-right in 1/WEIGHT_ONE (this order
    /// is what the SSE2 kernel multiplies after interleaving the top and bottom rows).
    pub w: [i16; 4],
}

/// Bytes the SIMD kernel reads from a block's top-left and bottom-left pixel (6 used).
pub(super) const SIMD_READ: usize = 8;

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
}

/// Resamples one output row. `quads` are the row's blocks, `counts` (if any) how many of them
/// each pixel has (otherwise one each); `reach` is the largest block offset of the row, which
/// bounds every read once for the whole row.
pub(super) fn apply_row(
    quads: &[Quad],
    counts: Option<&[u8]>,
    data: &[u8],
    stride: usize,
    reach: u32,
    out: &mut [u8],
    kernel: Kernel,
) {
    let stride3 = stride * 3;
    let end = reach as usize * 3 + stride3;
    #[cfg(not(target_arch = "x86_64"))]
    let _ = kernel;
    #[cfg(target_arch = "x86_64")]
    if kernel != Kernel::Scalar && end + SIMD_READ <= data.len() {
        // SAFETY: every quad of the row has offset <= reach, so each 8-byte load at
        // offset·3 and offset·3 + stride·3 ends at or before end + 8 <= data.len(); AVX2 is
        // used only where the CPU has it.
        unsafe {
            if kernel == Kernel::Auto && std::arch::is_x86_feature_detected!("avx2") {
                avx2::apply_row(quads, counts, data, stride3, out);
            } else {
                sse2::apply_row(quads, counts, data, stride3, out);
            }
        }
        return;
    }
    if end + 6 <= data.len() {
        apply_row_scalar(quads, counts, out, |q| sum_plain(data, stride3, q));
    } else {
        // Only for sources one row high (the block's lower row does not exist) or the
        // last pixels of the source: read the pixels with a weight, checked.
        apply_row_scalar(quads, counts, out, |q| sum_checked(data, stride3, q));
    }
}

/// How many leading `counts` equal `n`, eight at a time (a row's runs are long: a byte at a
/// time cost a quarter of the AVX2 kernel's time).
fn same_prefix(counts: &[u8], n: u8) -> usize {
    let pattern = u64::from_ne_bytes([n; 8]);
    let mut words = counts.chunks_exact(8);
    let mut i = 0;
    for word in &mut words {
        if u64::from_ne_bytes(word.try_into().expect("8 bytes")) != pattern {
            break;
        }
        i += 8;
    }
    i + counts[i..]
        .iter()
        .position(|&c| c != n)
        .unwrap_or(counts.len() - i)
}

fn apply_row_scalar(
    quads: &[Quad],
    counts: Option<&[u8]>,
    out: &mut [u8],
    sum: impl Fn(&Quad) -> [i32; 3],
) {
    let finish = |acc: [i32; 3]| acc.map(|v| ((v + HALF) >> WEIGHT_BITS) as u8);
    match counts {
        None => {
            for (px, q) in out.chunks_exact_mut(3).zip(quads) {
                px.copy_from_slice(&finish(sum(q)));
            }
        }
        Some(counts) => {
            let mut rest = quads;
            for (px, &n) in out.chunks_exact_mut(3).zip(counts) {
                let (mine, tail) = rest.split_at(n as usize);
                rest = tail;
                let mut acc = [0i32; 3];
                for q in mine {
                    let s = sum(q);
                    for c in 0..3 {
                        acc[c] += s[c];
                    }
                }
                px.copy_from_slice(&finish(acc));
            }
        }
    }
}

/// Weighted sum of a block whose four pixels are known to be inside `data`.
#[inline(always)]
fn sum_plain(data: &[u8], stride3: usize, q: &Quad) -> [i32; 3] {
    let base = q.offset as usize * 3;
    let top: &[u8; 6] = data[base..base + 6].try_into().expect("6 bytes");
    let bottom: &[u8; 6] = data[base + stride3..base + stride3 + 6]
        .try_into()
        .expect("6 bytes");
    let [tl, bl, tr, br] = q.w.map(i32::from);
    std::array::from_fn(|c| {
        top[c] as i32 * tl
            + bottom[c] as i32 * bl
            + top[c + 3] as i32 * tr
            + bottom[c + 3] as i32 * br
    })
}

/// As [`sum_plain`], reading only the pixels with a nonzero weight (which exist).
fn sum_checked(data: &[u8], stride3: usize, q: &Quad) -> [i32; 3] {
    let base = q.offset as usize * 3;
    let mut acc = [0i32; 3];
    for (w, at) in q.w.iter().zip([0, stride3, 3, stride3 + 3]) {
        if *w != 0 {
            for (c, a) in acc.iter_mut().enumerate() {
                *a += data[base + at + c] as i32 * *w as i32;
            }
        }
    }
    acc
}

#[cfg(target_arch = "x86_64")]
mod sse2 {
    //! SSE2 (baseline on x86_64, so no runtime detection): one block is two 8-byte loads,
    //! the rows interleaved so that `_mm_madd_epi16` forms top·w + bottom·w per channel.
    use super::{Quad, HALF, WEIGHT_BITS};
    use std::arch::x86_64::*;

    /// The block's (r, g, b, junk) weighted sums.
    ///
    /// SAFETY: `data + offset·3` and `data + offset·3 + stride3` must have 8 readable bytes.
    #[inline]
    #[target_feature(enable = "sse2")]
    pub(super) unsafe fn quad_sum(data: *const u8, stride3: usize, q: &Quad) -> __m128i {
        let base = q.offset as usize * 3;
        // SAFETY: the caller's contract; the weights are 8 bytes of `q`.
        let (top, bottom, w) = unsafe {
            (
                _mm_loadl_epi64(data.add(base) as *const __m128i),
                _mm_loadl_epi64(data.add(base + stride3) as *const __m128i),
                _mm_loadl_epi64(q.w.as_ptr() as *const __m128i),
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

    /// SAFETY: every quad's reads (see [`quad_sum`]) must lie inside `data`.
    #[target_feature(enable = "sse2")]
    pub(super) unsafe fn apply_row(
        quads: &[Quad],
        counts: Option<&[u8]>,
        data: &[u8],
        stride3: usize,
        out: &mut [u8],
    ) {
        let p = data.as_ptr();
        match counts {
            None => {
                for (px, q) in out.chunks_exact_mut(3).zip(quads) {
                    // SAFETY: the caller's contract.
                    px.copy_from_slice(&finish(unsafe { quad_sum(p, stride3, q) }));
                }
            }
            Some(counts) => {
                let mut rest = quads;
                for (px, &n) in out.chunks_exact_mut(3).zip(counts) {
                    let (mine, tail) = rest.split_at(n as usize);
                    rest = tail;
                    let mut acc = _mm_setzero_si128();
                    for q in mine {
                        // SAFETY: the caller's contract.
                        acc = _mm_add_epi32(acc, unsafe { quad_sum(p, stride3, q) });
                    }
                    px.copy_from_slice(&finish(acc));
                }
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! AVX2 (where the CPU has it): the SSE2 kernel's arithmetic on two pixels at once, one
    //! per 128-bit lane, so each shuffle and multiply serves two pixels. Same integer results.
    use super::{sse2, Quad, HALF, WEIGHT_BITS};
    use std::arch::x86_64::*;

    /// The (r, g, b, 0) sums of blocks `a` (low lane) and `b` (high lane).
    ///
    /// Byte shuffles put each row's left and right pixel side by side as 16-bit values
    /// (r r' g g' b b' 0 0) and the weights beside them (tl tr ... and bl br ...), so two
    /// `madd`s and one add give the sums: fewer shuffles than the SSE2 interleave.
    ///
    /// SAFETY: as [`sse2::quad_sum`], for both blocks.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn pair_sum(data: *const u8, stride3: usize, a: &Quad, b: &Quad) -> __m256i {
        let (oa, ob) = (a.offset as usize * 3, b.offset as usize * 3);
        let load = |p: *const u8| {
            // SAFETY: the caller's contract (pixels) or 8 bytes of a quad (weights).
            unsafe { _mm_loadl_epi64(p as *const __m128i) }
        };
        let top = _mm256_set_m128i(load(data.wrapping_add(ob)), load(data.wrapping_add(oa)));
        let bottom = _mm256_set_m128i(
            load(data.wrapping_add(ob + stride3)),
            load(data.wrapping_add(oa + stride3)),
        );
        let w = _mm256_set_m128i(load(b.w.as_ptr() as _), load(a.w.as_ptr() as _));
        // -1 (0x80 set) writes a zero byte
        #[rustfmt::skip]
        let pixels = _mm256_setr_epi8(
            0, -1, 3, -1, 1, -1, 4, -1, 2, -1, 5, -1, -1, -1, -1, -1,
            0, -1, 3, -1, 1, -1, 4, -1, 2, -1, 5, -1, -1, -1, -1, -1,
        );
        // w is tl bl tr br (16-bit): top weights tl tr, bottom weights bl br, three times
        #[rustfmt::skip]
        let top_w = _mm256_setr_epi8(
            0, 1, 4, 5, 0, 1, 4, 5, 0, 1, 4, 5, -1, -1, -1, -1,
            0, 1, 4, 5, 0, 1, 4, 5, 0, 1, 4, 5, -1, -1, -1, -1,
        );
        #[rustfmt::skip]
        let bottom_w = _mm256_setr_epi8(
            2, 3, 6, 7, 2, 3, 6, 7, 2, 3, 6, 7, -1, -1, -1, -1,
            2, 3, 6, 7, 2, 3, 6, 7, 2, 3, 6, 7, -1, -1, -1, -1,
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

    /// Pixels 0 and 1 (`x`'s lanes) and 2 and 3 (`y`'s), rounded, as 12 bytes r g b r g b ...
    /// and 4 bytes of junk.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn finish_four(x: __m256i, y: __m256i) -> __m128i {
        let half = _mm256_set1_epi32(HALF);
        let x = _mm256_srai_epi32::<{ WEIGHT_BITS as i32 }>(_mm256_add_epi32(x, half));
        let y = _mm256_srai_epi32::<{ WEIGHT_BITS as i32 }>(_mm256_add_epi32(y, half));
        // bytes, per lane: pixel 0 (or 1) then pixel 2 (or 3), each r g b 0, twice
        let b = _mm256_packus_epi16(_mm256_packs_epi32(x, y), _mm256_setzero_si256());
        // dwords in pixel order: lane 0's first two, lane 1's first two, interleaved
        let d = _mm256_permutevar8x32_epi32(b, _mm256_setr_epi32(0, 4, 1, 5, 0, 0, 0, 0));
        #[rustfmt::skip]
        let squeeze = _mm_setr_epi8(0, 1, 2, 4, 5, 6, 8, 9, 10, 12, 13, 14, -1, -1, -1, -1);
        _mm_shuffle_epi8(_mm256_castsi256_si128(d), squeeze)
    }

    /// Both pixels of a pair, rounded: (r, g, b, junk) of each.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn finish_pair(acc: __m256i) -> [u32; 2] {
        let r = _mm256_srai_epi32::<{ WEIGHT_BITS as i32 }>(_mm256_add_epi32(
            acc,
            _mm256_set1_epi32(HALF),
        ));
        let p = _mm256_packus_epi16(_mm256_packs_epi32(r, r), r);
        [
            _mm256_cvtsi256_si32(p) as u32,
            _mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(p)) as u32,
        ]
    }

    /// SAFETY: every quad's reads (see [`sse2::quad_sum`]) must lie inside `data`, and the CPU
    /// must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn apply_row(
        quads: &[Quad],
        counts: Option<&[u8]>,
        data: &[u8],
        stride3: usize,
        out: &mut [u8],
    ) {
        let p = data.as_ptr();
        match counts {
            // SAFETY (all three): the caller's contract.
            None => unsafe { run(p, stride3, quads, 1, out) },
            Some(counts) => {
                // Runs of pixels with the same number of blocks (a row has few: 2×1
                // supersampled columns at the sides, one block in the middle), each with
                // the loop for its count, free of per-pixel decisions.
                let w = counts.len().min(out.len() / 3);
                let (mut u, mut q) = (0, 0);
                while u < w {
                    let n = counts[u];
                    let len = super::same_prefix(&counts[u..w], n);
                    let k = len * n as usize;
                    unsafe {
                        run(
                            p,
                            stride3,
                            &quads[q..q + k],
                            n as usize,
                            &mut out[3 * u..3 * (u + len)],
                        )
                    };
                    u += len;
                    q += k;
                }
            }
        }
    }

    /// Pixels of `n` blocks each, `out.len() / 3` of them.
    ///
    /// SAFETY: as [`apply_row`].
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn run(p: *const u8, stride3: usize, quads: &[Quad], n: usize, out: &mut [u8]) {
        // SAFETY (all three): the caller's contract.
        match n {
            1 => unsafe { run_n::<1>(p, stride3, quads, out) },
            2 => unsafe { run_n::<2>(p, stride3, quads, out) },
            _ => unsafe { run_any(p, stride3, quads, n, out) },
        }
    }

    /// Pixels of `N` blocks each (the common counts: 1, and 2 for the 2×1 supersampled
    /// columns), two pixels in the two lanes, their blocks summed lane by lane.
    ///
    /// SAFETY: as [`apply_row`].
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn run_n<const N: usize>(p: *const u8, stride3: usize, quads: &[Quad], out: &mut [u8]) {
        let pixels = (out.len() / 3).min(quads.len() / N);
        let o = out.as_mut_ptr();
        let q = quads.as_ptr();
        // The sums of pixels a and b (lanes 0 and 1).
        // SAFETY: a, b < pixels, so their blocks are inside `quads`; reads: the caller's.
        let pair = |a: usize, b: usize| unsafe {
            let mut acc = pair_sum(p, stride3, &*q.add(a * N), &*q.add(b * N));
            for k in 1..N {
                acc = _mm256_add_epi32(
                    acc,
                    pair_sum(p, stride3, &*q.add(a * N + k), &*q.add(b * N + k)),
                );
            }
            acc
        };
        // Four pixels at a time, packed together and stored as 16 bytes (12 of them pixels,
        // the rest overwritten by the next ones), while 2 more pixels follow.
        let fours = pixels.saturating_sub(2) / 4;
        for i in 0..fours {
            let u = 4 * i;
            let px = finish_four(pair(u, u + 1), pair(u + 2, u + 3));
            // SAFETY: the store at byte 12i ends at 12i + 16 <= 3·pixels - 2.
            unsafe { _mm_storeu_si128(o.add(3 * u) as *mut __m128i, px) };
        }
        // Then two at a time, each pixel as 4 bytes (the 4th overwritten by the next pixel)
        // while a pixel follows, the last ones as 3 bytes.
        let mut u = 4 * fours;
        while u + 2 <= pixels {
            let [a, b] = finish_pair(pair(u, u + 1));
            if u + 2 < pixels {
                // SAFETY: pixel u + 1's 4 bytes end at 3u + 7 <= 3·pixels - 2.
                unsafe {
                    std::ptr::write_unaligned(o.add(3 * u) as *mut u32, a);
                    std::ptr::write_unaligned(o.add(3 * u + 3) as *mut u32, b);
                }
            } else {
                out[3 * u..3 * u + 3].copy_from_slice(&a.to_le_bytes()[..3]);
                out[3 * u + 3..3 * u + 6].copy_from_slice(&b.to_le_bytes()[..3]);
            }
            u += 2;
        }
        if u < pixels {
            let mut acc = _mm_setzero_si128();
            for quad in &quads[u * N..(u + 1) * N] {
                // SAFETY: the caller's contract.
                acc = _mm_add_epi32(acc, unsafe { sse2::quad_sum(p, stride3, quad) });
            }
            out[3 * u..3 * u + 3].copy_from_slice(&sse2::finish(acc));
        }
    }

    /// Pixels of `n` blocks each, any n: blocks two at a time in the two lanes.
    ///
    /// SAFETY: as [`apply_row`].
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn run_any(p: *const u8, stride3: usize, quads: &[Quad], n: usize, out: &mut [u8]) {
        // blocks two at a time in the two lanes, the lanes summed at the end
        for (px, qs) in out.chunks_exact_mut(3).zip(quads.chunks_exact(n)) {
            let mut wide = _mm256_setzero_si256();
            let mut pairs = qs.chunks_exact(2);
            for q in &mut pairs {
                // SAFETY: the caller's contract.
                wide = _mm256_add_epi32(wide, unsafe { pair_sum(p, stride3, &q[0], &q[1]) });
            }
            let mut acc = _mm_add_epi32(
                _mm256_castsi256_si128(wide),
                _mm256_extracti128_si256::<1>(wide),
            );
            if let [q] = pairs.remainder() {
                // SAFETY: the caller's contract.
                acc = _mm_add_epi32(acc, unsafe { sse2::quad_sum(p, stride3, q) });
            }
            px.copy_from_slice(&sse2::finish(acc));
        }
    }
}
