//! A PNG source warped straight from its compressed rows into the PNG encoder.
//!
//! [`PngSource`] holds a source PNG whose header and chunks are checked but whose pixels are
//! not decoded yet. Its first warp decodes the source a band of rows at a time, just ahead of
//! the output row that reads them, so every source row is read by the remap moments after it
//! is unfiltered, while it is still in the core's cache, and each output row is filtered and
//! deflated as it is made. The decoded image is kept for further warps of the same source
//! (`--augment` views). Files the direct decoder does not take are decoded whole by the png
//! crate at once, so their errors come when the file is read; a stream found damaged while
//! warping falls back to the png crate, whose error names the file, and nothing of the warp
//! is kept.

use super::RemapTable;
use crate::codec::png::{self, decode::RowDecoder, PngCompression};
use crate::codec::MAX_PIXELS;
use crate::error::Result;
use crate::image::RgbImage;
use std::path::{Path, PathBuf};

thread_local! {
    /// The pixel buffer of the last source image this thread dropped, decoded into by the
    /// next one: no megabyte zeroed and faulted in each frame.
    static SPARE: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// A source image read from a PNG file, decoded by its first warp (see the module's notes).
pub struct PngSource {
    state: State,
}

enum State {
    /// The file's bytes (for the png crate's error, should the stream be damaged) and the
    /// decoder, nothing inflated yet.
    Pending {
        bytes: Vec<u8>,
        path: PathBuf,
        decoder: Box<RowDecoder>,
    },
    Decoded(RgbImage),
}

impl PngSource {
    /// Takes a PNG file's bytes: checked and left undecoded where the direct decoder takes
    /// them, decoded at once (and any error returned now) where it does not.
    pub fn new(bytes: Vec<u8>, path: &Path) -> Result<PngSource> {
        let spare = SPARE.with_borrow_mut(std::mem::take);
        let state = match RowDecoder::with_buffer(&bytes, MAX_PIXELS, spare) {
            Some(decoder) => State::Pending {
                bytes,
                path: path.to_owned(),
                decoder: Box::new(decoder),
            },
            None => State::Decoded(png::decode_rgb8_with_png_crate(&bytes, path)?),
        };
        Ok(PngSource { state })
    }

    /// (width, height) in pixels.
    pub fn size(&self) -> (u32, u32) {
        match &self.state {
            State::Pending { decoder, .. } => decoder.size(),
            State::Decoded(img) => (img.width(), img.height()),
        }
    }

    /// The whole image, decoded.
    pub fn decode(mut self) -> Result<RgbImage> {
        match std::mem::replace(&mut self.state, State::Decoded(RgbImage::new(0, 0))) {
            State::Decoded(img) => Ok(img),
            State::Pending {
                bytes,
                path,
                decoder,
            } => match decoder.finish() {
                Some((w, h, data)) => Ok(RgbImage::from_raw(w, h, data).expect("w · h · 3 bytes")),
                None => png::decode_rgb8_with_png_crate(&bytes, &path),
            },
        }
    }

    /// The PNG file of the source warped through `table` (whose source size must be this
    /// image's), encoded with compression `c`: the same bytes as encoding
    /// `table.apply(&image)`.
    pub fn warp_encode(&mut self, table: &RemapTable, c: PngCompression) -> Result<Vec<u8>> {
        let State::Pending { decoder, .. } = &mut self.state else {
            let State::Decoded(img) = &self.state else {
                unreachable!("not pending")
            };
            return Ok(warp_encode(table, img, c));
        };
        let size = table.size();
        let mut damaged = false;
        // a table sampling the source's pyramid reads it from its first row: the source is
        // decoded whole and the pyramid built once, then the rows warped from it
        let mut pyramid = None;
        let encoded = png::encode_rgb8_rows(size.width, size.height, c, |v, row| {
            if damaged {
                return;
            }
            if table.levels() <= 1 {
                match decoder.decode_rows(table.source_rows(v)) {
                    Some(()) => table.apply_row_data(decoder.image(), v, row),
                    None => damaged = true,
                }
                return;
            }
            if pyramid.is_none() {
                match decoder.decode_rows(decoder.size().1 as usize) {
                    Some(()) => pyramid = Some(table.input(decoder.image()).into_owned()),
                    None => {
                        damaged = true;
                        return;
                    }
                }
            }
            table.apply_row_data(pyramid.as_deref().expect("built above"), v, row);
        });
        let placeholder = State::Decoded(RgbImage::new(0, 0));
        let State::Pending {
            bytes,
            path,
            decoder,
        } = std::mem::replace(&mut self.state, placeholder)
        else {
            unreachable!("pending above")
        };
        let decoded = if damaged { None } else { decoder.finish() };
        match decoded {
            Some((w, h, data)) => {
                self.state =
                    State::Decoded(RgbImage::from_raw(w, h, data).expect("w · h · 3 bytes"));
                Ok(encoded)
            }
            None => {
                // The png crate decides: its error, or (for a file the direct decoder refuses
                // only once inflating) the image, warped again from it.
                let img = png::decode_rgb8_with_png_crate(&bytes, &path)?;
                let out = warp_encode(table, &img, c);
                self.state = State::Decoded(img);
                Ok(out)
            }
        }
    }
}

/// Warps `src` row by row as the PNG encoder takes the rows, so that the warped image never
/// has to exist whole.
pub fn warp_encode(table: &RemapTable, src: &RgbImage, c: PngCompression) -> Vec<u8> {
    let size = table.size();
    // (the source's pyramid, where the table samples one, built once)
    let input = table.input(src.as_raw());
    png::encode_rgb8_rows(size.width, size.height, c, |v, row| {
        table.apply_row_data(&input, v, row)
    })
}

impl Drop for PngSource {
    fn drop(&mut self) {
        if let State::Decoded(img) =
            std::mem::replace(&mut self.state, State::Decoded(RgbImage::new(0, 0)))
        {
            let buffer = img.into_raw();
            SPARE.with_borrow_mut(|spare| {
                if spare.capacity() < buffer.capacity() {
                    *spare = buffer;
                }
            });
        }
    }
}
