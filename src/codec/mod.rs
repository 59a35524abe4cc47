//! Image file formats: PNG (read and write, with a direct fast path for KITTI's 8-bit RGB),
//! JPEG (read), and TIFF and WebP (read, through the `image` crate) for folder inputs.

pub mod general;
pub mod jpeg;
pub mod png;

use crate::error::Result;
use crate::image::RgbImage;
use std::path::Path;

/// Largest image accepted in any format, checked on the header before the pixels are
/// decoded (a 16384x8192 panorama is 134 Mpx).
pub const MAX_PIXELS: u64 = 150_000_000;

/// The lower-case extensions of the image files panoconv reads.
pub const READABLE_EXTENSIONS: [&str; 6] = ["png", "jpg", "jpeg", "tif", "tiff", "webp"];

/// Whether `path` names an image file panoconv reads (by its extension, any case).
pub fn is_readable_image(path: &Path) -> bool {
    READABLE_EXTENSIONS.contains(&lower_extension(path).as_str())
}

/// Decodes an image file to RGB8 with the decoder its extension names (PNG when in doubt);
/// failures name `path`.
pub fn decode_rgb8(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    match lower_extension(path).as_str() {
        "jpg" | "jpeg" => jpeg::decode_rgb8(bytes, path),
        e if general::EXTENSIONS.contains(&e) => general::decode_rgb8(bytes, path),
        _ => png::decode_rgb8(bytes, path),
    }
}

fn lower_extension(path: &Path) -> String {
    path.extension()
        .map(|x| x.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}
