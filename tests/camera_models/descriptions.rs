//! Camera description files of the new models: what loads, and what is refused naming the
//! field.

use super::references::eucm_reference;
use super::*;
use panoconv::camera::description::CameraDescription;
use panoconv::camera::CameraModel;
use std::path::Path;

fn parse(text: &str) -> panoconv::error::Result<CameraDescription> {
    CameraDescription::parse(text, Path::new("cams/side.json"))
}

#[test]
fn descriptions_of_the_new_models_load() {
    let kitti = r#"{
  "version": 1, "model": "mei", "width": 1400, "height": 1400, "max_fov_deg": 200,
  "xi": 2.2134047507854890,
  "k": [1.6798235660113681e-02, 1.6548773243373522],
  "p": [4.2223943394772046e-04, 4.2462134260997584e-04],
  "fx": 1.3363220825849971e+03, "fy": 1.3357883350012958e+03,
  "cx": 7.1694323510126321e+02, "cy": 7.0576498308221585e+02
}"#;
    let d = parse(kitti).unwrap();
    assert_eq!(d.camera.name(), "mei");
    let reference = kitti360_image_02()
        .erased()
        .with_max_theta(200f64.to_radians() / 2.0)
        .unwrap();
    assert_eq!(d.camera.max_theta(), reference.max_theta());
    // serde_json may read a decimal 1 ulp off the nearest double: compare the projections.
    for i in 0..=50 {
        let b = bearing(reference.max_theta() * i as f64 / 50.0, 0.37 * i as f64);
        let (p, q) = (
            d.camera.project(&b).unwrap(),
            reference.project(&b).unwrap(),
        );
        assert!((p - q).norm() < 1e-9, "{p} {q}");
    }
    let eucm = r#"{"version": 1, "model": "eucm", "width": 800, "height": 600, "max_fov_deg": 180,
        "alpha": 0.6, "beta": 1.1, "fx": 300, "fy": 301, "cx": 399.5, "cy": 299.5}"#;
    let d = parse(eucm).unwrap();
    assert_eq!(d.camera.name(), "eucm");
    let p = d.camera.project(&bearing(1.0, 0.3)).unwrap();
    let q = eucm_reference(
        bearing(1.0, 0.3),
        0.6,
        1.1,
        Intrinsics::new(300.0, 301.0, 399.5, 299.5),
    );
    assert!((p - q).norm() < REFERENCE_PX);
    let ds = r#"{"version": 1, "model": "double_sphere", "width": 800, "height": 600, "max_fov_deg": 190,
        "xi": -0.2, "alpha": 0.59, "fx": 300, "cx": 399.5, "cy": 299.5,
        "rotation": {"yaw_deg": 90}}"#;
    let d = parse(ds).unwrap();
    assert_eq!(d.camera.name(), "double_sphere");
    assert!((d.output_from_camera * Vector3::z() - Vector3::x()).norm() < 1e-12);
}

#[track_caller]
fn refused(text: &str, field: &str, line: usize, words: &str) {
    let e = parse(text).unwrap_err().to_string();
    eprintln!("{e}");
    assert!(
        e.starts_with(&format!("cams/side.json:{line}: {field}: ")),
        "{e}"
    );
    assert!(e.contains(words), "{e}");
}

#[test]
fn bad_descriptions_of_the_new_models_name_the_field() {
    let eucm = "{\n\"version\": 1, \"model\": \"eucm\", \"width\": 800, \"height\": 600,\n\"max_fov_deg\": 180,\n\"alpha\": 0.6,\n\"beta\": 1.1,\n\"fx\": 300, \"cx\": 399.5, \"cy\": 299.5\n}";
    refused(&eucm.replace("0.6", "1.6"), "alpha", 4, "[0, 1]");
    refused(&eucm.replace("1.1", "-1"), "beta", 5, "positive");
    refused(
        &eucm.replace("\"beta\": 1.1,", ""),
        "model",
        2,
        "needs the field `beta`",
    );
    // α = 0.6, β = 1.1: w = 2/3, the limit is 2·(π − atan2(√(1 − w²), w·√β)) ≈ 266.5°.
    refused(
        &eucm.replace("180", "350"),
        "max_fov_deg",
        3,
        "can represent",
    );
    refused(
        &eucm.replace("\"alpha\": 0.6,", "\"alpha\": 0.6, \"xi\": 0.1,"),
        "xi",
        4,
        "not used by model Eucm",
    );
    let mei = "{\n\"version\": 1, \"model\": \"mei\", \"width\": 800, \"height\": 600,\n\"max_fov_deg\": 180,\n\"xi\": 1.2,\n\"k\": [0.1, 0.01, 0.3],\n\"fx\": 300, \"cx\": 399.5, \"cy\": 299.5\n}";
    refused(mei, "k", 5, "at most 2");
    refused(
        &mei.replace(", 0.3]", "]").replace("1.2", "-1"),
        "xi",
        4,
        "≥ 0",
    );
    // ξ = 1.2: the limit is 2·acos(−1/ξ) ≈ 292.9°.
    refused(
        &mei.replace(", 0.3]", "]").replace("180", "300"),
        "max_fov_deg",
        3,
        "292.885",
    );
    assert!(parse(&mei.replace(", 0.3]", "]").replace("180", "290")).is_ok());
    refused(
        &mei.replace("\"model\": \"mei\"", "\"model\": \"double_sphere\"")
            .replace("\"k\": [0.1, 0.01, 0.3],", "\"alpha\": 0.5,")
            .replace("1.2", "1.5"),
        "xi",
        4,
        "(-1, 1)",
    );
}
