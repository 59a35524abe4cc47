//! A truncated image is a failed frame, whatever reads it: the JPEG decoder fills the rows past
//! a cut with grey and says nothing, so every reader (nuScenes, KITTI-360, KITTI, the folder
//! commands) gets an error naming the file; the run exits 1, counts the frame, and `verify`
//! is not OK. Driven through the binary on copies of the fixtures.

use crate::common::*;
use panoconv::codec::{decode_rgb8, png};
use panoconv::image::RgbImage;
use std::path::Path;

/// A camera-like test image: a gradient with a bright square.
fn scene(w: u32, h: u32) -> RgbImage {
    let mut img = RgbImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = (x * 255 / w) as u8 / 2 + (y * 255 / h) as u8 / 2;
            let inside = (w / 4..w / 2).contains(&x) && (h / 4..h / 2).contains(&y);
            img.put_pixel(x, y, if inside { [250; 3] } else { [v; 3] });
        }
    }
    img
}

#[test]
fn the_test_jpeg_writer_round_trips_and_every_cut_is_an_error_naming_the_file() {
    let img = scene(100, 60);
    let jpeg = jpeg_blocks(&img);
    let path = Path::new("cam/frame.jpg");
    let back = decode_rgb8(&jpeg, path).unwrap();
    assert_eq!((back.width(), back.height()), (100, 60));
    // each block one level: the pixel at a block's centre is the block's mean, within 1
    let (x, y) = (3 * 8 + 4, 2 * 8 + 4);
    let mean: u32 = (24..32)
        .flat_map(|x| (16..24).map(move |y| (x, y)))
        .map(|(x, y)| img.pixel(x, y)[0] as u32)
        .sum::<u32>()
        / 64;
    assert!((back.pixel(x, y)[0] as i32 - mean as i32).abs() <= 1);
    for cut in [jpeg.len() * 2 / 5, jpeg.len() - 40, jpeg.len() - 2] {
        let e = decode_rgb8(&jpeg[..cut], path).unwrap_err().to_string();
        assert!(
            e.contains("cam/frame.jpg") && e.contains("truncated"),
            "{cut}: {e}"
        );
    }
    // bytes after the end-of-image marker are ignored, as decoders do
    let mut padded = jpeg.clone();
    padded.extend_from_slice(&[0; 16]);
    assert_eq!(decode_rgb8(&padded, path).unwrap().as_raw(), back.as_raw());
}

/// The run failed that frame alone, naming `file`, and `verify` says so.
#[track_caller]
fn assert_failed_frame(run: &Run, out: &Path, file: &Path, words: &str) {
    assert_eq!(run.code, 1, "{}", run.stderr);
    let failures = run.frame_failures();
    assert_eq!(failures.len(), 1, "{}", run.stderr);
    let named = format!("{}: {words}", file.display());
    assert!(
        failures[0].contains(&named),
        "{named:?} not in {}",
        failures[0]
    );
    assert_eq!(read_manifest(out)["summary"]["failed"], 1);
    let verify = panoconv([std::ffi::OsStr::new("verify"), out.as_os_str()]);
    assert_ne!(verify.code, 0, "{}", verify.stdout);
    assert!(
        verify.stdout.contains("1 failed frames"),
        "{}",
        verify.stdout
    );
}

/// Cuts `file` to two fifths of its bytes.
fn cut(file: &Path) {
    let bytes = std::fs::read(file).unwrap();
    std::fs::write(file, &bytes[..bytes.len() * 2 / 5]).unwrap();
}

#[test]
fn a_truncated_nuscenes_jpeg_is_a_failed_frame_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("nus");
    copy_tree(&repo().join("fixtures/nuscenes"), &root);
    // the first sample's CAM_BACK as a JPEG, as nuScenes ships its images
    let name = "n000-2026-01-01-00-00-00+0000__CAM_BACK__1532402927637525";
    let png_path = root.join(format!("samples/CAM_BACK/{name}.png"));
    let img = png::decode_rgb8(&std::fs::read(&png_path).unwrap(), &png_path).unwrap();
    std::fs::remove_file(&png_path).unwrap();
    let jpg = root.join(format!("samples/CAM_BACK/{name}.jpg"));
    std::fs::write(&jpg, jpeg_blocks(&img)).unwrap();
    let table = root.join("v1.0-mini/sample_data.json");
    let text = read_text(&table).replace(&format!("{name}.png"), &format!("{name}.jpg"));
    write_text(&table, &text);
    let args = |out: &Path| {
        let mut a = vec!["nuscenes", "--input", root.to_str().unwrap()];
        a.extend(["--version", "v1.0-mini", "--to", "equirect"]);
        a.extend(["--pano-width", "512", "--output", out.to_str().unwrap()]);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let whole = tmp.path().join("whole");
    assert_success(&panoconv(args(&whole)));
    cut(&jpg);
    let out = tmp.path().join("out");
    let run = panoconv(args(&out));
    assert_failed_frame(
        &run,
        &out,
        &jpg,
        "cannot decode JPEG: the file is truncated",
    );
}

#[test]
fn a_truncated_kitti360_or_kitti_png_is_a_failed_frame_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("k360");
    copy_tree(&repo().join("fixtures/kitti360"), &root);
    let seq = panoconv::tools::synth360::SEQUENCE;
    let png = root.join(format!(
        "data_2d_raw/{seq}/image_00/data_rect/0000000251.png"
    ));
    cut(&png);
    let out = tmp.path().join("out360");
    let mut args = vec!["kitti360", "--input", root.to_str().unwrap()];
    args.extend(["--sequence", seq, "--to", "equirect", "--pano-width", "360"]);
    args.extend(["--output", out.to_str().unwrap()]);
    let run = panoconv(&args);
    assert_failed_frame(&run, &out, &png, "cannot decode PNG");

    let kitti_root = tmp.path().join("kitti");
    copy_tree(synth_source(), &kitti_root);
    let png = kitti_root.join("training/image_2/000001.png");
    cut(&png);
    let out = tmp.path().join("out_kitti");
    let run = kitti("equirect", &kitti_root, &out, &[]);
    assert_failed_frame(&run, &out, &png, "cannot decode PNG");
}

#[test]
fn a_truncated_jpeg_panorama_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("panos");
    std::fs::create_dir_all(&input).unwrap();
    let jpeg = jpeg_blocks(&scene(256, 128));
    std::fs::write(input.join("a.jpg"), &jpeg).unwrap();
    let cut_one = input.join("b.jpg");
    std::fs::write(&cut_one, &jpeg[..jpeg.len() * 2 / 5]).unwrap();
    let out = tmp.path().join("out");
    let o = out.to_str().unwrap();
    let mut args = vec!["pano", "--to", "cylindrical", "--input"];
    args.extend([input.to_str().unwrap(), "--output", o]);
    let run = panoconv(&args);
    assert_failed_frame(
        &run,
        &out,
        &cut_one,
        "cannot decode JPEG: the file is truncated",
    );
    assert_eq!(read_manifest(&out)["summary"]["converted"], 1);
}
