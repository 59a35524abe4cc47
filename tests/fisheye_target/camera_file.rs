//! The `--camera` file: the options it excludes are set-up errors, and a native calibration
//! file (KITTI-360's yaml) is a fisheye target.

use super::*;

#[test]
fn fisheye_set_up_errors_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let cam = kb_camera(dir.path());
    let cam = cam.to_str().unwrap();
    let cases: [(&str, Vec<&str>, &str); 5] = [
        ("fisheye", vec![], "--camera"),
        ("equirect", vec!["--camera", cam], "--camera"),
        (
            "fisheye",
            vec!["--camera", cam, "--pano-width", "2048"],
            "--pano-width",
        ),
        (
            "fisheye",
            vec!["--camera", cam, "--size", "800x400"],
            "--size",
        ),
        (
            "fisheye",
            vec!["--camera", cam, "--px-per-deg", "9"],
            "--px-per-deg",
        ),
    ];
    for (i, (to, extra, names)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        let run = kitti(to, synth_source(), &out, extra);
        assert_eq!(
            run.code, 2,
            "{to} {extra:?}: exit {}: {}",
            run.code, run.stderr
        );
        assert!(run.stderr.contains(names), "{to} {extra:?}: {}", run.stderr);
        assert!(!out.exists(), "{to} {extra:?}: wrote {}", out.display());
    }
}

#[test]
#[allow(clippy::excessive_precision)] // the published digits
fn a_kitti_360_yaml_is_a_fisheye_target() {
    let dir = tempfile::tempdir().unwrap();
    // KITTI-360's calibration/image_02.yaml, as published.
    let yaml = "%YAML:1.0\n---\nmodel_type: MEI\ncamera_name: image_02\nimage_width: 1400\n\
        image_height: 1400\nmirror_parameters:\n   xi: 2.2134047507854890e+00\n\
        distortion_parameters:\n   k1: 1.6798235660113681e-02\n   k2: 1.6548773243373522e+00\n\
        \x20  p1: 4.2223943394772046e-04\n   p2: 4.2462134260997584e-04\n\
        projection_parameters:\n   gamma1: 1.3363220825849971e+03\n\
        \x20  gamma2: 1.3357883350012958e+03\n   u0: 7.1694323510126321e+02\n\
        \x20  v0: 7.0576498308221585e+02\n";
    let cam = write_camera(dir.path(), "image_02.yaml", yaml);
    let out = dir.path().join("out");
    // Half size, so that the test stays quick (intrinsics by the half-pixel rule).
    convert(
        &cam,
        synth_source(),
        &out,
        &["--frames", "000000", "--resize", "700x700"],
    );
    let calib = read_text(&out.join("training/calib/000000.txt"));
    assert!(calib.contains("\nmodel2: mei\n"), "{calib}");
    let d = calib_values(&calib, "D2").unwrap();
    let want = [
        2.2134047507854890,
        1.6798235660113681e-02,
        1.6548773243373522,
        4.2223943394772046e-04,
        4.2462134260997584e-04,
        0.0,
    ];
    for (a, b) in d.iter().zip(want) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-3), "D2 {d:?}");
    }
    assert_k_close(
        "KITTI-360 at half size",
        k2_of(&calib),
        [
            0.5 * 1.3363220825849971e+03,
            0.5 * 1.3357883350012958e+03,
            0.5 * (7.1694323510126321e+02 + 0.5) - 0.5,
            0.5 * (7.0576498308221585e+02 + 0.5) - 0.5,
        ],
    );
    let image = read_rgb8(&out.join("training/image_2/000000.png"));
    assert_eq!((image.width, image.height), (700, 700));
    // The source's view lies in the middle of the fisheye: some pixels there are not black.
    let lit = image
        .data
        .chunks(3)
        .filter(|p| p.iter().any(|&c| c > 0))
        .count();
    assert!(lit > 20_000, "only {lit} pixels with data");
    assert_success(&panoconv(["verify".as_ref(), out.as_os_str()]));
}
