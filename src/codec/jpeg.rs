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
pub fn decode_rgb8(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    let bad = |e: String| Error::file(path, format!("cannot decode JPEG: {e}"));
    let side = (MAX_PIXELS as f64).sqrt() as usize * 4;
    let options = DecoderOptions::default()
        .jpeg_set_out_colorspace(ColorSpace::RGB)
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
    let pixels = decoder.decode().map_err(|e| bad(format!("{e:?}")))?;
    RgbImage::from_raw(w, h, pixels)
        .ok_or_else(|| bad("decoded data does not match the image size".into()))
}
