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

/// Rows of the buffer holding `levels` levels of a source of `size` (see [`level_shapes`]).
pub(crate) fn pyramid_rows(size: ImageSize, levels: u32) -> u32 {
    let shapes = level_shapes(size, levels);
    let &(_, h, row) = shapes.last().expect("level 0");
    row + h
}

/// The pyramid of `levels` levels of `src` (`size`, `channels` values a pixel, rows top to
/// bottom) in one buffer of the source's width (see the module's notes); `average` gives a
/// coarser pixel's value from its four finer ones (top-left, top-right, bottom-left,
/// bottom-right). Level 0 is `src`'s values, copied.
pub fn pyramid<T: Copy + Default>(
    src: &[T],
    size: ImageSize,
    channels: usize,
    levels: u32,
    average: impl Fn(T, T, T, T) -> T,
) -> Vec<T> {
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
    for pair in shapes.windows(2) {
        let [(fw, fh, frow), (lw, lh, lrow)] = [pair[0], pair[1]];
        let (fine, coarse) = out.split_at_mut(lrow as usize * stride);
        let fine = &fine[frow as usize * stride..];
        for y in 0..lh as usize {
            let (y0, y1) = (2 * y, (2 * y + 1).min(fh as usize - 1));
            let (top, bottom) = (&fine[y0 * stride..], &fine[y1 * stride..]);
            let row = &mut coarse[y * stride..];
            for x in 0..lw as usize {
                let (x0, x1) = (
                    2 * x * channels,
                    (2 * x + 1).min(fw as usize - 1) * channels,
                );
                for c in 0..channels {
                    row[x * channels + c] =
                        average(top[x0 + c], top[x1 + c], bottom[x0 + c], bottom[x1 + c]);
                }
            }
        }
    }
    out
}

/// The rounded mean of four 8-bit values (the integer rule of the RGB pyramid).
#[inline]
pub fn average_u8(a: u8, b: u8, c: u8, d: u8) -> u8 {
    ((a as u16 + b as u16 + c as u16 + d as u16 + 2) >> 2) as u8
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
        let p = pyramid(&src, size, 1, 4, average_u8);
        assert_eq!(p.len(), 5 * 5);
        assert_eq!(&p[..15], &src[..]);
        // (0 + 10 + 50 + 60 + 2) / 4 = 30; the odd column repeated: (40 + 40 + 90 + 90) / 4
        assert_eq!(&p[15..20], &[30, 50, 65, 0, 0]);
        // the odd last row repeated: (100 + 110 + 100 + 110 + 2) / 4 = 105
        assert_eq!(&p[20..25], &[105, 125, 140, 0, 0]);
    }
}
