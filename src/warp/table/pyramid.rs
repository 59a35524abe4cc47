//! A source image's pyramid, in one buffer with the source's row stride: level 0 is the source,
//! each further level the 2×2 box average of the one above (an odd side's last pixel repeated),
//! its rows stored below the previous level's, left-aligned and padded with zeros to the
//! source's width. A [`Quad`](super::kernel::Quad)'s offset thus addresses a pixel of any level
//! and the kernels apply a table that samples coarser levels unchanged: an output pixel several
//! source pixels wide takes one or a few bilinear taps at the level where its footprint is one
//! to two pixels, instead of a tap per source pixel it covers.

use crate::camera::ImageSize;

/// Width, height and first buffer row of each level, level 0 (the source) first: `levels` of
/// them, fewer where a level would be under 2 pixels on a side (a bilinear block needs 2×2).
pub(crate) fn level_shapes(size: ImageSize, levels: u32) -> Vec<(u32, u32, u32)> {
    let mut out = vec![(size.width, size.height, 0)];
    while (out.len() as u32) < levels {
        let &(w, h, row) = out.last().expect("level 0");
        let (lw, lh) = (w.div_ceil(2), h.div_ceil(2));
        if lw < 2 || lh < 2 {
            break;
        }
        out.push((lw, lh, row + h));
    }
    out
}

/// [`level_shapes`] of a 360° source (its columns wrap): only the levels whose width is the
/// source's divided exactly, so that a level's columns tile the full turn as the source's do
/// and its last column's right neighbour is its column 0 (an odd width's last pixel, the last
/// column repeated, would straddle the wrap). A 2048-wide panorama keeps all 5 levels, a
/// 2000-wide one 5 (2000 = 16 · 125), an odd width level 0 alone (its taps).
pub(crate) fn wrapping_level_shapes(size: ImageSize, levels: u32) -> Vec<(u32, u32, u32)> {
    let mut shapes = level_shapes(size, levels);
    let even = |k: usize| k < 32 && size.width.is_multiple_of(1u32 << k);
    let kept = (0..shapes.len()).take_while(|&k| even(k)).count();
    shapes.truncate(kept);
    shapes
}

/// Rows of the buffer holding `levels` levels of a source of `size` (see [`level_shapes`]).
pub(crate) fn pyramid_rows(size: ImageSize, levels: u32) -> u32 {
    let shapes = level_shapes(size, levels);
    let &(_, h, row) = shapes.last().expect("level 0");
    row + h
}

/// The pyramid of `levels` levels of `src` (`size`, `channels` values a pixel, rows top to
/// bottom) in one buffer of the source's width (see the module's notes). A level-k pixel is
/// the mean of the source pixels under it, rounded once: each level's 2×2 sums of the one
/// above are kept in the wider type `A` (`widen` of a source value) and `narrow(sum, k)` makes
/// a level-k value of the sum of its 4^k source values. Level 0 is `src`'s values, copied.
pub fn pyramid<T, A>(
    src: &[T],
    size: ImageSize,
    channels: usize,
    levels: u32,
    widen: impl Fn(T) -> A,
    narrow: impl Fn(A, u32) -> T,
) -> Vec<T>
where
    T: Copy + Default,
    A: Copy + Default + std::ops::Add<Output = A>,
{
    let width = size.width as usize;
    let stride = width * channels;
    assert_eq!(
        src.len(),
        stride * size.height as usize,
        "source size differs from the pyramid's"
    );
    let shapes = level_shapes(size, levels);
    let rows = pyramid_rows(size, levels) as usize;
    let mut out = vec![T::default(); stride * rows];
    out[..src.len()].copy_from_slice(src);
    if shapes.len() < 2 {
        return out;
    }
    let mut fine: Vec<A> = src.iter().map(|&v| widen(v)).collect();
    let mut coarse: Vec<A> = Vec::new();
    for (k, pair) in shapes.windows(2).enumerate() {
        let [(fw, fh, _), (lw, lh, lrow)] = [pair[0], pair[1]];
        let (fs, ls) = (fw as usize * channels, lw as usize * channels);
        coarse.clear();
        coarse.resize(ls * lh as usize, A::default());
        for y in 0..lh as usize {
            let (y0, y1) = (2 * y, (2 * y + 1).min(fh as usize - 1));
            let (top, bottom) = (&fine[y0 * fs..], &fine[y1 * fs..]);
            let sums = &mut coarse[y * ls..(y + 1) * ls];
            let row = &mut out[(lrow as usize + y) * stride..];
            for x in 0..lw as usize {
                let (x0, x1) = (
                    2 * x * channels,
                    (2 * x + 1).min(fw as usize - 1) * channels,
                );
                for c in 0..channels {
                    let sum = top[x0 + c] + top[x1 + c] + bottom[x0 + c] + bottom[x1 + c];
                    sums[x * channels + c] = sum;
                    row[x * channels + c] = narrow(sum, k as u32 + 1);
                }
            }
        }
        std::mem::swap(&mut fine, &mut coarse);
    }
    out
}

/// The rule of 8-bit pyramids ([`pyramid`]'s `narrow` for values summed in a `u32`): the sum
/// of 4^`level` values (`level` >= 1), divided and rounded half up.
#[inline]
pub fn narrow_u8(sum: u32, level: u32) -> u8 {
    ((sum + (1 << (2 * level - 1))) >> (2 * level)) as u8
}

/// The RGB pyramid the kernels of a [`RemapTable`](super::RemapTable) read: [`pyramid`] of
/// 8-bit values with [`narrow_u8`], the sums in 16 bits (4^4 · 255 fits: at most 5 levels),
/// row pairs at a time in loops the compiler vectorises (a KITTI frame's 4 levels in about a
/// tenth of the generic function's time).
pub(crate) fn pyramid_u8(src: &[u8], size: ImageSize, levels: u32) -> Vec<u8> {
    assert!(levels <= 5, "16-bit sums hold 4 levels above the source");
    let stride = size.width as usize * 3;
    assert_eq!(src.len(), stride * size.height as usize, "source size");
    let shapes = level_shapes(size, levels);
    // written row by row, only the padding zeroed (zeroing the whole buffer first would
    // write each byte twice; it is twice the source's size)
    let total = stride * pyramid_rows(size, levels) as usize;
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(src);
    let mut fine: Vec<u16> = Vec::new();
    let mut coarse: Vec<u16> = Vec::new();
    for (k, pair) in shapes.windows(2).enumerate() {
        let [(fw, fh, _), (lw, lh, _)] = [pair[0], pair[1]];
        let (fs, ls) = (fw as usize * 3, lw as usize * 3);
        let level = k as u32 + 1;
        let half = 1u16 << (2 * level - 1);
        coarse.clear();
        coarse.reserve(ls * lh as usize);
        for y in 0..lh as usize {
            let (y0, y1) = (2 * y, (2 * y + 1).min(fh as usize - 1));
            // (one row zeroed then summed into: it stays in the cache)
            coarse.resize((y + 1) * ls, 0);
            let sums = &mut coarse[y * ls..];
            if k == 0 {
                let row = |r: usize| &src[r * fs..(r + 1) * fs];
                sum_pairs(row(y0), row(y1), sums);
            } else {
                let row = |r: usize| &fine[r * fs..(r + 1) * fs];
                sum_pairs(row(y0), row(y1), sums);
            }
            out.extend(sums.iter().map(|&sum| ((sum + half) >> (2 * level)) as u8));
            out.resize(out.len() + stride - ls, 0);
        }
        std::mem::swap(&mut fine, &mut coarse);
    }
    debug_assert_eq!(out.len(), total, "the pyramid's rows");
    out
}

/// `out`'s RGB sums of the 2×2 pixels of rows `top` and `bottom` (an odd last column counted
/// twice).
#[inline]
fn sum_pairs<V: Copy + Into<u16>>(top: &[V], bottom: &[V], out: &mut [u16]) {
    let pairs = top.len() / 6;
    let blocks = out
        .chunks_exact_mut(3)
        .zip(top.chunks_exact(6).zip(bottom.chunks_exact(6)));
    for (o, (t, b)) in blocks {
        for c in 0..3 {
            o[c] = t[c].into() + t[c + 3].into() + b[c].into() + b[c + 3].into();
        }
    }
    if out.len() > pairs * 3 {
        let x = pairs * 6;
        for c in 0..3 {
            out[pairs * 3 + c] = 2 * (top[x + c].into() + bottom[x + c].into());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_level_is_the_box_average_of_the_one_above() {
        // 5×3 → 3×2 → (2×1 is too small: two levels)
        let size = ImageSize::new(5, 3);
        let src: Vec<u8> = (0..15).map(|i| (i * 10) as u8).collect();
        assert_eq!(level_shapes(size, 4), vec![(5, 3, 0), (3, 2, 3)]);
        let p = pyramid(&src, size, 1, 4, u32::from, narrow_u8);
        assert_eq!(p.len(), 5 * 5);
        assert_eq!(&p[..15], &src[..]);
        // (0 + 10 + 50 + 60 + 2) / 4 = 30; the odd column repeated: (40 + 40 + 90 + 90) / 4
        assert_eq!(&p[15..20], &[30, 50, 65, 0, 0]);
        // the odd last row repeated: (100 + 110 + 100 + 110 + 2) / 4 = 105
        assert_eq!(&p[20..25], &[105, 125, 140, 0, 0]);
    }

    #[test]
    fn a_level_is_the_mean_of_its_source_pixels_rounded_once() {
        // 8×8 → 4×4 → 2×2: in each 4×4 block three 2×2 blocks of mean 0.5 (rounded up to 1 at
        // level 1) and one of 0: the block's mean is 0.375 (0), its rounded level-1 values'
        // 0.75 (1): a level made of the rounded level above drifts
        let size = ImageSize::new(8, 8);
        let src: Vec<u8> = (0..64)
            .map(|i| {
                let (x, y) = (i % 8, i / 8);
                let corner = x % 2 == 0 && y % 2 == 0 && !(x % 4 >= 2 && y % 4 >= 2);
                if corner {
                    2
                } else {
                    0
                }
            })
            .collect();
        let p = pyramid(&src, size, 1, 3, u32::from, narrow_u8);
        let shapes = level_shapes(size, 3);
        assert_eq!(shapes.len(), 3);
        let mut drifted = false;
        for (k, &(lw, lh, row)) in shapes.iter().enumerate().skip(1) {
            let n = 1usize << k;
            for y in 0..lh as usize {
                for x in 0..lw as usize {
                    let sum: u32 = (0..n * n)
                        .map(|i| src[(y * n + i / n) * 8 + x * n + i % n] as u32)
                        .sum();
                    let got = p[(row as usize + y) * 8 + x];
                    assert_eq!(got, narrow_u8(sum, k as u32), "level {k} ({x}, {y})");
                    if k == 2 {
                        // what level 1's rounded values would give
                        let l1 = |xx: usize, yy: usize| p[(4 + yy) * 8 + xx] as u32;
                        let from_above = narrow_u8(
                            l1(2 * x, 2 * y)
                                + l1(2 * x + 1, 2 * y)
                                + l1(2 * x, 2 * y + 1)
                                + l1(2 * x + 1, 2 * y + 1),
                            1,
                        );
                        drifted |= from_above != got;
                    }
                }
            }
        }
        assert!(drifted, "the case tells the two rules apart");
    }

    #[test]
    fn a_wrapping_sources_levels_divide_its_width() {
        let widths = |w: u32| -> Vec<u32> {
            let shapes = wrapping_level_shapes(ImageSize::new(w, w / 2), 6);
            // (the levels kept are the plain levels' first ones, rows and all)
            assert_eq!(
                shapes,
                level_shapes(ImageSize::new(w, w / 2), 6)[..shapes.len()]
            );
            shapes.iter().map(|s| s.0).collect()
        };
        assert_eq!(widths(800), [800, 400, 200, 100, 50, 25]);
        assert_eq!(widths(1000), [1000, 500, 250, 125]);
        assert_eq!(widths(999), [999]);
    }

    #[test]
    fn the_rgb_pyramid_is_the_generic_one() {
        // odd and even sides, 4 levels, values that exercise the rounding
        for (w, h) in [(37, 23), (64, 32), (9, 17)] {
            let size = ImageSize::new(w, h);
            let src: Vec<u8> = (0..w * h * 3).map(|i| (i * 37 % 251) as u8).collect();
            let want = pyramid(&src, size, 3, 4, u32::from, narrow_u8);
            assert_eq!(pyramid_u8(&src, size, 4), want, "{w}x{h}");
        }
    }
}
