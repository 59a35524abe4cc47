//! JPEG decoding to RGB8, for panorama and fisheye inputs (KITTI itself is PNG).

use crate::codec::MAX_PIXELS;
use crate::error::{Error, Result};
use crate::image::RgbImage;
use std::path::Path;
use zune_core::colorspace::ColorSpace;
use zune_core::options::DecoderOptions;
use zune_jpeg::JpegDecoder;

/// Decodes a JPEG (baseline or progressive, grey or colour) to RGB8, tagging failures with
/// `path`. The header's size is checked against the same pixel limit as PNGs before decoding.
///
/// A truncated file is an error: the decoder alone fills the rows past the cut with grey and
/// says nothing, so the file's segments are first walked to its end-of-image marker
/// ([`check_complete`]); the decoder's strict mode makes the damage it notices (a marker
/// inside the image data, a premature end) an error too.
pub fn decode_rgb8(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    let bad = |e: String| Error::file(path, format!("cannot decode JPEG: {e}"));
    check_complete(bytes).map_err(bad)?;
    let side = (MAX_PIXELS as f64).sqrt() as usize * 4;
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
        .set_strict_mode(true)
        .set_max_width(side)
        .set_max_height(side);
    let mut decoder = JpegDecoder::new_with_options(bytes, options);
    decoder
        .decode_headers()
        .map_err(|e| bad(format!("{e:?}")))?;
    let info = decoder
        .info()
        .ok_or_else(|| bad("no image header".into()))?;
    let (w, h) = (info.width as u32, info.height as u32);
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_PIXELS {
        return Err(bad(format!("{w}x{h} is outside panoconv's limits")));
    }
    let mut pixels = decoder.decode().map_err(|e| bad(format!("{e:?}")))?;
    // zune-jpeg decodes a grey image to one channel whatever colour space was asked for
    if pixels.len() == w as usize * h as usize {
        pixels = pixels.iter().flat_map(|&g| [g, g, g]).collect();
    }
    RgbImage::from_raw(w, h, pixels)
        .ok_or_else(|| bad("decoded data does not match the image size".into()))
}

/// Walks a JPEG's segments and image data from its start-of-image marker to its end-of-image
/// marker (bytes after it are ignored, as decoders do); `Err` says where a truncated file
/// ends. Segments are skipped by their lengths, so an embedded thumbnail's markers are not
/// taken for the file's own.
pub fn check_complete(bytes: &[u8]) -> std::result::Result<(), String> {
    let truncated = |at: usize| {
        format!("the file is truncated: its {at} bytes end before its end-of-image marker (FF D9)")
    };
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return Err("no start-of-image marker (FF D8)".into());
    }
    let mut at = 2;
    loop {
        // the next marker: fill bytes (FF) before it are allowed, stray bytes are skipped
        while at < bytes.len() && bytes[at] != 0xFF {
            at += 1;
        }
        while at < bytes.len() && bytes[at] == 0xFF {
            at += 1;
        }
        let Some(&marker) = bytes.get(at) else {
            return Err(truncated(bytes.len()));
        };
        at += 1;
        match marker {
            0xD9 => return Ok(()),
            0x01 | 0xD0..=0xD7 => continue,
            _ => {}
        }
        let len = match bytes.get(at..at + 2) {
            Some(l) => u16::from_be_bytes([l[0], l[1]]) as usize,
            None => return Err(truncated(bytes.len())),
        };
        if at + len > bytes.len() {
            return Err(truncated(bytes.len()));
        }
        at += len;
        if marker == 0xDA {
            at = end_of_scan(bytes, at).ok_or_else(|| truncated(bytes.len()))?;
        }
    }
}

/// Where a scan's entropy-coded data that starts at `at` ends: at the first marker other than
/// a stuffed zero or a restart marker; `None` when the file ends first.
fn end_of_scan(bytes: &[u8], mut at: usize) -> Option<usize> {
    loop {
        at += bytes.get(at..)?.iter().position(|&b| b == 0xFF)?;
        match *bytes.get(at + 1)? {
            0x00 | 0xD0..=0xD7 | 0xFF => at += 1,
            _ => return Some(at),
        }
    }
}
