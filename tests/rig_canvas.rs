//! A rig panorama's default canvas fits its use: without a scale, 2048 px for 360° over the band
//! of elevations the cameras cover (no row without a camera); `--full-360` asks for the whole
//! sphere and the summary says how many of its rows no camera sees; an explicit `--pano-width`
//! keeps the whole sphere as before; `--size` gives the canvas. Through the binary on the
//! nuScenes and KITTI-360 fixtures.

use crate::common::*;
use std::path::Path;

fn nuscenes(out: &Path, extra: &[&str]) -> Run {
    let input = repo().join("fixtures/nuscenes");
    let mut args = vec!["nuscenes", "--to", "equirect", "--input"];
    args.extend([input.to_str().unwrap(), "--version", "v1.0-mini"]);
    args.extend(["--output", out.to_str().unwrap()]);
    args.extend(extra);
    panoconv(&args)
}

/// The first frame's source map: (width, height, pixels with no camera per row).
fn uncovered_rows(out: &Path) -> (u32, u32, Vec<usize>) {
    let png = read_png(&out.join("training/source_2/000000.png"));
    let (w, h) = (png.width, png.height);
    let rows = (0..h as usize)
        .map(|y| {
            let row = &png.data[y * w as usize..(y + 1) * w as usize];
            row.iter().filter(|&&v| v == 255).count()
        })
        .collect();
    (w, h, rows)
}

#[test]
fn a_rig_panorama_is_the_band_its_cameras_cover_at_2048_by_default() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("band");
    let run = nuscenes(&out, &[]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(!run.stderr.contains("warning"), "{}", run.stderr);
    let (w, h, rows) = uncovered_rows(&out);
    assert_eq!(w, 2048);
    assert!(h < 1024, "a band, not the sphere: {h} rows");
    // the band is the cameras' directions; seen from C2, the rows at its lower edge look past
    // cameras that sit apart from C2 (the stitch's 10 m proxy): a few rows without a camera
    let empty = rows.iter().filter(|&&n| n == w as usize).count();
    assert!(
        empty * 8 < h as usize,
        "{empty} of {h} rows without a camera"
    );
    assert!(rows[0] < w as usize, "the top row has a camera");
    let black: usize = rows.iter().sum();
    assert!(
        black * 2 < (w * h) as usize,
        "{black} of {} uncovered",
        w * h
    );
    let image = read_png(&out.join("training/image_2/000000.png"));
    assert_eq!((image.width, image.height), (w, h));
}

#[test]
fn full_360_is_the_sphere_and_the_summary_says_how_much_is_black() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("full");
    let run = nuscenes(&out, &["--full-360"]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let (w, h, rows) = uncovered_rows(&out);
    assert_eq!(h, w.div_ceil(2), "2:1: {w}x{h}");
    let black: usize = rows.iter().sum();
    let share = (100.0 * black as f64 / (w * h) as f64).round();
    assert!(share > 50.0, "{share} %");
    // the rows no camera sees, counted (tests/rig_coverage.rs: a note, not a warning)
    let poles = rows.iter().filter(|&&n| n == w as usize).count();
    let said = format!("note: {poles} of the {h} rows of ");
    assert!(run.stderr.contains(&said), "{said:?} not in {}", run.stderr);
    // an explicit scale keeps the whole sphere (as before), --size gives the canvas
    let out = tmp.path().join("width");
    assert_success(&nuscenes(&out, &["--pano-width", "1024"]));
    let (w, h, _) = uncovered_rows(&out);
    assert_eq!((w, h), (1024, 512));
    let out = tmp.path().join("size");
    assert_success(&nuscenes(
        &out,
        &["--size", "800x200", "--pano-width", "1024"],
    ));
    let (w, h, _) = uncovered_rows(&out);
    assert_eq!((w, h), (800, 200));
}

#[test]
fn kitti360_takes_full_360_and_size_too() {
    let tmp = tempfile::tempdir().unwrap();
    let input = repo().join("fixtures/kitti360");
    let seq = panoconv::tools::synth360::SEQUENCE;
    for (flags, size) in [
        (vec!["--full-360", "--pano-width", "360"], (360, 180)),
        (vec!["--size", "300x100", "--pano-width", "360"], (300, 100)),
    ] {
        let out = tmp.path().join(flags[0].trim_start_matches('-'));
        let mut args = vec!["kitti360", "--to", "equirect", "--input"];
        args.extend([
            input.to_str().unwrap(),
            "--sequence",
            seq,
            "--frames",
            "250",
        ]);
        args.extend(["--output", out.to_str().unwrap()]);
        args.extend(flags);
        assert_success(&panoconv(&args));
        let png = read_png(&out.join("training/image_2/000250.png"));
        assert_eq!((png.width, png.height), size);
    }
}
