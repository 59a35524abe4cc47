//! The PNG signature and header (IHDR): one reader for every place that needs an image's size or
//! sample layout without decoding it.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// The 8 bytes every PNG file starts with.
pub const SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];

/// Bytes from the file's start to the end of the IHDR chunk.
const HEADER_LEN: usize = 33;

/// A PNG colour type (IHDR byte 9).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ColourType {
    /// Grey samples.
    Grey = 0,
    /// Red, green, blue samples.
    Rgb = 2,
    /// Indices into a palette.
    Palette = 3,
    /// Grey and alpha samples.
    GreyAlpha = 4,
    /// Red, green, blue and alpha samples.
    Rgba = 6,
}

impl ColourType {
    fn from_byte(byte: u8) -> Option<Self> {
        Some(match byte {
            0 => Self::Grey,
            2 => Self::Rgb,
            3 => Self::Palette,
            4 => Self::GreyAlpha,
            6 => Self::Rgba,
            _ => return None,
        })
    }

    /// Whether `depth` bits per sample is allowed with this colour type (PNG spec, table 11.1).
    fn allows(self, depth: u8) -> bool {
        match self {
            Self::Grey => matches!(depth, 1 | 2 | 4 | 8 | 16),
            Self::Palette => matches!(depth, 1 | 2 | 4 | 8),
            Self::Rgb | Self::GreyAlpha | Self::Rgba => matches!(depth, 8 | 16),
        }
    }
}

/// What a PNG's IHDR chunk says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageHeader {
    /// Width in pixels (positive).
    pub width: u32,
    /// Height in pixels (positive).
    pub height: u32,
    /// Bits per sample.
    pub bit_depth: u8,
    /// How samples make a pixel.
    pub colour: ColourType,
    /// Adam7 interlacing.
    pub interlaced: bool,
}

/// Parses the signature and the IHDR chunk at the start of `bytes` (its first 33 bytes);
/// `None` unless they form a valid header (checksum, sizes, a legal colour type and depth).
pub fn read_header(bytes: &[u8]) -> Option<ImageHeader> {
    let head = bytes.get(..HEADER_LEN)?;
    let be = |at: usize| u32::from_be_bytes(head[at..at + 4].try_into().expect("4 bytes"));
    if head[..8] != SIGNATURE || be(8) != 13 || head[12..16] != *b"IHDR" {
        return None;
    }
    if crc32fast::hash(&head[12..29]) != be(29) {
        return None;
    }
    let (width, height) = (be(16), be(20));
    let colour = ColourType::from_byte(head[25])?;
    let bit_depth = head[24];
    let valid = (1..=i32::MAX as u32).contains(&width)
        && (1..=i32::MAX as u32).contains(&height)
        && colour.allows(bit_depth)
        && head[26] == 0
        && head[27] == 0
        && head[28] <= 1;
    valid.then_some(ImageHeader {
        width,
        height,
        bit_depth,
        colour,
        interlaced: head[28] == 1,
    })
}

/// The image size from the header of a PNG held in `bytes`; an undecodable header is reported
/// with the png crate's reason, tagged with `path`.
pub fn read_size(bytes: &[u8], path: &Path) -> Result<(u32, u32)> {
    if let Some(h) = read_header(bytes) {
        return Ok((h.width, h.height));
    }
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let reader = decoder
        .read_info()
        .map_err(|e| Error::file(path, format!("cannot decode PNG: {e}")))?;
    Ok((reader.info().width, reader.info().height))
}

/// The image size of the PNG file at `path`, reading only its start (the whole file only when
/// the header is not valid, for the png crate's reason).
pub fn read_file_size(path: &Path) -> Result<(u32, u32)> {
    let mut head = Vec::with_capacity(HEADER_LEN);
    std::fs::File::open(path)
        .and_then(|f| f.take(HEADER_LEN as u64).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    match read_header(&head) {
        Some(h) => Ok((h.width, h.height)),
        None => read_size(&crate::fs::read_file(path)?, path),
    }
}
