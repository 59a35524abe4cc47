//! The PNG decoded row by row (`RowDecoder`) and warped as its rows arrive (`PngSource`):
//! every band of rows equals the whole image the png crate decodes, the streamed warp writes
//! the bytes of decoding first and warping after (real KITTI frames, every preset), a table
//! reads no source row beyond `source_rows`, and a damaged file gives the png crate's answer.

use crate::common;

use nalgebra::Matrix3;
use panoconv::camera::{ImageSize, Intrinsics, Perspective, Projection};
use panoconv::codec::png::decode::RowDecoder;
use panoconv::codec::png::{decode_rgb8_with_png_crate, encode_rgb8, PngCompression, MAX_PIXELS};
use panoconv::geometry::{output_camera, OutputSpec};
use panoconv::image::RgbImage;
use panoconv::warp::{warp_encode, PngSource, RemapTable, Wrap};
use std::path::{Path, PathBuf};

const PRESETS: [PngCompression; 3] = [
    PngCompression::Fast,
    PngCompression::Default,
    PngCompression::Best,
];

fn kitti_frames() -> Vec<PathBuf> {
    let dir = common::real_kitti().join("training/image_2");
    let mut frames: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    frames.sort();
    assert!(frames.len() >= 3, "KITTI frames in {}", dir.display());
    frames
}

/// The equirect table of a perspective source of `size` with focal length `f`, as
/// `panoconv kitti --to equirect` builds it.
fn equirect_table(f: f64, size: ImageSize) -> RemapTable {
    let k = Intrinsics::new(f, f, size.width as f64 / 2.0, size.height as f64 / 2.0);
    let src = Perspective::new(k, size);
    let out = output_camera(&OutputSpec::new(Projection::Equirect), k, &src).expect("camera");
    RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None)
}

/// A smooth image with a little noise (xorshift), like a camera image to a PNG filter.
fn camera_like(w: u32, h: u32, seed: u64) -> RgbImage {
    let mut x = seed | 1;
    let data = (0..(w * h * 3) as usize)
        .map(|i| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let (p, c) = (i / 3, i % 3);
            let (u, v) = (p % w as usize, p / w as usize);
            ((u * 3 + v * 2 + c * 40) as u8).wrapping_add((x >> 24) as u8 % 5)
        })
        .collect();
    RgbImage::from_raw(w, h, data).expect("size")
}

/// Decodes `png` in bands of `step` rows, checking after each band that the rows decoded so
/// far are the png crate's, and the rest still zero.
fn assert_bands(png: &[u8], step: usize, what: &str) {
    let reference = decode_rgb8_with_png_crate(png, Path::new(what)).expect("png crate decodes");
    let len = reference.width() as usize * 3;
    let h = reference.height() as usize;
    let mut dec = RowDecoder::new(png, MAX_PIXELS).expect("the direct decoder takes it");
    assert_eq!(
        dec.size(),
        (reference.width(), reference.height()),
        "{what}"
    );
    let mut want = 0;
    while want < h {
        want = (want + step).min(h);
        dec.decode_rows(want).expect("decodes");
        let rows = dec.rows();
        assert!(rows >= want && rows <= h, "{what}: {rows} rows for {want}");
        assert!(
            dec.image()[..rows * len] == reference.as_raw()[..rows * len],
            "{what}, step {step}: the first {rows} rows differ from the png crate's"
        );
        assert!(
            dec.image()[rows * len..].iter().all(|&b| b == 0),
            "{what}: bytes below the decoded rows"
        );
    }
    let (w, hh, data) = dec.finish().expect("the stream ends where the image does");
    assert_eq!((w, hh), (reference.width(), reference.height()));
    assert!(
        data == *reference.as_raw(),
        "{what}: finished image differs"
    );
}

#[test]
fn row_decoder_bands_equal_the_png_crate_on_kitti_frames_and_every_filter() {
    for path in kitti_frames().iter().take(3) {
        let png = std::fs::read(path).expect("read");
        for step in [1, 7, 100] {
            assert_bands(&png, step, &path.display().to_string());
        }
    }
    // `best` filters row by row adaptively (every filter type), `fast` Sub, `default` Paeth;
    // 700 × 3 + 1 bytes a row over 400 rows passes the inflate window several times
    let img = camera_like(700, 400, 5);
    for c in PRESETS {
        assert_bands(&encode_rgb8(&img, c), 13, &format!("700x400 {c:?}"));
    }
    assert_bands(
        &encode_rgb8(&camera_like(1, 1, 3), PngCompression::Default),
        1,
        "1x1",
    );
}

#[test]
fn streamed_warp_equals_decoding_then_warping_on_kitti_frames() {
    for path in kitti_frames() {
        let png = std::fs::read(&path).expect("read");
        let what = path.display().to_string();
        let img = decode_rgb8_with_png_crate(&png, &path).expect("decodes");
        let table = equirect_table(721.5, ImageSize::new(img.width(), img.height()));
        for c in PRESETS {
            let mut source = PngSource::new(png.clone(), &path).expect("reads");
            assert_eq!(source.size(), (img.width(), img.height()));
            let whole = warp_encode(&table, &img, c);
            assert!(
                source.warp_encode(&table, c).expect("warps") == whole,
                "{what} {c:?}"
            );
            // a second view of the same source warps the kept image
            assert!(
                source.warp_encode(&table, c).expect("warps") == whole,
                "{what} {c:?}"
            );
            assert!(
                source.decode().expect("decoded") == img,
                "{what}: kept image"
            );
        }
    }
}

#[test]
fn a_table_reads_no_source_row_beyond_source_rows() {
    let img = camera_like(300, 120, 9);
    let size = ImageSize::new(300, 120);
    let stride = 300 * 3;
    for f in [60.0, 150.0, 400.0] {
        let table = equirect_table(f, size);
        let out = table.size();
        let mut ahead = 0;
        let mut fewer = 0;
        for v in 0..out.height as usize {
            let rows = table.source_rows(v);
            assert!(rows <= 120);
            fewer += (rows < 120) as usize;
            ahead = ahead.max(rows);
            let mut expected = vec![0u8; out.width as usize * 3];
            table.apply_row(&img, v, &mut expected);
            // every row below the ones the table says it reads spoiled
            let mut spoiled = img.as_raw().to_vec();
            spoiled[rows * stride..].fill(0xA5);
            let mut row = vec![0u8; out.width as usize * 3];
            table.apply_row_data(&spoiled, v, &mut row);
            assert!(
                row == expected,
                "f {f}: output row {v} read beyond source row {rows}"
            );
        }
        // the bound is not trivially the whole image for the upper output rows
        assert!(fewer > 0, "f {f}: every output row reads the whole source");
        assert_eq!(
            ahead, 120,
            "f {f}: the lowest rows read the source's last row"
        );
    }
}

/// Damaged files (bits flipped, cut short, chunks repeated or dropped, CRCs fixed): the
/// streamed warp gives the png crate's answer, its error naming the file or the warp of its
/// pixels, and never a panic.
#[test]
fn damaged_files_warp_as_the_png_crate_decodes_them() {
    let img = camera_like(37, 21, 11);
    let table = equirect_table(20.0, ImageSize::new(37, 21));
    let mut x = 0xfeed_u64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 24) as usize
    };
    let (mut warped, mut errors) = (0, 0);
    for round in 0..600 {
        let c = PRESETS[round % 3];
        let mut png = encode_rgb8(&img, c);
        // flip bits past the header and the zlib header: mostly the deflate stream
        let n = png.len();
        for _ in 0..1 + next() % 3 {
            png[45 + next() % (n - 57)] ^= 1 << (next() % 8);
        }
        if next() % 4 == 0 {
            png.truncate(n - 12 - next() % 40);
        }
        common_fix_crcs(&mut png);
        let path = PathBuf::from(format!("damaged-{round}.png"));
        let theirs = decode_rgb8_with_png_crate(&png, &path)
            .map(|i| warp_encode(&table, &i, PngCompression::Default));
        let ours = PngSource::new(png, &path)
            .and_then(|mut s| s.warp_encode(&table, PngCompression::Default));
        match (&ours, &theirs) {
            (Ok(a), Ok(b)) => {
                assert!(a == b, "round {round}: warped bytes differ");
                warped += 1;
            }
            (Err(a), Err(b)) => {
                assert_eq!(a.to_string(), b.to_string(), "round {round}");
                assert!(a.to_string().contains("damaged-"), "{a}");
                errors += 1;
            }
            _ => panic!(
                "round {round}: ours {:?}, the png crate's {:?}",
                ours.is_ok(),
                theirs.is_ok()
            ),
        }
    }
    assert!(
        warped > 50 && errors > 50,
        "{warped} warped, {errors} errors"
    );
}

/// Recomputes the CRC of every whole chunk (so that the damage reaches the deflate stream).
fn common_fix_crcs(png: &mut [u8]) {
    let mut at = 8;
    while at + 12 <= png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().expect("4 bytes")) as usize;
        if at + 12 + len > png.len() {
            break;
        }
        let crc = common::png_crc32(&png[at + 4..at + 8 + len]);
        png[at + 8 + len..at + 12 + len].copy_from_slice(&crc.to_be_bytes());
        at += 12 + len;
    }
}
