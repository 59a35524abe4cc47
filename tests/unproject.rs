//! labels → pixel objects → unproject returns the KITTI boxes: location within 1 mm and
//! rotation_y within 1e-4 rad, in every projection, objects near ±90° azimuth included.

use nalgebra::Vector3;
use panoconv::camera::{CameraModel, ImageSize, Intrinsics, LinearCamera, Projection};
use panoconv::kitti::{Label, LabelFile};
use panoconv::tools::unproject::{
    format_pixel_line, label_to_pixel, parse_pixel_line, pixel_to_box, trained_focal_scale,
};
use proptest::prelude::*;
use std::path::Path;
use std::process::Command;

const LOCATION_TOL_M: f64 = 1e-3;
const ANGLE_TOL_RAD: f64 = 1e-4;

fn angle_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

fn cameras() -> Vec<Box<dyn LinearCamera>> {
    vec![
        Projection::Perspective.camera(
            Intrinsics::new(721.5377, 721.5377, 609.5593, 172.854),
            ImageSize::new(1242, 375),
        ),
        Projection::Equirect.camera(
            Intrinsics::new(325.95, 325.95, 1023.5, 511.5),
            ImageSize::new(2048, 1024),
        ),
        Projection::Cylindrical.camera(
            Intrinsics::new(500.0, 480.0, 1570.0, 200.0),
            ImageSize::new(3141, 400),
        ),
    ]
}

fn label(dims: [f64; 3], loc: Vector3<f64>, ry: f64) -> Label {
    let line = format!(
        "Car 0.00 0 0.00 0 0 1 1 {:.2} {:.2} {:.2} {:.2} {:.2} {:.2} {:.2}",
        dims[0], dims[1], dims[2], loc.x, loc.y, loc.z, ry
    );
    Label::parse(Path::new("t"), 1, &line).unwrap()
}

/// Through the text format, as the files carry it.
fn round_trip(l: &Label, cam: &dyn CameraModel, c: &Vector3<f64>) -> Option<(Vector3<f64>, f64)> {
    let obj = label_to_pixel(l, cam, c)?;
    let parsed = parse_pixel_line(Path::new("p"), 1, &format_pixel_line(&obj)).unwrap();
    pixel_to_box(&parsed, cam, c, 1.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn labels_survive_pixels_and_back(
        az in -3.1..3.1f64, dist in 2.0..60.0f64, y in 0.5..2.5f64,
        h in 0.5..3.0f64, w in 0.5..2.5f64, l in 0.5..6.0f64, ry in -3.1..3.1f64,
    ) {
        let c = Vector3::new(-0.0598, 0.0004, -0.0027);
        let loc = Vector3::new(dist * az.sin(), y, dist * az.cos());
        let lab = label([h, w, l], loc, ry);
        for cam in cameras() {
            if cam.projection() == Projection::Perspective && az.abs() > 1.2 {
                continue; // behind or beside a pinhole
            }
            let (back, back_ry) = round_trip(&lab, cam.as_ref(), &c).expect("visible");
            let err = (back - lab.location).norm();
            prop_assert!(err < LOCATION_TOL_M, "{:?}: location off by {err} m", cam.projection());
            prop_assert!(angle_diff(back_ry, lab.rotation_y) < ANGLE_TOL_RAD, "{:?}: ry {back_ry} vs {}", cam.projection(), lab.rotation_y);
        }
    }
}

#[test]
fn objects_near_ninety_degrees_azimuth() {
    let c = Vector3::new(-0.0598, 0.0004, -0.0027);
    for az_deg in [-90.0f64, -89.5, 89.5, 90.0, 135.0, -179.0] {
        let az = az_deg.to_radians();
        let lab = label(
            [1.52, 1.65, 3.9],
            Vector3::new(9.0 * az.sin(), 1.65, 9.0 * az.cos()),
            0.7,
        );
        for cam in cameras()
            .into_iter()
            .filter(|c| c.projection() != Projection::Perspective)
        {
            let (back, back_ry) = round_trip(&lab, cam.as_ref(), &c).unwrap();
            assert!(
                (back - lab.location).norm() < LOCATION_TOL_M,
                "{az_deg}° {:?}",
                cam.projection()
            );
            assert!(
                angle_diff(back_ry, lab.rotation_y) < ANGLE_TOL_RAD,
                "{az_deg}° {:?}",
                cam.projection()
            );
        }
    }
}

#[test]
fn trained_focal_rescales_distance_to_the_output_camera() {
    // A detector trained at f_Y = 721.5 sees an object at rho = 20 m in a cylindrical image with
    // f_y = 480 as big as a perspective object at Z = 20 · 721.5 / 480: it predicts that Z.
    let cams = cameras();
    let cyl = cams[2].as_ref();
    let c = Vector3::zeros();
    let lab = label([1.52, 1.65, 3.9], Vector3::new(3.0, 1.65, 20.0), 0.3);
    let mut obj = label_to_pixel(&lab, cyl, &c).unwrap();
    let rho = obj.distance;
    obj.distance = rho * 721.5 / 480.0;
    let scale = trained_focal_scale(cams[2].as_ref(), 721.5);
    assert!((scale - 480.0 / 721.5).abs() < 1e-12);
    let (back, _) = pixel_to_box(&obj, cyl, &c, scale).unwrap();
    assert!((back - lab.location).norm() < 1e-9);
}

#[test]
fn cli_labels_to_pixels_then_unproject_returns_the_labels() {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti");
    let tmp = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_panoconv");
    for to in ["perspective", "equirect", "cylindrical"] {
        let out = tmp.path().join(to);
        let ok = |args: &[&std::ffi::OsStr]| {
            let o = Command::new(bin).args(args).output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        };
        ok(&[
            "kitti".as_ref(),
            "--to".as_ref(),
            to.as_ref(),
            "-q".as_ref(),
            "-i".as_ref(),
            sample.as_os_str(),
            "-o".as_ref(),
            out.as_os_str(),
        ]);
        let pix = tmp.path().join(format!("{to}_pixels"));
        ok(&[
            "labels-to-pixels".as_ref(),
            "-i".as_ref(),
            out.as_os_str(),
            "-o".as_ref(),
            pix.as_os_str(),
        ]);
        let res = tmp.path().join(format!("{to}_results"));
        let calib = out.join("training/calib");
        ok(&[
            "unproject".as_ref(),
            "--calib".as_ref(),
            calib.as_os_str(),
            "-i".as_ref(),
            pix.as_os_str(),
            "-o".as_ref(),
            res.as_os_str(),
        ]);
        let mut n = 0;
        for id in ["000000", "000001", "000002"] {
            let orig = LabelFile::read(&out.join(format!("training/label_2/{id}.txt"))).unwrap();
            let back = LabelFile::read(&res.join(format!("{id}.txt"))).unwrap();
            let objects: Vec<&Label> = orig.labels.iter().filter(|l| l.has_box_3d()).collect();
            assert_eq!(objects.len(), back.labels.len(), "{to} {id}");
            for (a, b) in objects.iter().zip(&back.labels) {
                assert!(
                    (a.location - b.location).norm() < LOCATION_TOL_M,
                    "{to} {id}: {:?} vs {:?}",
                    a.location,
                    b.location
                );
                assert!(angle_diff(a.rotation_y, b.rotation_y) < ANGLE_TOL_RAD);
                assert_eq!(a.kind, b.kind);
                assert_eq!(b.score, Some(1.0));
                n += 1;
            }
        }
        eprintln!("{to}: {n} objects returned within 1 mm / 1e-4 rad");
        assert!(n >= 7);
    }
}

#[test]
fn malformed_prediction_names_file_line_and_field() {
    let err =
        parse_pixel_line(Path::new("preds/000001.txt"), 4, "Car 1 2 abc 1 1 1 0 0.5").unwrap_err();
    assert_eq!(
        err.to_string(),
        "preds/000001.txt:4: distance: \"abc\" is not a finite number"
    );
    let err = parse_pixel_line(Path::new("p.txt"), 1, "Car 1 2 3").unwrap_err();
    assert!(err
        .to_string()
        .starts_with("p.txt:1: fields: expected 9 fields"));
    let err = parse_pixel_line(Path::new("p.txt"), 2, "Car 1 2 -3 1 1 1 0 1").unwrap_err();
    assert_eq!(err.to_string(), "p.txt:2: distance: must be positive");
}
