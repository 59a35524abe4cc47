//! A direct decoder for the common PNG: 8-bit RGB, not interlaced (every KITTI image).
//!
//! The IDAT stream is inflated with fdeflate (the png crate's own inflater) into a small
//! sliding window (32 KiB of history and room for a few rows), and each row is unfiltered from
//! there into the image as soon as it is complete: none of the png crate's per-row copies or
//! streaming state, and no second whole-image buffer. [`RowDecoder`] hands out the image a
//! band of rows at a time, so that a warp can read rows moments after they are decoded (still
//! in the core's cache) instead of after the whole image. It accepts only files it is sure of:
//! anything else (another pixel format, interlacing, a bad checksum, a truncated or overlong
//! stream, chunks out of order, tRNS) returns `None` and the caller decodes with the png
//! crate, whose errors panoconv reports. `tests/png.rs` checks the pixels equal the png
//! crate's.

use super::ColourType;
use std::cell::RefCell;

/// Bytes from the file's start to the end of the IHDR chunk.
const HEADER_LEN: usize = 33;
/// Deflate's largest back-reference distance: the window keeps this much inflated history.
const HISTORY: usize = 32 * 1024;
/// Least room for new inflated bytes in the window (more for rows longer than half of it).
const CHUNK: usize = 256 * 1024;

thread_local! {
    /// The gathered IDAT stream and the inflate window of the image being decoded, kept per
    /// thread so that they are not allocated and grown each frame.
    static BUFFERS: RefCell<(Vec<u8>, Vec<u8>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// The image's (width, height, RGB bytes), or `None` when this decoder does not take the file.
/// `max_pixels` bounds what the header may ask for.
pub fn decode_rgb8(bytes: &[u8], max_pixels: u64) -> Option<(u32, u32, Vec<u8>)> {
    RowDecoder::new(bytes, max_pixels)?.finish()
}

/// An 8-bit RGB PNG decoded row by row on demand into a whole-image buffer.
pub struct RowDecoder {
    width: u32,
    height: u32,
    /// Bytes of an unfiltered row.
    len: usize,
    /// The IDAT data, gathered into one stream (a camera PNG has many small IDAT chunks).
    stream: Vec<u8>,
    /// Bytes of `stream` the inflater has taken.
    used: usize,
    inflater: fdeflate::Decompressor,
    /// Inflated bytes: history, then rows not yet unfiltered, up to `filled`.
    window: Vec<u8>,
    filled: usize,
    /// Where the next row (its filter byte) starts in `window`.
    next: usize,
    /// Inflated bytes so far, in all.
    produced: usize,
    /// The pixels, rows `..rows` decoded, the rest zero.
    image: Vec<u8>,
    rows: usize,
}

impl RowDecoder {
    /// Checks the header and every chunk (CRCs, order) and gathers the IDAT stream; `None`
    /// when this decoder does not take the file. Nothing is inflated yet; the image's rows
    /// are zero until decoded.
    pub fn new(bytes: &[u8], max_pixels: u64) -> Option<RowDecoder> {
        Self::with_buffer(bytes, max_pixels, Vec::new())
    }

    /// As [`RowDecoder::new`], decoding into `buffer` (an earlier image's, so that its memory
    /// is neither zeroed nor faulted in again): rows not yet decoded hold what it held.
    pub fn with_buffer(bytes: &[u8], max_pixels: u64, mut buffer: Vec<u8>) -> Option<RowDecoder> {
        let header = super::read_header(bytes)?;
        let (width, height) = (header.width, header.height);
        // 8-bit RGB, not interlaced (read_header checked the rest)
        if header.bit_depth != 8
            || header.colour != ColourType::Rgb
            || header.interlaced
            || width as u64 * height as u64 > max_pixels
        {
            return None;
        }
        let len = width as usize * 3;
        let (mut stream, mut window) = BUFFERS.with_borrow_mut(std::mem::take);
        stream.clear();
        let mut chunks = Chunks {
            rest: &bytes[HEADER_LEN..],
        };
        let mut seen_idat = false;
        let mut ended_idat = false;
        loop {
            let (kind, data) = chunks.next()?;
            match &kind {
                b"IDAT" if !ended_idat => {
                    seen_idat = true;
                    stream.extend_from_slice(data);
                }
                b"IEND" if seen_idat => break,
                // ancillary chunks (lowercase first letter) other than tRNS, which would add
                // an alpha channel, and PLTE (a suggested palette for an RGB image) are not
                // needed for the pixels
                k if (k[0].is_ascii_lowercase() && k != b"tRNS") || k == b"PLTE" => {
                    ended_idat |= seen_idat;
                }
                _ => return None,
            }
        }
        window.resize(HISTORY + CHUNK.max(2 * (len + 1)), 0);
        let mut inflater = fdeflate::Decompressor::new();
        // as the png crate: the IDAT chunks' CRCs already protect the data
        inflater.ignore_adler32();
        Some(RowDecoder {
            width,
            height,
            len,
            stream,
            used: 0,
            inflater,
            window,
            filled: 0,
            next: 0,
            produced: 0,
            image: {
                buffer.resize(len.checked_mul(height as usize)?, 0);
                buffer
            },
            rows: 0,
        })
    }

    /// (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The whole image's buffer (3 bytes a pixel, rows top to bottom): the rows decoded so far
    /// ([`RowDecoder::rows`]), then what the buffer held (zeros from [`RowDecoder::new`]).
    pub fn image(&self) -> &[u8] {
        &self.image
    }

    /// Rows decoded so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Decodes rows until at least `n` (at most the height) are; `None` when the stream is
    /// damaged (the decoder is then of no further use).
    pub fn decode_rows(&mut self, n: usize) -> Option<()> {
        let n = n.min(self.height as usize);
        while self.rows < n {
            if self.next + self.len < self.filled {
                self.unfilter_row()?;
            } else {
                self.inflate()?;
            }
        }
        Some(())
    }

    /// Decodes the rest and checks the stream ends exactly there: the image's (width, height,
    /// RGB bytes).
    pub fn finish(mut self) -> Option<(u32, u32, Vec<u8>)> {
        self.decode_rows(self.height as usize)?;
        Some((self.width, self.height, std::mem::take(&mut self.image)))
    }

    /// Unfilters the row at `next` into the image, against the row above it.
    fn unfilter_row(&mut self) -> Option<()> {
        let (r, len) = (self.rows, self.len);
        let filter = self.window[self.next];
        let src = &self.window[self.next + 1..self.next + 1 + len];
        let (done, rest) = self.image.split_at_mut(r * len);
        let prev = if r == 0 {
            None
        } else {
            Some(&done[(r - 1) * len..])
        };
        unfilter(filter, prev, src, &mut rest[..len])?;
        self.next += len + 1;
        self.rows += 1;
        Some(())
    }

    /// Inflates more bytes into the window (at least one, or `None`).
    fn inflate(&mut self) -> Option<()> {
        let raw_len = (self.len + 1) * self.height as usize;
        if self.window.len() - self.filled < CHUNK.max(2 * (self.len + 1)) / 2 {
            // keep the deflate history and the unconsumed part of the next row
            let keep = self.next.min(self.filled.saturating_sub(HISTORY));
            self.window.copy_within(keep..self.filled, 0);
            self.filled -= keep;
            self.next -= keep;
        }
        let input = &self.stream[self.used..];
        if self.produced + 1 < raw_len {
            // All but the image's last byte first: fdeflate sums the adler32 of whatever the
            // call that reaches the checksum produced, ignored or not, and that should be one
            // byte, not a window's worth.
            let end = self
                .window
                .len()
                .min(self.filled + (raw_len - 1 - self.produced));
            let (used, n) = self
                .inflater
                .read(input, &mut self.window[..end], self.filled, true)
                .ok()?;
            if n == 0 {
                return None;
            }
            self.used += used;
            self.filled += n;
            self.produced += n;
        } else if self.produced + 1 == raw_len {
            let (used, n) = self
                .inflater
                .read(
                    input,
                    &mut self.window[..self.filled + 1],
                    self.filled,
                    true,
                )
                .ok()?;
            if n != 1 || !self.inflater.is_done() || self.used + used != self.stream.len() {
                return None;
            }
            self.used += used;
            self.filled += 1;
            self.produced += 1;
        } else {
            return None;
        }
        Some(())
    }
}

impl Drop for RowDecoder {
    fn drop(&mut self) {
        let stream = std::mem::take(&mut self.stream);
        let window = std::mem::take(&mut self.window);
        // (a second decoder on the same thread keeps its own buffers; they are freed here)
        BUFFERS.with_borrow_mut(|b| {
            if b.0.capacity() < stream.capacity() {
                *b = (stream, window);
            }
        });
    }
}

/// Undoes PNG filter `filter` of the row `src` into `cur` (3 bytes a pixel) given the row above
/// (`None`: zeros). Each pixel is handled as a 3-byte array, which the compiler keeps in
/// registers.
fn unfilter(filter: u8, prev: Option<&[u8]>, src: &[u8], cur: &mut [u8]) -> Option<()> {
    let pixel = |px: &mut [u8], new: [u8; 3]| px.copy_from_slice(&new);
    match (filter, prev) {
        (0, _) | (2, None) => cur.copy_from_slice(src),
        (1, _) | (4, None) => unsub(src, cur),
        (2, Some(prev)) => {
            for ((y, x), b) in cur.iter_mut().zip(src).zip(prev) {
                *y = x.wrapping_add(*b);
            }
        }
        (3, None) => {
            let mut a = [0u8; 3];
            for (px, x) in cur.chunks_exact_mut(3).zip(src.chunks_exact(3)) {
                a = [
                    x[0].wrapping_add(a[0] / 2),
                    x[1].wrapping_add(a[1] / 2),
                    x[2].wrapping_add(a[2] / 2),
                ];
                pixel(px, a);
            }
        }
        (3, Some(prev)) => {
            let avg = |a: u8, b: u8| ((a as u16 + b as u16) / 2) as u8;
            let mut a = [0u8; 3];
            for ((px, x), b) in cur
                .chunks_exact_mut(3)
                .zip(src.chunks_exact(3))
                .zip(prev.chunks_exact(3))
            {
                a = [
                    x[0].wrapping_add(avg(a[0], b[0])),
                    x[1].wrapping_add(avg(a[1], b[1])),
                    x[2].wrapping_add(avg(a[2], b[2])),
                ];
                pixel(px, a);
            }
        }
        (4, Some(prev)) => {
            let (mut a, mut c) = ([0u8; 3], [0u8; 3]);
            for ((px, x), b) in cur
                .chunks_exact_mut(3)
                .zip(src.chunks_exact(3))
                .zip(prev.chunks_exact(3))
            {
                a = [
                    x[0].wrapping_add(paeth(a[0], b[0], c[0])),
                    x[1].wrapping_add(paeth(a[1], b[1], c[1])),
                    x[2].wrapping_add(paeth(a[2], b[2], c[2])),
                ];
                pixel(px, a);
                c = [b[0], b[1], b[2]];
            }
        }
        _ => return None,
    }
    Some(())
}

/// Undoes the Sub filter (each byte plus the byte one pixel to its left, 3 bytes a pixel): the
/// KITTI images' only filter. A running sum along the row; with SSSE3 five pixels at a time.
fn unsub(src: &[u8], cur: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("ssse3") {
        // SAFETY: the CPU has SSSE3.
        unsafe { ssse3::unsub(src, cur) };
        return;
    }
    unsub_scalar(src, cur, [0; 3]);
}

/// [`unsub`] one pixel at a time (3 bytes in registers), continuing from the pixel `a`.
fn unsub_scalar(src: &[u8], cur: &mut [u8], mut a: [u8; 3]) {
    for (px, x) in cur.chunks_exact_mut(3).zip(src.chunks_exact(3)) {
        a = [
            x[0].wrapping_add(a[0]),
            x[1].wrapping_add(a[1]),
            x[2].wrapping_add(a[2]),
        ];
        px.copy_from_slice(&a);
    }
}

#[cfg(target_arch = "x86_64")]
mod ssse3 {
    //! The Sub filter's running sum five pixels (15 bytes) at a time: a prefix sum inside the
    //! register by shifts of one, two and four pixels, then the previous block's last pixel
    //! added to all five. Only the last step depends on the previous block.
    use std::arch::x86_64::*;

    /// # Safety
    ///
    /// The CPU must have SSSE3: the function is compiled with its instructions, which
    /// fault on a processor without them. Its loads and stores stay inside both slices (each
    /// block is checked against their shorter length).
    #[target_feature(enable = "ssse3")]
    pub(super) unsafe fn unsub(src: &[u8], cur: &mut [u8]) {
        let n = src.len().min(cur.len());
        // the block's last pixel (bytes 12..15) five times
        let spread = _mm_setr_epi8(
            12, 13, 14, 12, 13, 14, 12, 13, 14, 12, 13, 14, 12, 13, 14, -1,
        );
        let mut carry = _mm_setzero_si128();
        let mut i = 0;
        while i + 16 <= n {
            // SAFETY: bytes i..i + 16 are inside both slices.
            let mut x = unsafe { _mm_loadu_si128(src.as_ptr().add(i) as *const __m128i) };
            x = _mm_add_epi8(x, _mm_slli_si128::<3>(x));
            x = _mm_add_epi8(x, _mm_slli_si128::<6>(x));
            x = _mm_add_epi8(x, _mm_slli_si128::<12>(x));
            x = _mm_add_epi8(x, carry);
            // 15 bytes of pixels and one of junk, which the next block or the tail overwrites
            // SAFETY: as the load.
            unsafe { _mm_storeu_si128(cur.as_mut_ptr().add(i) as *mut __m128i, x) };
            carry = _mm_shuffle_epi8(x, spread);
            i += 15;
        }
        let a = if i == 0 {
            [0; 3]
        } else {
            [cur[i - 3], cur[i - 2], cur[i - 1]]
        };
        super::unsub_scalar(&src[i..n], &mut cur[i..n], a);
    }
}

/// The Paeth predictor as stb_image computes it (public domain; the png crate decodes with
/// it on x86_64): branch-free, short dependency chains. Equal to the specification's.
#[inline(always)]
fn paeth(a: u8, b: u8, c: u8) -> u8 {
    let thresh = c as i16 * 3 - (a as i16 + b as i16);
    let (lo, hi) = (a.min(b), a.max(b));
    let t0 = if hi as i16 <= thresh { lo } else { c };
    if thresh <= lo as i16 {
        hi
    } else {
        t0
    }
}

/// The chunks of a PNG after its signature, each (type, data) once its CRC is checked; the
/// iteration stops (`None`) at the end of the file or at a damaged chunk.
struct Chunks<'a> {
    rest: &'a [u8],
}

impl<'a> Chunks<'a> {
    fn next(&mut self) -> Option<([u8; 4], &'a [u8])> {
        let len = u32::from_be_bytes(self.rest.get(..4)?.try_into().ok()?) as usize;
        let body = self.rest.get(4..8 + len)?;
        let crc = u32::from_be_bytes(self.rest.get(8 + len..12 + len)?.try_into().ok()?);
        if crc32fast::hash(body) != crc {
            return None;
        }
        self.rest = &self.rest[12 + len..];
        Some((body[..4].try_into().ok()?, &body[4..]))
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    proptest! {
        /// The dispatched Sub (SSSE3 where the CPU has it) against the scalar loop, on rows of
        /// every length up to 120 pixels.
        #[test]
        fn unsub_equals_the_scalar_loop(row in prop::collection::vec(any::<u8>(), 0..120)
            .prop_map(|mut r| { r.truncate(r.len() / 3 * 3); r })) {
            let (mut fast, mut slow) = (vec![9u8; row.len()], vec![7u8; row.len()]);
            super::unsub(&row, &mut fast);
            super::unsub_scalar(&row, &mut slow, [0; 3]);
            prop_assert_eq!(fast, slow);
        }
    }

    #[test]
    fn unsub_undoes_the_sub_filter() {
        let image: Vec<u8> = (0..3 * 97u32).map(|i| (i * 37 % 256) as u8).collect();
        let filtered: Vec<u8> = (0..image.len())
            .map(|i| image[i].wrapping_sub(if i >= 3 { image[i - 3] } else { 0 }))
            .collect();
        let mut back = vec![0u8; image.len()];
        super::unsub(&filtered, &mut back);
        assert_eq!(back, image);
    }

    #[test]
    fn paeth_predictor_equals_the_specification_for_every_input() {
        for a in 0..=255u8 {
            for b in 0..=255u8 {
                for c in 0..=255u8 {
                    let p = a as i16 + b as i16 - c as i16;
                    let (pa, pb, pc) = (
                        (p - a as i16).abs(),
                        (p - b as i16).abs(),
                        (p - c as i16).abs(),
                    );
                    let spec = if pa <= pb && pa <= pc {
                        a
                    } else if pb <= pc {
                        b
                    } else {
                        c
                    };
                    assert_eq!(super::paeth(a, b, c), spec, "a={a} b={b} c={c}");
                }
            }
        }
    }
}
