//! A direct decoder for the common PNG: 8-bit RGB, not interlaced (every KITTI image).
//!
//! The IDAT stream is inflated with fdeflate (the png crate's own inflater) in one call into
//! one buffer, and the rows are unfiltered in place into the image: none of the png crate's
//! per-row copies, buffer compaction or streaming state. It accepts only files it is sure of:
//! anything else (another pixel format, interlacing, a bad checksum, a truncated or overlong
//! stream, chunks out of order, tRNS) returns `None` and the caller decodes with the png
//! crate, whose errors panoconv reports. `tests/png.rs` checks the pixels equal the png
//! crate's.

use super::ColourType;
use std::cell::RefCell;

/// Bytes from the file's start to the end of the IHDR chunk.
const HEADER_LEN: usize = 33;

thread_local! {
    /// The IDAT data of the frame being decoded, gathered into one stream (a camera PNG has
    /// many small IDAT chunks), kept per thread so it is not allocated and grown each frame.
    static STREAM: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
}

/// The image's (width, height, RGB bytes), or `None` when this decoder does not take the file.
/// `max_pixels` bounds what the header may ask for.
pub fn decode_rgb8(bytes: &[u8], max_pixels: u64) -> Option<(u32, u32, Vec<u8>)> {
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
    let mut chunks = Chunks {
        rest: &bytes[HEADER_LEN..],
    };
    STREAM.with_borrow_mut(|stream| {
        stream.clear();
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
        inflate_and_unfilter(stream, width, height)
    })
}

fn inflate_and_unfilter(stream: &[u8], width: u32, height: u32) -> Option<(u32, u32, Vec<u8>)> {
    let len = width as usize * 3;
    let h = height as usize;
    let raw_len = (len + 1).checked_mul(h)?;
    let mut buf = vec![0u8; raw_len];
    let mut inflater = fdeflate::Decompressor::new();
    // as the png crate: the IDAT chunks' CRCs already protect the data
    inflater.ignore_adler32();
    // All but the last byte first: fdeflate sums the adler32 of whatever the call that
    // reaches the checksum produced, ignored or not, and that should be one byte, not the
    // whole image.
    let (used, produced) = inflater
        .read(stream, &mut buf[..raw_len - 1], 0, true)
        .ok()?;
    if produced != raw_len - 1 {
        return None;
    }
    let (rest, last) = inflater
        .read(&stream[used..], &mut buf, produced, true)
        .ok()?;
    if last != 1 || !inflater.is_done() || used + rest != stream.len() {
        return None;
    }
    // Row r's filtered bytes sit at r·(len + 1) + 1; its pixels go to r·len, below them, so
    // the rows move down in order and each is unfiltered against the one before it.
    for r in 0..h {
        let filter = buf[r * (len + 1)];
        let src = r * (len + 1) + 1;
        buf.copy_within(src..src + len, r * len);
        let (done, rest) = buf.split_at_mut(r * len);
        let cur = &mut rest[..len];
        let prev = if r == 0 {
            None
        } else {
            Some(&done[(r - 1) * len..])
        };
        unfilter(filter, prev, cur)?;
    }
    buf.truncate(len * h);
    Some((width, height, buf))
}

/// Undoes PNG filter `filter` on `cur` (3 bytes a pixel) given the row above (`None`: zeros).
/// Each pixel is handled as a 3-byte array, which the compiler keeps in registers.
fn unfilter(filter: u8, prev: Option<&[u8]>, cur: &mut [u8]) -> Option<()> {
    let pixel = |px: &mut [u8], new: [u8; 3]| px.copy_from_slice(&new);
    match (filter, prev) {
        (0, _) | (2, None) => {}
        (1, _) | (4, None) => {
            let mut a = [0u8; 3];
            for px in cur.chunks_exact_mut(3) {
                a = [
                    px[0].wrapping_add(a[0]),
                    px[1].wrapping_add(a[1]),
                    px[2].wrapping_add(a[2]),
                ];
                pixel(px, a);
            }
        }
        (2, Some(prev)) => {
            for (x, b) in cur.iter_mut().zip(prev) {
                *x = x.wrapping_add(*b);
            }
        }
        (3, None) => {
            let mut a = [0u8; 3];
            for px in cur.chunks_exact_mut(3) {
                a = [
                    px[0].wrapping_add(a[0] / 2),
                    px[1].wrapping_add(a[1] / 2),
                    px[2].wrapping_add(a[2] / 2),
                ];
                pixel(px, a);
            }
        }
        (3, Some(prev)) => {
            let avg = |a: u8, b: u8| ((a as u16 + b as u16) / 2) as u8;
            let mut a = [0u8; 3];
            for (px, b) in cur.chunks_exact_mut(3).zip(prev.chunks_exact(3)) {
                a = [
                    px[0].wrapping_add(avg(a[0], b[0])),
                    px[1].wrapping_add(avg(a[1], b[1])),
                    px[2].wrapping_add(avg(a[2], b[2])),
                ];
                pixel(px, a);
            }
        }
        (4, Some(prev)) => {
            let (mut a, mut c) = ([0u8; 3], [0u8; 3]);
            for (px, b) in cur.chunks_exact_mut(3).zip(prev.chunks_exact(3)) {
                a = [
                    px[0].wrapping_add(paeth(a[0], b[0], c[0])),
                    px[1].wrapping_add(paeth(a[1], b[1], c[1])),
                    px[2].wrapping_add(paeth(a[2], b[2], c[2])),
                ];
                pixel(px, a);
                c = [b[0], b[1], b[2]];
            }
        }
        _ => return None,
    }
    Some(())
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
