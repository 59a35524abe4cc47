//! Native calibration files (KITTI-360 YAML, WoodScape JSON, OpenCV FileStorage YAML/JSON)
//! written from documented values or by OpenCV itself, loaded by `--camera` and checked against
//! independent projections; their errors; `panoconv camera convert`.

// Calibration values are written digit for digit as published.
#![allow(clippy::excessive_precision)]

use crate::common::{panoconv, read_text};
use crate::opencv_ref::{opencv_project, run_python};
use nalgebra::{Point2, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::CameraModel;
use std::f64::consts::PI;
use std::path::Path;

/// KITTI-360's `calibration/image_02.yaml`, as published with the dataset.
const KITTI360_IMAGE_02: &str = "%YAML:1.0
---
model_type: MEI
camera_name: image_02
image_width: 1400
image_height: 1400
mirror_parameters:
   xi: 2.2134047507854890e+00
distortion_parameters:
   k1: 1.6798235660113681e-02
   k2: 1.6548773243373522e+00
   p1: 4.2223943394772046e-04
   p2: 4.2462134260997584e-04
projection_parameters:
   gamma1: 1.3363220825849971e+03
   gamma2: 1.3357883350012958e+03
   u0: 7.1694323510126321e+02
   v0: 7.0576498308221585e+02
";

const XI: f64 = 2.2134047507854890;
const K1: f64 = 1.6798235660113681e-02;
const K2: f64 = 1.6548773243373522;
const P1: f64 = 4.2223943394772046e-04;
const P2: f64 = 4.2462134260997584e-04;
const GAMMA: [f64; 4] = [
    1.3363220825849971e+03,
    1.3357883350012958e+03,
    7.1694323510126321e+02,
    7.0576498308221585e+02,
];

/// The front camera (FV) of a WoodScape calibration file (`calibration/*_FV.json`).
const WOODSCAPE_FV: &str = r#"{
    "extrinsic": {
        "quaternion": [0.5946970238045494, -0.5837953694518585, 0.39063952590941586, -0.3910488170060691],
        "translation": [3.7484, 0.0, 0.6577999999999999]
    },
    "intrinsic": {
        "aspect_ratio": 1.0,
        "cx_offset": 3.942,
        "cy_offset": -3.093,
        "height": 966.0,
        "k1": 339.749,
        "k2": -31.988,
        "k3": 48.275,
        "k4": -7.201,
        "model": "radial_poly",
        "poly_order": 4,
        "width": 1280.0
    },
    "name": "FV"
}"#;

/// Max pixel distance allowed from the independent references.
const REFERENCE_PX: f64 = 1e-6;

fn bearing(theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

fn points_within(max_theta: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in 0..=40 {
        for j in 0..16 {
            let range = 0.5 + (i * 3 + j) as f64 % 7.0;
            out.push(
                bearing(
                    max_theta * 0.999 * i as f64 / 40.0,
                    0.2 + PI * j as f64 / 8.0,
                ) * range,
            );
        }
    }
    out
}

fn load(dir: &Path, name: &str, text: &str) -> panoconv::error::Result<CameraDescription> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    CameraDescription::read(&path)
}

#[test]
fn kitti360_yaml_projects_as_opencv_omnidir() {
    let dir = tempfile::tempdir().unwrap();
    let desc = load(dir.path(), "image_02.yaml", KITTI360_IMAGE_02).unwrap();
    let cam = &desc.camera;
    assert_eq!(cam.name(), "mei");
    assert_eq!((cam.size().width, cam.size().height), (1400, 1400));
    // The image corners lie beyond the valid circle: the whole valid field of view, 2·acos(−1/ξ)
    // at most.
    let fov = 2.0 * cam.max_theta().to_degrees();
    eprintln!("kitti-360 image_02: field of view {fov:.2}°");
    assert!(fov <= 2.0 * (-1.0 / XI).acos().to_degrees() + 1e-9 && fov > 230.0);
    let points = points_within(cam.max_theta());
    let k = [
        GAMMA[0], 0.0, GAMMA[2], 0.0, GAMMA[1], GAMMA[3], 0.0, 0.0, 1.0,
    ];
    let reference = opencv_project("omnidir", &points, k, [K1, K2, P1, P2], XI);
    let worst = points
        .iter()
        .zip(&reference)
        .map(|(p, q)| (cam.project_point(p).unwrap() - q).norm())
        .fold(0.0, f64::max);
    eprintln!("kitti-360 image_02.yaml: max {worst:.2e} px from cv2.omnidir");
    assert!(worst <= REFERENCE_PX);
}

/// KITTI-360's `image_03.yaml` values: (ξ, k1, k2, p1, p2, γ1, γ2, u0, v0).
const KITTI360_IMAGE_03: [f64; 9] = [
    2.5535139132482758,
    4.9370396274089505e-02,
    4.5068455478645308,
    1.3477698472982495e-03,
    -7.0340482615055284e-04,
    1.4854388981875156e+03,
    1.4849477411748708e+03,
    6.9888316784030962e+02,
    6.9814541887723055e+02,
];

/// KITTI-360's own projection script (kitti360scripts/helpers/project.py, `cam2image` of the
/// fisheye camera): the MEI model without p1/p2, written out here. `c` as KITTI360_IMAGE_03.
fn kitti360_script(c: &[f64; 9], d: &Vector3<f64>) -> Point2<f64> {
    let s = d.normalize();
    let (x, y) = (s.x / (s.z + c[0]), s.y / (s.z + c[0]));
    let r2 = x * x + y * y;
    let radial = 1.0 + c[1] * r2 + c[2] * r2 * r2;
    Point2::new(c[5] * x * radial + c[7], c[6] * y * radial + c[8])
}

#[test]
fn kitti360_script_without_p1_p2_differs_from_the_full_model() {
    let dir = tempfile::tempdir().unwrap();
    let image_02 = [XI, K1, K2, P1, P2, GAMMA[0], GAMMA[1], GAMMA[2], GAMMA[3]];
    let c = KITTI360_IMAGE_03;
    let image_03_yaml = format!(
        "model_type: MEI\nimage_width: 1400\nimage_height: 1400\nmirror_parameters:\n  xi: {}\n\
         distortion_parameters:\n  k1: {}\n  k2: {}\n  p1: {}\n  p2: {}\n\
         projection_parameters:\n  gamma1: {}\n  gamma2: {}\n  u0: {}\n  v0: {}\n",
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8]
    );
    for (name, text, values) in [
        ("image_02.yaml", KITTI360_IMAGE_02.to_owned(), image_02),
        ("image_03.yaml", image_03_yaml, KITTI360_IMAGE_03),
    ] {
        let cam = load(dir.path(), name, &text).unwrap().camera;
        // Every 2nd pixel of the image that has a ray: where KITTI-360's script puts that ray.
        let (mut worst, mut sum2, mut n, mut within_180) = (0.0f64, 0.0, 0usize, 0.0f64);
        for v in (0..1400).step_by(2) {
            for u in (0..1400).step_by(2) {
                let p = Point2::new(u as f64, v as f64);
                let Ok(d) = cam.unproject(&p) else { continue };
                let e = (kitti360_script(&values, &d) - p).norm();
                worst = worst.max(e);
                if d.z > 0.0 {
                    within_180 = within_180.max(e);
                }
                sum2 += e * e;
                n += 1;
            }
        }
        let rms = (sum2 / n as f64).sqrt();
        eprintln!(
            "kitti-360 {name}, script without p1/p2 vs full model over {n} pixels: max {worst:.3} px, \
             RMS {rms:.3} px, max within 180° {within_180:.3} px"
        );
        // p1, p2 ~ 1e-3 move a pixel by about 2·p·r²·γ: up to a pixel or so at the edge.
        assert!(worst > 0.3 && worst < 5.0, "{name}: {worst}");
        assert!(rms < worst);
    }
}

/// WoodScape's projection (its calibration documentation): ρ(θ) = k1θ + k2θ² + k3θ³ + k4θ⁴,
/// u = ρ·x/χ + cx_offset + W/2 − 0.5, v = ρ·y/χ·aspect_ratio + cy_offset + H/2 − 0.5.
fn woodscape_reference(p: &Vector3<f64>) -> Point2<f64> {
    let k = [339.749, -31.988, 48.275, -7.201];
    let chi = p.x.hypot(p.y);
    let theta = chi.atan2(p.z);
    let rho = k[0] * theta + k[1] * theta.powi(2) + k[2] * theta.powi(3) + k[3] * theta.powi(4);
    Point2::new(
        rho * p.x / chi + 3.942 + 640.0 - 0.5,
        rho * p.y / chi * 1.0 - 3.093 + 483.0 - 0.5,
    )
}

#[test]
fn woodscape_json_projects_as_its_documentation() {
    let dir = tempfile::tempdir().unwrap();
    let cam = load(dir.path(), "00001_FV.json", WOODSCAPE_FV)
        .unwrap()
        .camera;
    assert_eq!(cam.name(), "woodscape");
    let points = points_within(cam.max_theta());
    let worst = points
        .iter()
        .filter(|p| p.x.hypot(p.y) > 1e-9)
        .map(|p| (cam.project_point(p).unwrap() - woodscape_reference(p)).norm())
        .fold(0.0, f64::max);
    // The field of view reaches the farthest image corner and no further.
    let corners = [(-0.5, -0.5), (1279.5, -0.5), (-0.5, 965.5), (1279.5, 965.5)];
    let widest = corners
        .iter()
        .map(|&(u, v)| {
            let d = cam.unproject(&Point2::new(u, v)).unwrap();
            d.x.hypot(d.y).atan2(d.z)
        })
        .fold(0.0, f64::max);
    eprintln!(
        "woodscape FV: max {worst:.2e} px from the documented formula, field of view {:.2}°",
        2.0 * cam.max_theta().to_degrees()
    );
    assert!(worst <= REFERENCE_PX);
    assert!((widest - cam.max_theta()).abs() < 1e-9);
}

/// Writes an OpenCV FileStorage file with cv2 itself and projects points with the same model.
const OPENCV_WRITE: &str = r#"
import sys, json
import numpy as np, cv2
path, model = sys.argv[1], sys.argv[2]
K = np.array([[600.5, 0.0, 640.2], [0.0, 601.5, 480.7], [0.0, 0.0, 1.0]])
fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
fs.write("image_width", 1280)
fs.write("image_height", 960)
fs.write("K", K)
if model == "fisheye":
    fs.write("D", np.array([[0.05, -0.01, 0.002, -0.0003]]))
else:
    fs.write("D", np.array([[-0.2, 0.05, 1e-3, -5e-4]]))
    fs.write("xi", np.array([[1.4]]))
fs.release()
"#;

#[test]
fn opencv_filestorage_files_written_by_opencv_load() {
    let dir = tempfile::tempdir().unwrap();
    let k = [600.5, 0.0, 640.2, 0.0, 601.5, 480.7, 0.0, 0.0, 1.0];
    for (name, model, d, xi) in [
        (
            "fisheye.yaml",
            "fisheye",
            [0.05, -0.01, 0.002, -0.0003],
            0.0,
        ),
        (
            "fisheye.json",
            "fisheye",
            [0.05, -0.01, 0.002, -0.0003],
            0.0,
        ),
        ("omnidir.yaml", "omnidir", [-0.2, 0.05, 1e-3, -5e-4], 1.4),
        ("omnidir.json", "omnidir", [-0.2, 0.05, 1e-3, -5e-4], 1.4),
    ] {
        let path = dir.path().join(name);
        run_python(OPENCV_WRITE, &[path.to_str().unwrap(), model]);
        let cam = CameraDescription::read(&path).unwrap().camera;
        assert_eq!(
            cam.name(),
            if model == "fisheye" {
                "kannala_brandt"
            } else {
                "mei"
            }
        );
        let points: Vec<_> = points_within(cam.max_theta().min(PI / 2.0 * 0.99));
        let reference = opencv_project(model, &points, k, d, xi);
        let worst = points
            .iter()
            .zip(&reference)
            .map(|(p, q)| (cam.project_point(p).unwrap() - q).norm())
            .fold(0.0, f64::max);
        eprintln!(
            "{name}: field of view {:.1}°, max {worst:.2e} px from cv2.{model}",
            2.0 * cam.max_theta().to_degrees()
        );
        assert!(worst <= REFERENCE_PX, "{name}: {worst:e}");
    }
}

#[track_caller]
fn refused(name: &str, text: &str, line: usize, field: &str, words: &str) {
    let dir = tempfile::tempdir().unwrap();
    let e = load(dir.path(), name, text).unwrap_err().to_string();
    eprintln!("{e}");
    let prefix = format!("{}:{line}: {field}: ", dir.path().join(name).display());
    assert!(e.starts_with(&prefix), "{e}\nexpected {prefix}");
    assert!(e.contains(words), "{e}");
}

#[test]
fn bad_native_files_name_the_file_line_and_field() {
    let k = KITTI360_IMAGE_02;
    refused(
        "a.yaml",
        &k.replace("1.6548773243373522e+00", "abc"),
        11,
        "distortion_parameters.k2",
        "not a finite number",
    );
    refused(
        "a.yaml",
        &k.replace("   gamma1: 1.3363220825849971e+03\n", ""),
        14,
        "projection_parameters.gamma1",
        "missing field `gamma1`",
    );
    refused(
        "a.yaml",
        &k.replace("model_type: MEI", "model_type: KANNALA_BRANDT"),
        3,
        "model_type",
        "only MEI",
    );
    refused(
        "a.yaml",
        &k.replace("image_width: 1400", "image_width: -3"),
        5,
        "image_width",
        "positive whole number",
    );
    refused(
        "a.yaml",
        &k.replace("   xi: 2.2134047507854890e+00", "   xi: -2"),
        8,
        "mirror_parameters.xi",
        "≥ 0",
    );
    refused("a.yaml", &k.replace("   k1:", "\tk1:"), 10, "yaml", "tabs");
    refused(
        "a.yaml",
        &k.replace("   p2:", "  p2:"),
        13,
        "yaml",
        "indentation",
    );
    let w = WOODSCAPE_FV;
    refused(
        "w.json",
        &w.replace("radial_poly", "fov"),
        15,
        "intrinsic.model",
        "radial_poly",
    );
    refused(
        "w.json",
        &w.replace("\"k3\": 48.275", "\"k3\": \"x\""),
        13,
        "intrinsic.k3",
        "not a finite number",
    );
    refused(
        "w.json",
        &w.replace("\"width\": 1280.0", "\"width\": 1280.5"),
        17,
        "intrinsic.width",
        "whole number",
    );
    let opencv = "%YAML:1.0\n---\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 600., 0., 640., 0., 600., 480., 0., 0., 1. ]\nD: !!opencv-matrix\n   rows: 1\n   cols: 4\n   dt: d\n   data: [ 0.05, -0.01, 0.002, -0.0003 ]\n";
    refused("o.yaml", opencv, 1, "image_width", "no image size");
    let sized = format!("{opencv}image_width: 1280\nimage_height: 960\n");
    assert!(load(tempfile::tempdir().unwrap().path(), "o.yaml", &sized).is_ok());
    refused(
        "o.yaml",
        &sized.replace("0.002, -0.0003 ]", "0.002 ]"),
        12,
        "D.data",
        "3 values for a 1x4 matrix",
    );
    refused(
        "o.yaml",
        &sized.replace("rows: 3", "rows: 2"),
        7,
        "K.data",
        "9 values for a 2x3",
    );
    let dir = tempfile::tempdir().unwrap();
    let e = load(dir.path(), "x.yaml", "just: a\nfile: 1\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.yaml: not a camera file panoconv knows"),
        "{e}"
    );
}

fn number_after(text: &str, key: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.starts_with(key))
        .unwrap_or_else(|| panic!("no {key} in {text}"));
    line[key.len()..].trim().parse().unwrap()
}

#[test]
fn camera_convert_mei_to_kannala_brandt() {
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("image_02.yaml");
    std::fs::write(&source, KITTI360_IMAGE_02).unwrap();
    let out = dir.path().join("kb.json");
    let run = panoconv([
        "camera".as_ref(),
        "convert".as_ref(),
        source.as_os_str(),
        "--to".as_ref(),
        "kannala_brandt".as_ref(),
        "--max-fov".as_ref(),
        "200".as_ref(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    eprintln!("{}", run.stdout);
    let (rms, max) = (
        number_after(&run.stdout, "rms_px"),
        number_after(&run.stdout, "max_px"),
    );
    assert!(rms > 0.0 && rms <= max);
    // Kannala-Brandt has no tangential terms and no fold at the edge: sub-pixel, not exact.
    assert!(rms < 0.5 && max < 2.0, "rms {rms}, max {max}");
    let written = read_text(&out);
    assert!(
        written.contains("\"model\": \"kannala_brandt\""),
        "{written}"
    );
    let fitted = CameraDescription::read(&out).unwrap().camera;
    let mei = CameraDescription::read(&source).unwrap().camera;
    assert!((2.0 * fitted.max_theta().to_degrees() - 200.0).abs() < 1e-9);
    // On a third grid, neither the fit's nor the report's: the written file projects every ray
    // of the source's pixels within 200° close to where the source does.
    let (mut worst, mut sum2, mut n) = (0.0f64, 0.0, 0usize);
    for v in (0..1400).step_by(5) {
        for u in (0..1400).step_by(5) {
            let p = Point2::new(u as f64 + 0.3, v as f64 + 0.7);
            let Ok(d) = mei.unproject(&p) else { continue };
            if d.x.hypot(d.y).atan2(d.z) > 100f64.to_radians() {
                continue;
            }
            let e = (fitted.project(&d).unwrap() - p).norm();
            worst = worst.max(e);
            sum2 += e * e;
            n += 1;
        }
    }
    let rms3 = (sum2 / n as f64).sqrt();
    eprintln!("written kannala_brandt on {n} other pixels: RMS {rms3:.4} px, max {worst:.4} px");
    assert!(
        (rms3 - rms).abs() <= 0.1 * rms,
        "rms {rms3} vs reported {rms}"
    );
    assert!(worst <= 1.1 * max, "max {worst} vs reported {max}");
    // Refusals: an existing output, a bad field of view.
    let again = panoconv([
        "camera".as_ref(),
        "convert".as_ref(),
        source.as_os_str(),
        "--to".as_ref(),
        "eucm".as_ref(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(again.code, 2);
    assert!(again.stderr.contains("exists"), "{}", again.stderr);
    assert_eq!(read_text(&out), written);
}

#[test]
fn fisheye_command_reads_a_native_file() {
    let dir = tempfile::tempdir().unwrap();
    let camera = dir.path().join("image_02.yaml");
    std::fs::write(&camera, KITTI360_IMAGE_02).unwrap();
    let input = dir.path().join("frames");
    std::fs::create_dir(&input).unwrap();
    let mut img = panoconv::image::RgbImage::new(1400, 1400);
    for v in 0..1400 {
        for u in 0..1400 {
            img.put_pixel(u, v, [(u % 256) as u8, (v % 256) as u8, 128]);
        }
    }
    std::fs::write(
        input.join("0000000000.png"),
        panoconv::codec::png::encode_rgb8(&img, panoconv::codec::png::PngCompression::Fast),
    )
    .unwrap();
    let out = dir.path().join("cyl");
    let run = panoconv([
        "fisheye".as_ref(),
        "--camera".as_ref(),
        camera.as_os_str(),
        "--to".as_ref(),
        "cylindrical".as_ref(),
        "--px-per-deg".as_ref(),
        "2".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
        "-q".as_ref(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(out.join("0000000000.png").exists());
    assert!(read_text(&out.join("panoconv.json")).contains("\"camera_model\": \"mei\""));
}
