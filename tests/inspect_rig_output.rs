//! `panoconv inspect` on a rig output says what its `P2` is: the nominal pinhole K2·[I | −C2]
//! of the written camera, no camera of the rig, whose view (a LiDAR field-of-view filter's) is
//! a forward wedge of the panorama, checked here against the calib's own P2; a `kitti` output
//! keeps the source camera's P2 and is told so. The split's line lists the folders only
//! panoconv writes (source_2, objects). Through the binary on the nuScenes and synthetic
//! KITTI fixtures.

use crate::common::*;
use nalgebra::{Matrix3x4, Vector3, Vector4};
use std::path::Path;

fn inspect(out: &Path) -> String {
    let run = panoconv(["inspect", out.to_str().unwrap()]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    run.stdout
}

fn p2_line(report: &str) -> &str {
    (report.lines())
        .find(|l| l.starts_with("P2: "))
        .unwrap_or_else(|| panic!("no P2 line in:\n{report}"))
}

/// The pixel column P2 gives a point 10 m from C2 at `azimuth_deg` from rect's z axis.
fn p2_column(p2: &[f64], c2: &[f64], azimuth_deg: f64) -> f64 {
    let p = Matrix3x4::from_row_slice(p2);
    let a = azimuth_deg.to_radians();
    let x = Vector3::new(c2[0], c2[1], c2[2]) + 10.0 * Vector3::new(a.sin(), 0.0, a.cos());
    let h = p * Vector4::new(x.x, x.y, x.z, 1.0);
    h.x / h.z
}

#[test]
fn inspect_says_a_rig_outputs_p2_is_a_nominal_pinhole_and_its_view() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("equirect");
    let input = repo().join("fixtures/nuscenes");
    let mut args = vec!["nuscenes", "--input", input.to_str().unwrap()];
    args.extend([
        "--version",
        "v1.0-mini",
        "--to",
        "equirect",
        "--pano-width",
        "1024",
    ]);
    args.extend(["--output", out.to_str().unwrap()]);
    assert_success(&panoconv(&args));
    let report = inspect(&out);
    assert!(
        report.contains("  training: image_2 label_2 calib source_2 objects (no image_3"),
        "{report}"
    );
    let line = p2_line(&report);
    for said in [
        "P2: not the camera of these images (equirect 3): P0 to P3 are the nominal pinhole \
         K2·[I | −C2] of the written camera (a rig output's), no camera of the rig",
        "keeps only the points ahead of C2, within about ±72° of rect's z axis",
        "K2: and C2: lines",
        "labels-to-pixels",
    ] {
        assert!(line.contains(said), "{said:?} not in {line}");
    }
    assert!(!line.contains("kept for LiDAR"), "{line}");
    // what the line says of P2 holds for the calib's P2: the image's columns [0, 1024) hold
    // the points within 72° of z (72.3° = atan(π) for a 360° equirect), not those beyond
    let calib = read_text(&out.join("training/calib/000000.txt"));
    let p2 = calib_values(&calib, "P2").unwrap();
    let c2 = calib_values(&calib, "C2").unwrap();
    for (azimuth, inside) in [(-71.5, true), (71.5, true), (-73.0, false), (73.0, false)] {
        let u = p2_column(&p2, &c2, azimuth);
        assert_eq!((0.0..1024.0).contains(&u), inside, "{azimuth}°: u = {u}");
    }

    // a kitti output's P2 is the source camera's
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let report = inspect(&s.output);
    let line = p2_line(&report);
    assert!(
        line.starts_with(
            "P2: not the camera of these images (equirect 4): it is the source camera's \
             pinhole, kept for LiDAR field-of-view filters"
        ),
        "{line}"
    );
}
