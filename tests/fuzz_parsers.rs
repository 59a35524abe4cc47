//! Stable-toolchain fuzzing of the KITTI parsers (the cargo-fuzz targets in `fuzz/` need
//! nightly): the same properties, with proptest over arbitrary text and bytes and over
//! near-valid lines built from a vocabulary of tricky tokens. None of them may panic.

use panoconv::camera::{ImageSize, Projection};
use panoconv::kitti::Cam;
use panoconv::kitti::{velodyne, Calib, Label};
use proptest::prelude::*;
use std::path::Path;

/// Tokens that are numbers, almost numbers, or trouble.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        any::<i32>().prop_map(|v| v.to_string()),
        Just("nan".to_owned()),
        Just("-inf".to_owned()),
        Just("1e309".to_owned()),
        Just("-0".to_owned()),
        Just("0x10".to_owned()),
        Just("1,5".to_owned()),
        Just("Car".to_owned()),
        Just("DontCare".to_owned()),
        Just("P2:".to_owned()),
        Just("projection:".to_owned()),
        Just("K2:".to_owned()),
        Just("\u{feff}".to_owned()),
        "[a-zA-Z0-9.+-eE]{0,8}",
        ".{0,4}",
    ]
}

fn line_of(n: std::ops::Range<usize>) -> impl Strategy<Value = String> {
    (
        prop::collection::vec(token(), n),
        prop::sample::select(vec![" ", "\t", "  ", ": "]),
    )
        .prop_map(|(t, sep)| t.join(sep))
}

fn check_label(line: &str) {
    let path = Path::new("label_2/000000.txt");
    match Label::parse(path, 7, line) {
        Ok(label) => {
            assert!(label.tokens.len() == 15 || label.tokens.len() == 16);
            assert!(label.location.iter().all(|v| v.is_finite()));
            assert!(label.bbox.iter().all(|v| v.is_finite()));
            let _ = label.has_box_3d();
            let _ = label.corners();
            let _ = label.to_line_with(label.bbox, Some(label.truncated));
        }
        Err(e) => assert!(e.to_string().starts_with("label_2/000000.txt:7: "), "{e}"),
    }
}

fn check_calib(lines: Vec<String>) {
    let Ok(calib) = Calib::parse(Path::new("calib/000000.txt"), lines) else {
        return;
    };
    for n in Cam::ALL {
        if let Ok(cam) = calib.camera(n) {
            assert!(cam.k.fu > 0.0 && cam.k.fv > 0.0);
            // A non-finite centre or K is accepted by `camera` and makes `render_output` panic:
            // see `calib_with_non_finite_centre_is_refused` (ignored, a known bug).
            let finite = [cam.k.fu, cam.k.fv, cam.k.cu, cam.k.cv]
                .iter()
                .chain(cam.centre.iter())
                .all(|v| v.is_finite());
            if finite {
                let out = Projection::Perspective.camera(cam.k, ImageSize::new(1242, 375));
                let _ = calib.render_output(&[(n, out.as_ref(), cam.centre)]);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, ..ProptestConfig::default() })]

    #[test]
    fn label_any_text(line in ".{0,200}") {
        check_label(&line);
    }

    #[test]
    fn label_near_valid(line in line_of(13..18)) {
        check_label(&line);
    }

    #[test]
    fn calib_any_text(lines in prop::collection::vec(".{0,120}", 0..10)) {
        check_calib(lines);
    }

    #[test]
    fn calib_near_valid(
        keys in prop::collection::vec(
            prop::sample::select(vec!["P0:", "P2:", "P3", "R0_rect:", "R_rect", "Tr_velo_to_cam:", "K2:", "C2:", "projection:", "x:"]),
            0..8,
        ),
        values in prop::collection::vec(prop::collection::vec(token(), 0..14), 8),
    ) {
        let lines = keys
            .iter()
            .zip(&values)
            .map(|(k, v)| format!("{k} {}", v.join(" ")))
            .collect();
        check_calib(lines);
    }

    #[test]
    fn calib_perturbed_valid_p2(p in prop::collection::vec(prop_oneof![
        -2000.0f64..2000.0,
        Just(0.0),
        Just(1e-300),
        Just(1e300),
        Just(f64::MIN_POSITIVE),
    ], 12)) {
        let text: Vec<String> = p.iter().map(|v| format!("{v:e}")).collect();
        check_calib(vec![format!("P2: {}", text.join(" "))]);
    }

    #[test]
    fn velodyne_any_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        match velodyne::parse(&bytes, Path::new("v.bin")) {
            Ok(scan) => {
                prop_assert!(bytes.len().is_multiple_of(16));
                prop_assert_eq!(scan.points.len() + scan.dropped_non_finite, bytes.len() / 16);
                prop_assert_eq!(scan.points.len(), scan.reflectance.len());
                prop_assert!(scan.points.iter().all(|p| p.iter().all(|v| v.is_finite())));
            }
            Err(e) => {
                prop_assert!(!bytes.len().is_multiple_of(16));
                let want = format!("v.bin: {} bytes", bytes.len());
                prop_assert!(e.to_string().starts_with(&want), "{}", e);
            }
        }
    }
}

/// Found by `calib_perturbed_valid_p2`: a P2 whose K is finite but nearly singular (fu = 1e-300
/// after the division by P[2][2]) passes `Calib::camera` with a non-finite optical centre, and
/// `render_output` then panics in `format_sci` ("formatted with an exponent"). `camera` should
/// refuse it (`P2: optical centre is not finite`).
#[test]
fn calib_with_non_finite_centre_is_refused() {
    for p in [
        // fu = 6e-304, fv = cu = 6e296, centre.x = NaN
        "1e-300 0 1e300 0 2.2250738585072014e-308 1e300 0 0 2.2250738585072014e-308 0 1544.1979149459628 0",
        // P / P[2][2] overflows: fu = fv = inf
        "1e10 0 7.5e-300 0 0 1e10 3.5e-300 0 0 0 1e-300 0",
    ] {
        let calib = Calib::parse(Path::new("c.txt"), vec![format!("P2: {p}")]).unwrap();
        match calib.camera(Cam::C2) {
            Err(e) => assert!(e.to_string().starts_with("c.txt: P2: "), "{e}"),
            Ok(cam) => {
                let k = [cam.k.fu, cam.k.fv, cam.k.cu, cam.k.cv];
                let finite = k.iter().chain(cam.centre.iter()).all(|v| v.is_finite());
                assert!(finite, "accepted {cam:?}");
                let out = Projection::Perspective.camera(cam.k, ImageSize::new(1242, 375));
                let _ = calib.render_output(&[(Cam::C2, out.as_ref(), cam.centre)]);
            }
        }
    }
}
