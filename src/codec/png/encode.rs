//! PNG encoding for the fdeflate presets (`fast`, `default`), one row at a time.
//!
//! Each row is filtered and compressed as soon as it is produced, straight into the output
//! buffer, so an image is never held twice (filtered copy, compressed copy, chunked copy) as
//! the png crate's encoder does; and a row can come from a remap table without the warped image
//! ever existing whole. The bytes are those of png 0.17's encoder with the same settings
//! (`tests/png.rs` compares them), including its fallback to stored blocks when deflate would
//! be larger than the raw data.

use super::{ColourType, SIGNATURE};
use std::io::{Cursor, Write};

/// The png crate's largest IDAT chunk (2^31 - 1 bytes); larger streams span several chunks.
const MAX_CHUNK: usize = (u32::MAX >> 1) as usize;

/// The filter applied to every row (PNG filter types 1 and 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowFilter {
    /// Type 1: each byte minus the byte one pixel to its left.
    Sub,
    /// Type 4: each byte minus the Paeth predictor of its left, upper and upper-left bytes.
    Paeth,
}

/// The image header: size and sample layout (8-bit RGB or 16-bit grey here).
#[derive(Debug, Clone, Copy)]
pub struct Header {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Grey or RGB.
    pub colour: ColourType,
    /// Bits per sample (8 for RGB, 16 for grey).
    pub bit_depth: u8,
    /// Bytes per pixel.
    pub bpp: usize,
}

impl Header {
    /// An 8-bit RGB image of `width` × `height` pixels.
    pub fn rgb8(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            colour: ColourType::Rgb,
            bit_depth: 8,
            bpp: 3,
        }
    }

    /// A 16-bit greyscale image of `width` × `height` pixels (depth maps).
    pub fn gray16(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            colour: ColourType::Grey,
            bit_depth: 16,
            bpp: 2,
        }
    }

    fn row_len(&self) -> usize {
        self.width as usize * self.bpp
    }
}

/// Encodes an image whose raw row `v` is written by `raw_row(v, row)`. Rows are asked for in
/// order, and asked for again only in the rare case where deflate does not pay (the stored
/// fallback), so `raw_row` must give the same bytes each time.
pub fn encode_rows(
    header: Header,
    filter: RowFilter,
    mut raw_row: impl FnMut(usize, &mut [u8]),
) -> Vec<u8> {
    let len = header.row_len();
    let height = header.height as usize;
    // Room for the stored-block size, which bounds what is kept (the signature, IHDR, IDAT
    // header and CRC, IEND: under 64 bytes): no regrowth, and no copy of the stream, while
    // compressing. Camera images compress to about half of it; the rest is never touched.
    let raw_size = (len + 1) * height;
    // (and a row's worth of the compressor's slack: see deflate::Compressor)
    let mut out = Vec::with_capacity(
        fdeflate::StoredOnlyCompressor::<()>::compressed_size(raw_size) + 2 * (len + 1) + 96,
    );
    out.extend_from_slice(&SIGNATURE);
    let mut ihdr = [0u8; 13];
    ihdr[..4].copy_from_slice(&header.width.to_be_bytes());
    ihdr[4..8].copy_from_slice(&header.height.to_be_bytes());
    ihdr[8] = header.bit_depth;
    ihdr[9] = header.colour as u8;
    write_chunk(&mut out, b"IHDR", &ihdr);
    let idat = out.len();
    // IDAT length and type, filled in once the stream's length is known
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(b"IDAT");
    let stream = out.len();

    let (mut prev, mut cur) = (vec![0u8; len], vec![0u8; len]);
    let mut filtered = vec![0u8; len + 1];
    filtered[0] = match filter {
        RowFilter::Sub => 1,
        RowFilter::Paeth => 4,
    };
    let mut z = super::deflate::Compressor::new(out);
    for v in 0..height {
        raw_row(v, &mut cur);
        match filter {
            RowFilter::Sub => sub_dispatch(header.bpp, &cur, &mut filtered[1..]),
            RowFilter::Paeth => paeth_dispatch(header.bpp, &prev, &cur, &mut filtered[1..]),
        }
        z.write_data(&filtered);
        std::mem::swap(&mut prev, &mut cur);
    }
    let mut out = z.finish();
    if out.len() - stream > fdeflate::StoredOnlyCompressor::<()>::compressed_size(raw_size) {
        // Deflate made it larger: stored blocks of unfiltered rows, as the png crate does.
        out.truncate(stream);
        let mut cursor = Cursor::new(out);
        cursor.set_position(stream as u64);
        let mut z = fdeflate::StoredOnlyCompressor::new(cursor).expect("write to a Vec");
        for v in 0..height {
            raw_row(v, &mut cur);
            z.write_data(&[0]).expect("write to a Vec");
            z.write_data(&cur).expect("write to a Vec");
        }
        out = z.finish().expect("write to a Vec").into_inner();
    }
    let stream_len = out.len() - stream;
    if stream_len <= MAX_CHUNK {
        out[idat..idat + 4].copy_from_slice(&(stream_len as u32).to_be_bytes());
        let crc = crc32fast::hash(&out[idat + 4..]);
        out.extend_from_slice(&crc.to_be_bytes());
    } else {
        // Over 2 GiB of stream (not a camera image): split as the png crate does.
        let data = out.split_off(stream);
        out.truncate(idat);
        for chunk in data.chunks(MAX_CHUNK) {
            write_chunk(&mut out, b"IDAT", chunk);
        }
    }
    write_chunk(&mut out, b"IEND", &[]);
    out
}

fn write_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let start = out.len();
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    let crc = crc32fast::hash(&out[start..]);
    out.write_all(&crc.to_be_bytes()).expect("write to a Vec");
}

/// Bytes per loop step: whole chunks let the compiler vectorise the filters.
const CHUNK: usize = 32;

/// PNG filter 1: each byte minus the byte one pixel to its left.
#[inline(always)]
fn sub(bpp: usize, cur: &[u8], out: &mut [u8]) {
    let n = cur.len();
    out[..bpp.min(n)].copy_from_slice(&cur[..bpp.min(n)]);
    if n <= bpp {
        return;
    }
    let (mut o, mut c, mut a) = (
        out[bpp..].chunks_exact_mut(CHUNK),
        cur[bpp..].chunks_exact(CHUNK),
        cur[..n - bpp].chunks_exact(CHUNK),
    );
    for ((o, c), a) in (&mut o).zip(&mut c).zip(&mut a) {
        for i in 0..CHUNK {
            o[i] = c[i].wrapping_sub(a[i]);
        }
    }
    for ((o, c), a) in o
        .into_remainder()
        .iter_mut()
        .zip(c.remainder())
        .zip(a.remainder())
    {
        *o = c.wrapping_sub(*a);
    }
}

/// [`sub`], compiled for AVX2 where the CPU has it (as [`paeth_dispatch`]).
fn sub_dispatch(bpp: usize, cur: &[u8], out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        unsafe { sub_avx2(bpp, cur, out) };
        return;
    }
    sub(bpp, cur, out)
}

/// # Safety
///
/// The CPU must have AVX2: the function is compiled with its instructions, which
/// fault on a processor without them. It reads and writes only through safe slices.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn sub_avx2(bpp: usize, cur: &[u8], out: &mut [u8]) {
    sub(bpp, cur, out)
}

/// [`paeth`], compiled for AVX2 where the CPU has it (32 bytes a step instead of SSE2's 16;
/// the same integer operations, so the same bytes).
fn paeth_dispatch(bpp: usize, prev: &[u8], cur: &[u8], out: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        unsafe { paeth_avx2(bpp, prev, cur, out) };
        return;
    }
    paeth(bpp, prev, cur, out)
}

/// # Safety
///
/// The CPU must have AVX2: the function is compiled with its instructions, which
/// fault on a processor without them. It reads and writes only through safe slices.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn paeth_avx2(bpp: usize, prev: &[u8], cur: &[u8], out: &mut [u8]) {
    paeth(bpp, prev, cur, out)
}

/// PNG filter 4: each byte minus the Paeth predictor of its left (a), upper (b) and upper-left
/// (c) neighbours, with a and c zero in the first pixel.
#[inline(always)]
fn paeth(bpp: usize, prev: &[u8], cur: &[u8], out: &mut [u8]) {
    let n = cur.len();
    for i in 0..bpp.min(n) {
        out[i] = cur[i].wrapping_sub(predict(0, prev[i], 0));
    }
    if n <= bpp {
        return;
    }
    let (mut o, mut x, mut a, mut b, mut c) = (
        out[bpp..].chunks_exact_mut(CHUNK),
        cur[bpp..].chunks_exact(CHUNK),
        cur[..n - bpp].chunks_exact(CHUNK),
        prev[bpp..].chunks_exact(CHUNK),
        prev[..n - bpp].chunks_exact(CHUNK),
    );
    for ((((o, x), a), b), c) in (&mut o).zip(&mut x).zip(&mut a).zip(&mut b).zip(&mut c) {
        for i in 0..CHUNK {
            o[i] = x[i].wrapping_sub(predict(a[i], b[i], c[i]));
        }
    }
    for ((((o, x), a), b), c) in o
        .into_remainder()
        .iter_mut()
        .zip(x.remainder())
        .zip(a.remainder())
        .zip(b.remainder())
        .zip(c.remainder())
    {
        *o = x.wrapping_sub(predict(*a, *b, *c));
    }
}

/// The Paeth predictor in 8-bit arithmetic only (so that it vectorises), as FPNGE computes
/// it: pa = |b - c|, pb = |a - c|, and pc = |pa - pb| where it can matter (c between a and b;
/// otherwise pc is larger than both and never chosen). Equal to the PNG specification's.
#[inline(always)]
fn predict(a: u8, b: u8, c: u8) -> u8 {
    let pa = b.max(c) - b.min(c);
    let pb = a.max(c) - a.min(c);
    let between = (a <= c) != (b <= c);
    let pc = if between {
        pa.max(pb) - pa.min(pb)
    } else {
        255
    };
    if pa <= pb && pa <= pc {
        a
    } else if pb <= pc {
        b
    } else {
        c
    }
}

#[cfg(test)]
mod tests {
    use super::predict;
    use proptest::prelude::*;

    proptest! {
        /// The dispatched Sub and Paeth filters (AVX2 where the CPU has it) against the portable
        /// builds and the specification, for every pixel size PNG has, on rows of any length.
        #[test]
        fn the_dispatched_filters_equal_the_portable_ones(
            bpp in prop::sample::select(vec![1usize, 2, 3, 4, 6, 8]),
            rows in (0usize..90).prop_flat_map(|n| (
                prop::collection::vec(any::<u8>(), n),
                prop::collection::vec(any::<u8>(), n),
            )),
        ) {
            let (prev, cur) = rows;
            let n = cur.len() / bpp * bpp;
            let (prev, cur) = (&prev[..n], &cur[..n]);
            let (mut fast, mut slow) = (vec![1u8; n], vec![2u8; n]);
            super::paeth_dispatch(bpp, prev, cur, &mut fast);
            super::paeth(bpp, prev, cur, &mut slow);
            prop_assert_eq!(&fast, &slow);
            let (mut fast_sub, mut slow_sub) = (vec![1u8; n], vec![2u8; n]);
            super::sub_dispatch(bpp, cur, &mut fast_sub);
            super::sub(bpp, cur, &mut slow_sub);
            prop_assert_eq!(&fast_sub, &slow_sub);
            for i in 0..n {
                let a = if i >= bpp { cur[i - bpp] } else { 0 };
                prop_assert_eq!(fast_sub[i], cur[i].wrapping_sub(a));
            }
            // and both are the specification's filter
            for i in 0..n {
                let a = if i >= bpp { cur[i - bpp] } else { 0 };
                let c = if i >= bpp { prev[i - bpp] } else { 0 };
                prop_assert_eq!(fast[i], cur[i].wrapping_sub(reference(a, prev[i], c)));
            }
        }
    }

    /// The specification's predictor, in wide arithmetic.
    fn reference(a: u8, b: u8, c: u8) -> u8 {
        let p = a as i16 + b as i16 - c as i16;
        let (pa, pb, pc) = (
            (p - a as i16).abs(),
            (p - b as i16).abs(),
            (p - c as i16).abs(),
        );
        if pa <= pb && pa <= pc {
            a
        } else if pb <= pc {
            b
        } else {
            c
        }
    }

    #[test]
    fn paeth_predictor_equals_the_specification_for_every_input() {
        for a in 0..=255u8 {
            for b in 0..=255u8 {
                for c in 0..=255u8 {
                    assert_eq!(predict(a, b, c), reference(a, b, c), "a={a} b={b} c={c}");
                }
            }
        }
    }
}
