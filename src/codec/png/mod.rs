//! PNG decoding to RGB8 (8/16-bit, grey/grey+alpha/RGB/RGBA/palette) and encoding.

pub mod decode;
mod deflate;
mod encode;
mod header;

pub use header::{read_file_size, read_header, read_size, ColourType, ImageHeader, SIGNATURE};

use crate::error::{Error, Result};
use crate::image::RgbImage;
use encode::{encode_rows, Header, RowFilter};
use std::path::Path;

pub use super::MAX_PIXELS;

/// How hard the PNG encoder works: files are smaller or written faster.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PngCompression {
    /// fdeflate with the Sub filter on every row: the cheapest filter.
    Fast,
    /// fdeflate with the Paeth filter on every row: on KITTI images smaller than zlib's levels
    /// and about 30 times faster (docs/performance.md).
    #[default]
    Default,
    /// zlib level 9 with adaptive filtering (the png crate): far slower and no smaller on
    /// camera images; `panoconv synth` writes the shipped sample with it.
    Best,
}

/// Decodes a PNG, tagging any failure with `path`. Alpha is dropped (KITTI images are opaque);
/// 16-bit samples are rounded to 8 bits.
pub fn decode_rgb8(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    if let Some((width, height, data)) = decode::decode_rgb8(bytes, MAX_PIXELS) {
        return Ok(RgbImage::from_raw(width, height, data).expect("width · height · 3 bytes"));
    }
    decode_rgb8_with_png_crate(bytes, path)
}

/// As [`decode_rgb8`], always with the png crate (every pixel format; the error messages).
#[doc(hidden)]
pub fn decode_rgb8_with_png_crate(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    let bad = |e: String| Error::file(path, format!("cannot decode PNG: {e}"));
    if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return Err(bad(
            "the file is a JPEG (it starts with JPEG's FF D8 FF), not a PNG: KITTI images are PNG, convert it"
                .into(),
        ));
    }
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    // The png crate's default 64 MiB would refuse panoramas that MAX_PIXELS allows (the size
    // is checked against MAX_PIXELS below, before anything is allocated).
    decoder.set_limits(png::Limits {
        bytes: (MAX_PIXELS * 8) as usize,
    });
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| bad(e.to_string()))?;
    let (width, height) = {
        let info = reader.info();
        (info.width, info.height)
    };
    if width == 0 || height == 0 {
        return Err(bad("empty image".into()));
    }
    // The header is untrusted: refuse before allocating for it.
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(bad(format!(
            "{width}x{height} is larger than panoconv's limit of {} megapixels",
            MAX_PIXELS / 1_000_000
        )));
    }
    let mut buf = vec![0; reader.output_buffer_size()];
    let frame = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    if frame.color_type == png::ColorType::Rgb && frame.bit_depth == png::BitDepth::Eight {
        // The common case (KITTI): the decoded buffer is the image, no copy.
        buf.truncate(frame.buffer_size());
        return RgbImage::from_raw(width, height, buf)
            .ok_or_else(|| bad("truncated image data".into()));
    }
    let buf = &buf[..frame.buffer_size()];
    let channels = frame.color_type.samples();
    let wide = frame.bit_depth == png::BitDepth::Sixteen;
    let sample = |i: usize| -> u8 {
        if wide {
            let v = u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]) as u32;
            ((v * 255 + 32767) / 65535) as u8
        } else {
            buf[i]
        }
    };
    let n = width as usize * height as usize;
    let mut out = Vec::with_capacity(n * 3);
    match channels {
        1 | 2 => {
            for p in 0..n {
                let g = sample(p * channels);
                out.extend_from_slice(&[g, g, g]);
            }
        }
        3 | 4 => {
            if channels == 3 && !wide {
                out.extend_from_slice(buf);
            } else {
                for p in 0..n {
                    out.extend_from_slice(&[
                        sample(p * channels),
                        sample(p * channels + 1),
                        sample(p * channels + 2),
                    ]);
                }
            }
        }
        c => return Err(bad(format!("unsupported channel count {c}"))),
    }
    RgbImage::from_raw(width, height, out).ok_or_else(|| bad("truncated image data".into()))
}

fn encoder_settings(
    c: PngCompression,
) -> (png::Compression, png::FilterType, png::AdaptiveFilterType) {
    match c {
        PngCompression::Fast => (
            png::Compression::Fast,
            png::FilterType::Sub,
            png::AdaptiveFilterType::NonAdaptive,
        ),
        // Measured on KITTI (docs/performance.md): fdeflate with Paeth on every row is as small
        // as the adaptive choice (which picks Paeth almost everywhere) at less cost, 0.93x the
        // bytes of OpenCV's default; zlib levels are 30x slower and no smaller.
        PngCompression::Default => (
            png::Compression::Fast,
            png::FilterType::Paeth,
            png::AdaptiveFilterType::NonAdaptive,
        ),
        PngCompression::Best => (
            png::Compression::Best,
            png::FilterType::Paeth,
            png::AdaptiveFilterType::Adaptive,
        ),
    }
}

/// Encodes with the streamed fdeflate encoder ([`encode_rows`]) for `fast` and `default`,
/// with the png crate for `best`.
fn encode(header: Header, data: &[u8], c: PngCompression) -> Vec<u8> {
    match row_filter(c) {
        Some(filter) => {
            let len = header.width as usize * header.bpp;
            encode_rows(header, filter, |v, row| {
                row.copy_from_slice(&data[v * len..(v + 1) * len])
            })
        }
        None => encode_with_png_crate(header, data, c),
    }
}

/// The row filter of the fdeflate presets (streamed by [`encode_rows`]); `None` for `best`.
fn row_filter(c: PngCompression) -> Option<RowFilter> {
    match c {
        PngCompression::Fast => Some(RowFilter::Sub),
        PngCompression::Default => Some(RowFilter::Paeth),
        PngCompression::Best => None,
    }
}

/// The png crate's encoder with the settings of `c` (for `fast` and `default`, the reference
/// that `tests/png.rs` compares the streamed encoder with).
fn encode_with_png_crate(header: Header, data: &[u8], c: PngCompression) -> Vec<u8> {
    let (color, depth) = match header.colour {
        ColourType::Rgb => (png::ColorType::Rgb, png::BitDepth::Eight),
        _ => (png::ColorType::Grayscale, png::BitDepth::Sixteen),
    };
    // Room for a typical camera image (about half its raw size) up front: growing the Vec by
    // doubling copied the encoded bytes several times over.
    let mut out = Vec::with_capacity(data.len() / 2 + 4096);
    {
        let mut enc = png::Encoder::new(&mut out, header.width, header.height);
        enc.set_color(color);
        enc.set_depth(depth);
        let (comp, filter, adaptive) = encoder_settings(c);
        enc.set_compression(comp);
        enc.set_filter(filter);
        enc.set_adaptive_filter(adaptive);
        // Writing into a Vec cannot fail for a well-formed header and a buffer of the right size.
        let mut w = enc.write_header().expect("PNG header for a valid size");
        w.write_image_data(data)
            .expect("PNG data of the declared size");
    }
    out
}

/// The PNG file bytes of an RGB8 image encoded with compression `c`.
pub fn encode_rgb8(img: &RgbImage, c: PngCompression) -> Vec<u8> {
    encode(Header::rgb8(img.width(), img.height()), img.as_raw(), c)
}

/// Encodes a `width` × `height` RGB8 image whose row `v` is written by `fill(v, row)`: for
/// `fast` and `default` row by row as the encoder takes them (the image never exists whole),
/// for `best` gathered first for the png crate. Same bytes as [`encode_rgb8`] of the image.
pub fn encode_rgb8_rows(
    width: u32,
    height: u32,
    c: PngCompression,
    mut fill: impl FnMut(usize, &mut [u8]),
) -> Vec<u8> {
    let header = Header::rgb8(width, height);
    match row_filter(c) {
        Some(filter) => encode_rows(header, filter, fill),
        None => {
            let len = header.width as usize * 3;
            let mut data = vec![0u8; len * header.height as usize];
            if len > 0 {
                for (v, row) in data.chunks_exact_mut(len).enumerate() {
                    fill(v, row);
                }
            }
            encode_with_png_crate(header, &data, c)
        }
    }
}

/// As [`encode_rgb8`], always with the png crate's encoder (for tests).
#[doc(hidden)]
pub fn encode_rgb8_with_png_crate(img: &RgbImage, c: PngCompression) -> Vec<u8> {
    encode_with_png_crate(Header::rgb8(img.width(), img.height()), img.as_raw(), c)
}

/// 16-bit greyscale (depth maps).
pub fn encode_gray16(width: u32, height: u32, values: &[u16], c: PngCompression) -> Vec<u8> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    encode(Header::gray16(width, height), &bytes, c)
}

/// A 1-bit greyscale PNG: white where `set(u, v)`, black elsewhere (masks).
pub fn encode_mask(width: u32, height: u32, set: impl Fn(u32, u32) -> bool) -> Vec<u8> {
    let stride = (width as usize).div_ceil(8);
    let mut bits = vec![0u8; stride * height as usize];
    for v in 0..height {
        let row = &mut bits[v as usize * stride..(v as usize + 1) * stride];
        for u in 0..width {
            if set(u, v) {
                row[u as usize / 8] |= 0x80 >> (u % 8);
            }
        }
    }
    let mut out = Vec::with_capacity(bits.len() / 4 + 256);
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::One);
        enc.set_compression(png::Compression::Default);
        // Writing into a Vec cannot fail for a valid size and a buffer of the right length.
        let mut w = enc.write_header().expect("PNG header for a valid size");
        w.write_image_data(&bits)
            .expect("PNG data of the declared size");
    }
    out
}

/// As [`encode_gray16`], always with the png crate's encoder (for tests).
#[doc(hidden)]
pub fn encode_gray16_with_png_crate(
    width: u32,
    height: u32,
    values: &[u16],
    c: PngCompression,
) -> Vec<u8> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    encode_with_png_crate(Header::gray16(width, height), &bytes, c)
}

/// Decodes a 16-bit greyscale PNG (depth maps).
pub fn decode_gray16(bytes: &[u8], path: &Path) -> Result<(u32, u32, Vec<u16>)> {
    let bad = |e: String| Error::file(path, format!("cannot decode 16-bit PNG: {e}"));
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().map_err(|e| bad(e.to_string()))?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let frame = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    if frame.color_type != png::ColorType::Grayscale || frame.bit_depth != png::BitDepth::Sixteen {
        return Err(bad(format!(
            "expected 16-bit grey, found {:?} {:?}",
            frame.color_type, frame.bit_depth
        )));
    }
    let values = buf[..frame.buffer_size()]
        .chunks_exact(2)
        .map(|c| u16::from_be_bytes([c[0], c[1]]))
        .collect();
    Ok((frame.width, frame.height, values))
}
