//! The formats panoconv reads through the `image` crate (TIFF, WebP): folder inputs only, where
//! a general decoder serves; PNG and JPEG keep panoconv's own paths (KITTI's PNGs are the hot
//! path, and the JPEG decoder's pixels are what existing outputs were made from).

use crate::codec::MAX_PIXELS;
use crate::error::{Error, Result};
use crate::image::RgbImage;
use std::path::Path;

/// File extensions (lower case) decoded here.
pub const EXTENSIONS: [&str; 3] = ["tif", "tiff", "webp"];

/// Decodes a TIFF or WebP (8 or 16 bits, grey or colour, with or without alpha) to RGB8,
/// tagging failures with `path`: alpha is dropped, 16-bit samples are rounded to 8 bits. The
/// size is checked against the same pixel limit as PNGs before the pixels are decoded.
pub fn decode_rgb8(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    let bad = |e: String| Error::file(path, format!("cannot decode image: {e}"));
    let reader = ::image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| bad(e.to_string()))?;
    let (w, h) = reader.into_dimensions().map_err(|e| bad(e.to_string()))?;
    if w == 0 || h == 0 || w as u64 * h as u64 > MAX_PIXELS {
        return Err(bad(format!("{w}x{h} is outside panoconv's limits")));
    }
    let decoded = ::image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| bad(e.to_string()))?
        .decode()
        .map_err(|e| bad(e.to_string()))?
        .into_rgb8();
    RgbImage::from_raw(w, h, decoded.into_raw())
        .ok_or_else(|| bad("decoded data does not match the image size".into()))
}
