//! An 8-bit greyscale PNG (the source map), through the png crate.

/// The PNG of a `width` × `height` 8-bit greyscale image (row-major `values`).
pub(super) fn encode_gray8(width: u32, height: u32, values: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(values.len() / 8 + 256);
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Default);
        // Writing into a Vec cannot fail for a valid size and a buffer of the right length.
        let mut w = enc.write_header().expect("PNG header for a valid size");
        w.write_image_data(values)
            .expect("PNG data of the declared size");
    }
    out
}
