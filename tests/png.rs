//! The streamed PNG encoder (`fast`, `default`) against the png crate's encoder with the same
//! settings: byte-identical files, on real KITTI frames, odd sizes, 16-bit grey and an
//! incompressible image (the stored fallback), and every file decodes back to its pixels.
//! The direct RGB8 decoder against the png crate's decoder: the same pixels for every filter
//! type and every encoder, and files it must not take are left to the png crate.

use crate::common;

use panoconv::codec::png::decode;
use panoconv::codec::png::{
    decode_gray16, decode_rgb8, decode_rgb8_with_png_crate, encode_gray16,
    encode_gray16_with_png_crate, encode_rgb8, encode_rgb8_with_png_crate, PngCompression,
    MAX_PIXELS,
};
use panoconv::image::RgbImage;
use std::path::Path;

const PRESETS: [PngCompression; 2] = [PngCompression::Fast, PngCompression::Default];

/// A deterministic pseudo-random byte stream (xorshift), for noise and gradients with noise.
fn noise(seed: u64, n: usize) -> Vec<u8> {
    let mut x = seed | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect()
}

/// A smooth image with a little noise: what camera images look like to a PNG filter.
fn camera_like(w: u32, h: u32, seed: u64) -> RgbImage {
    let n = noise(seed, (w * h * 3) as usize);
    let data = (0..(w * h * 3) as usize)
        .map(|i| {
            let (p, c) = (i / 3, i % 3);
            let (x, y) = ((p as u32 % w) as usize, (p as u32 / w) as usize);
            ((x * 3 + y * 2 + c * 40) as u8).wrapping_add(n[i] % 5)
        })
        .collect();
    RgbImage::from_raw(w, h, data).expect("size")
}

fn assert_same_rgb(img: &RgbImage, what: &str) {
    for c in PRESETS {
        let streamed = encode_rgb8(img, c);
        let reference = encode_rgb8_with_png_crate(img, c);
        assert!(
            streamed == reference,
            "{what} ({}x{}, {c:?}): {} bytes streamed, {} from the png crate",
            img.width(),
            img.height(),
            streamed.len(),
            reference.len()
        );
        let back = decode_rgb8(&streamed, Path::new(what)).expect("decodes");
        assert!(
            back.as_raw() == img.as_raw(),
            "{what} {c:?}: pixels changed"
        );
    }
}

#[test]
fn streamed_encoder_equals_the_png_crate_on_kitti_frames() {
    let dir = common::real_kitti().join("training/image_2");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    files.sort();
    assert!(files.len() >= 3, "KITTI frames in {}", dir.display());
    for path in files.iter().take(3) {
        let img = decode_rgb8(&std::fs::read(path).expect("read"), path).expect("decode");
        assert_same_rgb(&img, &path.display().to_string());
    }
}

#[test]
fn streamed_encoder_equals_the_png_crate_at_odd_sizes() {
    // one pixel, one row, one column, widths around the filters' 32-byte steps
    for (i, (w, h)) in [(1, 1), (1, 7), (9, 1), (10, 3), (11, 4), (33, 5), (129, 17)]
        .into_iter()
        .enumerate()
    {
        assert_same_rgb(&camera_like(w, h, i as u64 + 1), "odd size");
    }
}

#[test]
fn incompressible_images_fall_back_to_stored_blocks_like_the_png_crate() {
    let (w, h) = (257, 64);
    let img = RgbImage::from_raw(w, h, noise(99, (w * h * 3) as usize)).expect("size");
    let raw = (w as usize * 3 + 1) * h as usize;
    let streamed = encode_rgb8(&img, PngCompression::Fast);
    // Stored blocks: the raw rows plus 5 bytes a block, zlib and PNG framing; deflate of
    // uniform noise is larger than that, so this checks the fallback was taken.
    assert!(
        streamed.len() < raw + raw / 1000 + 100,
        "{} bytes for {raw} raw: not the stored fallback",
        streamed.len()
    );
    assert_same_rgb(&img, "noise");
}

#[test]
fn streamed_gray16_equals_the_png_crate() {
    let (w, h) = (203, 41);
    let values: Vec<u16> = (0..w * h)
        .map(|i| ((i % w) * 97 + (i / w) * 13) as u16)
        .collect();
    for c in PRESETS {
        let streamed = encode_gray16(w, h, &values, c);
        assert!(
            streamed == encode_gray16_with_png_crate(w, h, &values, c),
            "{c:?}"
        );
        let (bw, bh, back) = decode_gray16(&streamed, Path::new("depth")).expect("decodes");
        assert_eq!((bw, bh), (w, h));
        assert!(back == values, "{c:?}: values changed");
    }
}

/// The direct decoder takes `png` and gives the png crate's pixels.
fn assert_direct_decode(png: &[u8], what: &str) -> RgbImage {
    let (w, h, data) = decode::decode_rgb8(png, MAX_PIXELS)
        .unwrap_or_else(|| panic!("{what}: the direct decoder did not take the file"));
    let reference = decode_rgb8_with_png_crate(png, Path::new(what)).expect("png crate decodes");
    assert_eq!((w, h), (reference.width(), reference.height()), "{what}");
    assert!(
        data == *reference.as_raw(),
        "{what}: pixels differ from the png crate's"
    );
    reference
}

#[test]
fn direct_decoder_equals_the_png_crate_on_kitti_frames() {
    let dir = common::real_kitti().join("training/image_2");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "png") {
            assert_direct_decode(
                &std::fs::read(&path).expect("read"),
                &path.display().to_string(),
            );
            n += 1;
        }
    }
    assert!(n >= 3, "KITTI frames in {}", dir.display());
}

#[test]
fn direct_decoder_undoes_every_filter_type() {
    // `best` picks the filter per row (all five types occur on this image; checked below by
    // reading the filter bytes back), `fast` is Sub and `default` Paeth on every row.
    for (i, (w, h)) in [(1, 1), (2, 9), (7, 3), (64, 48), (129, 33)]
        .into_iter()
        .enumerate()
    {
        let img = camera_like(w, h, 40 + i as u64);
        for c in [
            PngCompression::Fast,
            PngCompression::Default,
            PngCompression::Best,
        ] {
            let back = assert_direct_decode(&encode_rgb8(&img, c), "synthetic");
            assert!(
                back.as_raw() == img.as_raw(),
                "{w}x{h} {c:?}: pixels changed"
            );
        }
    }
    // rows of every filter type, made explicitly: NoFilter, Sub, Up, Avg, Paeth
    let (w, h) = (23u32, 10u32);
    let img = camera_like(w, h, 7);
    let len = w as usize * 3;
    let mut raw = Vec::new();
    let zero = vec![0u8; len];
    for r in 0..h as usize {
        let cur = &img.as_raw()[r * len..(r + 1) * len];
        let prev = if r == 0 {
            &zero[..]
        } else {
            &img.as_raw()[(r - 1) * len..r * len]
        };
        let filter = (r % 5) as u8;
        raw.push(filter);
        for i in 0..len {
            let a = if i >= 3 { cur[i - 3] as i16 } else { 0 };
            let b = prev[i] as i16;
            let c = if i >= 3 { prev[i - 3] as i16 } else { 0 };
            let predicted = match filter {
                0 => 0,
                1 => a,
                2 => b,
                3 => (a + b) / 2,
                _ => {
                    let p = a + b - c;
                    let (pa, pb, pc) = ((p - a).abs(), (p - b).abs(), (p - c).abs());
                    if pa <= pb && pa <= pc {
                        a
                    } else if pb <= pc {
                        b
                    } else {
                        c
                    }
                }
            };
            raw.push(cur[i].wrapping_sub(predicted as u8));
        }
    }
    let png = png_file(w, h, 2, &zlib_stored(&raw), &[]);
    let back = assert_direct_decode(&png, "all filter types");
    assert!(
        back.as_raw() == img.as_raw(),
        "explicit filters: pixels changed"
    );
}

#[test]
fn files_the_direct_decoder_does_not_take_go_to_the_png_crate() {
    let img = camera_like(16, 8, 3);
    let good = encode_rgb8(&img, PngCompression::Default);
    assert!(decode::decode_rgb8(&good, MAX_PIXELS).is_some());
    // a flipped bit in the image data: CRC mismatch
    let mut bad_crc = good.clone();
    let n = bad_crc.len();
    bad_crc[n - 20] ^= 1;
    // truncated in the middle of IDAT
    let truncated = good[..good.len() / 2].to_vec();
    // over the pixel limit
    let huge = png_file(100_000, 100_000, 2, &zlib_stored(&[0]), &[]);
    // grey, and RGB with a tRNS chunk (an alpha channel for the png crate)
    let grey = encode_gray16(4, 4, &[7; 16], PngCompression::Default);
    let raw: Vec<u8> = (0..8)
        .flat_map(|_| std::iter::once(0).chain(vec![9u8; 48]))
        .collect();
    let trns = png_file(
        16,
        8,
        2,
        &zlib_stored(&raw),
        &[(*b"tRNS", vec![0, 9, 0, 9, 0, 9])],
    );
    // an image stream shorter than the image
    let short = png_file(16, 8, 2, &zlib_stored(&raw[..raw.len() - 1]), &[]);
    for (what, png) in [
        ("bad CRC", &bad_crc),
        ("truncated", &truncated),
        ("over the pixel limit", &huge),
        ("16-bit grey", &grey),
        ("tRNS", &trns),
        ("short stream", &short),
    ] {
        assert!(
            decode::decode_rgb8(png, MAX_PIXELS).is_none(),
            "{what}: the direct decoder took it"
        );
        // and decode_rgb8 gives exactly what the png crate gives (error or pixels)
        let ours = decode_rgb8(png, Path::new(what)).map(|i| i.into_raw());
        let theirs = decode_rgb8_with_png_crate(png, Path::new(what)).map(|i| i.into_raw());
        assert_eq!(
            ours.as_ref().map_err(|e| e.to_string()),
            theirs.as_ref().map_err(|e| e.to_string()),
            "{what}"
        );
    }
    assert!(
        decode_rgb8(&trns, Path::new("tRNS")).is_ok(),
        "tRNS RGB still decodes"
    );
    assert!(
        decode_rgb8(&short, Path::new("short")).is_err(),
        "a short stream is an error"
    );
}

/// A zlib stream of stored blocks (no compression) holding `data`.
fn zlib_stored(data: &[u8]) -> Vec<u8> {
    let mut z = vec![0x78, 0x01];
    let mut blocks = data.chunks(65_535).peekable();
    if blocks.peek().is_none() {
        z.extend_from_slice(&[1, 0, 0, 0xff, 0xff]);
    }
    while let Some(block) = blocks.next() {
        z.push(blocks.peek().is_none() as u8);
        let len = block.len() as u16;
        z.extend_from_slice(&len.to_le_bytes());
        z.extend_from_slice(&(!len).to_le_bytes());
        z.extend_from_slice(block);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &x in data {
        a = (a + x as u32) % 65_521;
        b = (b + a) % 65_521;
    }
    z.extend_from_slice(&((b << 16) | a).to_be_bytes());
    z
}

/// A PNG file: 8-bit, colour type `color`, with `extra` chunks before IDAT.
fn png_file(w: u32, h: u32, color: u8, zlib: &[u8], extra: &[([u8; 4], Vec<u8>)]) -> Vec<u8> {
    let mut out = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    let mut chunk = |kind: &[u8; 4], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&common::png_crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, color, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    for (kind, data) in extra {
        chunk(kind, data);
    }
    chunk(b"IDAT", zlib);
    chunk(b"IEND", &[]);
    out
}

/// Damaged files with valid chunk CRCs (so that the damage reaches the inflater, the filters
/// and the chunk layout): the decoder never panics, and `decode_rgb8` gives the png crate's
/// answer, the same pixels or an error, whichever path takes the file.
#[test]
fn damaged_files_are_decoded_as_the_png_crate_decodes_them() {
    let img = camera_like(37, 21, 11);
    let mut rng = noise(0xdec0de, 40_000).into_iter();
    let mut next = move || rng.next().expect("enough noise") as usize;
    let (mut taken, mut errors) = (0, 0);
    for round in 0..2_000 {
        let c = [
            PngCompression::Fast,
            PngCompression::Default,
            PngCompression::Best,
        ][round % 3];
        let mut png = encode_rgb8(&img, c);
        let chunks = chunk_spans(&png);
        let (start, len) = chunks[next() % chunks.len()];
        match next() % 4 {
            // flip bits in a chunk's data (IHDR fields, the zlib stream, ...)
            0 | 1 if len > 0 => {
                for _ in 0..1 + next() % 3 {
                    png[start + 8 + next() % len] ^= 1 << (next() % 8);
                }
            }
            // cut the file short
            2 => png.truncate(start + next() % (len + 12)),
            // repeat or drop a chunk
            _ => {
                let chunk = png[start..start + len + 12].to_vec();
                if next() % 2 == 0 {
                    png.splice(start..start, chunk);
                } else {
                    png.drain(start..start + len + 12);
                }
            }
        }
        fix_crcs(&mut png);
        let what = format!("damaged file {round}");
        taken += decode::decode_rgb8(&png, MAX_PIXELS).is_some() as usize;
        let ours = decode_rgb8(&png, Path::new(&what)).map(|i| i.into_raw());
        let theirs = decode_rgb8_with_png_crate(&png, Path::new(&what)).map(|i| i.into_raw());
        errors += theirs.is_err() as usize;
        assert_eq!(
            ours.as_ref().map_err(|e| e.to_string()),
            theirs.as_ref().map_err(|e| e.to_string()),
            "{what}"
        );
    }
    // both kinds of outcome occurred, so both paths were compared
    assert!(
        taken > 100 && errors > 100,
        "{taken} taken directly, {errors} errors"
    );
}

/// (offset, data length) of every chunk of a PNG (up to where the chunk layout breaks).
fn chunk_spans(png: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut at = 8;
    while at + 12 <= png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
        if at + 12 + len > png.len() {
            break;
        }
        spans.push((at, len));
        at += 12 + len;
    }
    spans
}

/// Recomputes the CRC of every whole chunk.
fn fix_crcs(png: &mut [u8]) {
    for (at, len) in chunk_spans(png) {
        let crc = common::png_crc32(&png[at + 4..at + 8 + len]);
        png[at + 8 + len..at + 12 + len].copy_from_slice(&crc.to_be_bytes());
    }
}
