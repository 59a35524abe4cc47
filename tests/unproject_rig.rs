//! `unproject` on a rig output: its calib's `P2` is the nominal pinhole `K2·[I | −C2]`, no
//! source camera, so the result boxes are the converted image's whatever `--box` says (as for
//! a perspective output); before, the default `--box source` looked for a KITTI source image
//! the rig never had and failed every frame.

use crate::common::{assert_success, panoconv, tree_bytes};
use std::path::Path;

/// `unproject` of the pixel-format `pixels` with the calibs of `out`, into `results`, with
/// `extra` options.
fn unproject(out: &Path, pixels: &Path, results: &Path, extra: &[&str]) {
    let calib = out.join("training/calib");
    let mut args = vec![
        "unproject",
        "--calib",
        calib.to_str().unwrap(),
        "--input",
        pixels.to_str().unwrap(),
        "--output",
        results.to_str().unwrap(),
    ];
    args.extend(extra);
    assert_success(&panoconv(&args));
}

#[test]
fn a_rig_outputs_predictions_unproject_by_default_into_the_converted_images_boxes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/nuscenes");
    assert_success(&panoconv([
        "nuscenes",
        "--input",
        fixture.to_str().unwrap(),
        "--version",
        "v1.0-mini",
        "--to",
        "equirect",
        "--quiet",
        "--output",
        out.to_str().unwrap(),
    ]));
    let pixels = tmp.path().join("pixels");
    assert_success(&panoconv([
        "labels-to-pixels",
        "--input",
        out.to_str().unwrap(),
        "--output",
        pixels.to_str().unwrap(),
    ]));
    let (default, converted) = (tmp.path().join("default"), tmp.path().join("converted"));
    unproject(&out, &pixels, &default, &[]);
    unproject(&out, &pixels, &converted, &["--box", "converted"]);
    let results = tree_bytes(&default);
    let lines: usize = (results.values())
        .map(|b| b.iter().filter(|&&c| c == b'\n').count())
        .sum();
    assert!(lines >= 10, "{lines} result lines");
    assert!(
        results == tree_bytes(&converted),
        "the default differs from --box converted"
    );
}
