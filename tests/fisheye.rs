//! Fisheye cameras: every model's round trips and inversion, refusals, the camera description
//! file, fisheye → cylindrical against exact renders, and the `fisheye` subcommand.

use crate::common;

use crate::common::{panoconv, psnr, read_text};
use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::FisheyeError;
use panoconv::camera::{
    rotation_ypr, CameraModel, Fisheye, ImageSize, Intrinsics, Projection, RadialModel, Rotated,
};
use panoconv::codec::png::{encode_rgb8, PngCompression};
use panoconv::convert::pano::FisheyeView;
use panoconv::geometry::Scale;
use panoconv::image::RgbImage;
use panoconv::tools::synth::{frames, GROUND_Y};
use proptest::prelude::*;
use std::f64::consts::PI;
use std::path::Path;

/// PSNR the issue asks for where the fisheye has data.
const MIN_PSNR_DB: f64 = 45.0;
/// Round trip project(unproject(p)) tolerance, pixels.
const MAX_ROUND_TRIP_PX: f64 = 1e-6;
/// θ(R(θ)) tolerance, radians.
const MAX_INVERSION_RAD: f64 = 1e-6;

/// One camera per model: 640×640 (WoodScape-like 640×483), fisheye circle radius ~310 px.
fn cameras() -> Vec<Fisheye> {
    let size = ImageSize::new(640, 640);
    let c = |f: f64| Intrinsics::new(f, f, 319.5, 319.5);
    let fov190 = 190f64.to_radians();
    let t = fov190 / 2.0;
    let kb = [0.04, -0.012, 0.002, -0.0002];
    let kb_model = RadialModel::KannalaBrandt(kb);
    let ws = [169.87, -15.99, 24.14, -3.6];
    vec![
        Fisheye::new(RadialModel::Equidistant, c(310.0 / t), size, fov190).unwrap(),
        Fisheye::new(
            RadialModel::Equisolid,
            c(310.0 / (2.0 * (t / 2.0).sin())),
            size,
            fov190,
        )
        .unwrap(),
        Fisheye::new(
            RadialModel::Stereographic,
            c(310.0 / (2.0 * (t / 2.0).tan())),
            size,
            fov190,
        )
        .unwrap(),
        Fisheye::new(RadialModel::Orthographic, c(310.0), size, PI).unwrap(),
        Fisheye::new(
            kb_model.clone(),
            Intrinsics::new(
                310.0 / kb_model.radius(t),
                0.98 * 310.0 / kb_model.radius(t),
                321.2,
                317.4,
            ),
            size,
            fov190,
        )
        .unwrap(),
        Fisheye::new(
            RadialModel::Polynomial(ws),
            Intrinsics::new(1.0, 1.0, 319.5 + 1.8, 241.0 - 2.4),
            ImageSize::new(640, 483),
            fov190,
        )
        .unwrap(),
    ]
}

fn bearing(theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

#[test]
fn inversion_is_accurate_over_the_whole_field_of_view() {
    for cam in cameras() {
        let mut worst = 0.0f64;
        let n = 20_000;
        for i in 0..=n {
            let t = cam.max_theta * i as f64 / n as f64;
            let r = cam.model.radius(t);
            let back = cam.theta_of_radius(r);
            worst = worst.max((back - t).abs());
        }
        eprintln!("{}: max |θ(R(θ)) - θ| = {worst:.3e} rad", cam.model.name());
        assert!(worst <= MAX_INVERSION_RAD, "{}: {worst}", cam.model.name());
    }
}

#[test]
fn round_trips_over_the_whole_field_of_view() {
    for cam in cameras() {
        let (mut worst_px, mut worst_rad) = (0.0f64, 0.0f64);
        for i in 0..=400 {
            for j in 0..64 {
                let theta = cam.max_theta * i as f64 / 400.0;
                let phi = 2.0 * PI * j as f64 / 64.0;
                let d = bearing(theta, phi);
                let p = cam.project(&d).unwrap();
                let back = cam.unproject(&p).unwrap();
                worst_rad = worst_rad.max(back.angle(&d));
                let q = cam.project(&back).unwrap();
                worst_px = worst_px.max((q - p).norm());
            }
        }
        eprintln!(
            "{}: round trip max {worst_px:.3e} px, bearing max {worst_rad:.3e} rad",
            cam.model.name()
        );
        assert!(worst_px <= MAX_ROUND_TRIP_PX, "{}", cam.model.name());
        assert!(worst_rad <= MAX_INVERSION_RAD, "{}", cam.model.name());
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn pixel_round_trips(model in 0usize..6, u in -0.5f64..639.5, v in -0.5f64..639.5) {
        let cam = &cameras()[model];
        let p = Point2::new(u, v);
        match cam.unproject(&p) {
            Ok(d) => {
                prop_assert!((d.norm() - 1.0).abs() < 1e-12);
                let q = cam.project(&d).unwrap();
                prop_assert!((q - p).norm() <= MAX_ROUND_TRIP_PX, "{} {p} -> {q}", cam.model.name());
            }
            // Only pixels outside the fisheye circle have no ray.
            Err(_) => {
                let k = cam.k;
                let r = ((u - k.cu) / k.fu).hypot((v - k.cv) / k.fv);
                prop_assert!(r > cam.model.radius(cam.max_theta));
            }
        }
    }

    #[test]
    fn bearing_round_trips(model in 0usize..6, t in 0.0f64..1.0, phi in -PI..PI) {
        let cam = &cameras()[model];
        let d = bearing(t * cam.max_theta, phi);
        let p = cam.project(&d).unwrap();
        let back = cam.unproject(&p).unwrap();
        prop_assert!(back.angle(&d) <= MAX_INVERSION_RAD);
        prop_assert!((cam.project(&back).unwrap() - p).norm() <= MAX_ROUND_TRIP_PX);
    }
}

#[test]
fn beyond_180_degrees_rays_behind_the_image_plane_have_an_image() {
    let cam = &cameras()[0];
    assert!(cam.front_halfspace().is_none());
    let behind = bearing(94f64.to_radians(), 0.3);
    assert!(behind.z < 0.0);
    let p = cam.project(&behind).unwrap();
    assert!(cam.contains(&p));
    assert!(cam.project(&bearing(96f64.to_radians(), 0.3)).is_err());
    // The orthographic camera (180°) sees only its front half-space.
    assert_eq!(cameras()[3].front_halfspace(), Some(Vector3::z()));
    // Outside the circle: no ray.
    assert!(cam.unproject(&Point2::new(0.0, 0.0)).is_err());
}

#[test]
fn non_monotonic_polynomials_are_refused() {
    let size = ImageSize::new(640, 640);
    let k = Intrinsics::new(200.0, 200.0, 319.5, 319.5);
    // θ(1 - 0.3θ²) peaks at θ = 1/sqrt(0.9) ≈ 60.4°.
    let kb = RadialModel::KannalaBrandt([-0.3, 0.0, 0.0, 0.0]);
    match Fisheye::new(kb.clone(), k, size, 190f64.to_radians()) {
        Err(FisheyeError::NotMonotonic(m)) => {
            assert!(m.contains("not strictly increasing"), "{m}");
            assert!(m.contains("60."), "{m}");
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert!(Fisheye::new(kb, k, size, 110f64.to_radians()).is_ok());
    let ws = RadialModel::Polynomial([300.0, 0.0, -200.0, 0.0]);
    assert!(matches!(
        Fisheye::new(ws, k, size, 190f64.to_radians()),
        Err(FisheyeError::NotMonotonic(_))
    ));
    // Orthographic cannot go beyond 180°.
    assert!(matches!(
        Fisheye::new(RadialModel::Orthographic, k, size, 190f64.to_radians()),
        Err(FisheyeError::FieldOfView(_))
    ));
}

// ---------------------------------------------------------------------------------------------
// Warp against exact renders

/// Camera 1.2 m above the ground, pitched 8° down and rolled 2°, levelled by its rotation.
fn mounted(cam: Fisheye) -> CameraDescription {
    CameraDescription {
        camera: cam.into(),
        output_from_camera: rotation_ypr(0.0, -8f64.to_radians(), 2f64.to_radians()),
    }
}

#[test]
fn fisheye_to_cylindrical_matches_the_exact_render() {
    let scene = &frames()[0].scene;
    let centre = Vector3::new(0.0, GROUND_Y - 1.2, 0.0);
    let mut report = Vec::new();
    for cam in cameras() {
        let name = cam.model.name();
        let desc = mounted(cam);
        let source = Rotated::new(desc.camera.clone(), desc.output_from_camera);
        let fisheye_image = scene.render(&source, &centre);
        // Output 1.5x coarser than the fisheye's centre resolution, 160°x90°.
        let spec = FisheyeView {
            projection: Projection::Cylindrical,
            hfov: Some(160f64.to_radians()),
            vfov: Some(90f64.to_radians()),
            scale: Scale::PixelsPerDegree(desc.camera.centre_intrinsics().fu.to_radians() / 1.5),
        };
        let view = spec.plan(&desc).unwrap();
        let warped = view.table.apply(&fisheye_image);
        let world_from_output: Matrix3<f64> = desc.output_from_camera * view.source_from_output;
        let out_cam = Rotated::new(
            panoconv::camera::Cylindrical::new(view.camera.intrinsics(), view.camera.size()),
            world_from_output,
        );
        let inside = |u, v| view.table.is_inside(u, v);
        // `Scene::render` where the table covers
        let exact = common::render_where(scene, &out_cam, &centre, 0.55, 6, inside);
        let (db, n) = psnr(&warped, &exact, inside);
        let s = view.camera.size();
        eprintln!(
            "{name}: {}x{} cylindrical, PSNR {db:.2} dB over {n} px ({:.1} %)",
            s.width,
            s.height,
            100.0 * n as f64 / (s.width * s.height) as f64
        );
        report.push((name, db));
        assert!(
            n as f64 > 0.9 * (s.width * s.height) as f64,
            "{name}: coverage"
        );
    }
    for (name, db) in report {
        assert!(db >= MIN_PSNR_DB, "{name}: PSNR {db:.2} dB < {MIN_PSNR_DB}");
    }
}

// ---------------------------------------------------------------------------------------------
// Camera description files

fn parse(text: &str) -> panoconv::error::Result<CameraDescription> {
    CameraDescription::parse(text, Path::new("cams/front.json"))
}

const GOOD: &str = r#"{
  "version": 1,
  "model": "kannala_brandt",
  "width": 640,
  "height": 480,
  "max_fov_deg": 190,
  "fx": 180.0, "fy": 180.5, "cx": 320.1, "cy": 240.2,
  "k": [0.04, -0.012, 0.002, -0.0002],
  "rotation": {"pitch_deg": -10, "roll_deg": 1.5}
}"#;

#[test]
fn description_files_parse() {
    let d = parse(GOOD).unwrap();
    assert_eq!(d.camera.name(), "kannala_brandt");
    assert_eq!(d.camera.size(), ImageSize::new(640, 480));
    assert!((d.camera.max_theta() - 95f64.to_radians()).abs() < 1e-12);
    let forward = d.output_from_camera * Vector3::z();
    // Pitched down 10°: forward points below the horizon (y down).
    assert!(
        (forward.y - 10f64.to_radians().sin()).abs() < 1e-3,
        "{forward}"
    );
    let ws = r#"{"version": 1, "model": "woodscape", "width": 1280, "height": 966,
        "max_fov_deg": 190, "k": [339.749, -31.988, 48.275, -7.201],
        "aspect_ratio": 1.0, "cx_offset": 3.942, "cy_offset": -3.093,
        "rotation": {"matrix": [[1,0,0],[0,1,0],[0,0,1]]}}"#;
    let d = parse(ws).unwrap();
    assert!((d.camera.intrinsics().cu - (639.5 + 3.942)).abs() < 1e-12);
    assert!((d.camera.intrinsics().cv - (482.5 - 3.093)).abs() < 1e-12);
    for model in ["equidistant", "equisolid", "stereographic", "orthographic"] {
        let t = format!(
            r#"{{"version":1,"model":"{model}","width":100,"height":100,"max_fov_deg":180,"fx":30,"cx":49.5,"cy":49.5}}"#
        );
        assert_eq!(parse(&t).unwrap().camera.name(), model);
    }
}

#[track_caller]
fn refused(text: &str, field: &str, line: usize, words: &str) {
    let e = parse(text).unwrap_err().to_string();
    eprintln!("{e}");
    assert!(
        e.starts_with(&format!("cams/front.json:{line}: {field}: ")),
        "{e}"
    );
    assert!(e.contains(words), "{e}");
}

#[test]
fn bad_description_files_name_the_file_and_the_field() {
    refused(&GOOD.replace("180.0", "\"wide\""), "fx", 7, "invalid type");
    refused(&GOOD.replace("180.0", "\"wide\""), "fx", 7, "column");
    refused(
        &GOOD.replace("\"width\": 640,", ""),
        "width",
        10,
        "missing field",
    );
    refused(&GOOD.replace("\"fy\"", "\"fz\""), "fz", 7, "unknown field");
    refused(
        &GOOD.replace("kannala_brandt", "fisheye"),
        "model",
        3,
        "unknown variant",
    );
    refused(
        &GOOD.replace("\"version\": 1", "\"version\": 2"),
        "version",
        2,
        "version 2",
    );
    refused(&GOOD.replace("190", "400"), "max_fov_deg", 6, "(0, 360)");
    refused(
        &GOOD.replace("0.04", "-0.3"),
        "k",
        8,
        "not strictly increasing",
    );
    refused(
        &GOOD.replace(
            r#""pitch_deg": -10, "roll_deg": 1.5"#,
            r#""matrix": [[1,0,0],[0,1,0],[0,0,2]]"#,
        ),
        "matrix",
        9,
        "not a rotation",
    );
    refused(
        &GOOD.replace("-0.0002]", "-0.0002"),
        "k",
        9,
        "line 9 column 12",
    );
    refused(
        &GOOD.replace("0.002,", "0.002"),
        "json",
        8,
        "expected `,` or `]` at line 8",
    );
}

// ---------------------------------------------------------------------------------------------
// The `fisheye` subcommand

fn write_png(path: &Path, img: &RgbImage) {
    std::fs::write(path, encode_rgb8(img, PngCompression::Fast)).unwrap();
}

const SMALL_CAMERA: &str = r#"{
  "version": 1,
  "model": "equidistant",
  "width": 160,
  "height": 160,
  "max_fov_deg": 190,
  "fx": 47.0, "fy": 47.0, "cx": 79.5, "cy": 79.5,
  "rotation": {"yaw_deg": 0, "pitch_deg": -5, "roll_deg": 0}
}"#;

fn small_fisheye_dir(dir: &Path, n: usize) -> std::path::PathBuf {
    let input = dir.join("frames");
    std::fs::create_dir_all(&input).unwrap();
    let desc = CameraDescription::parse(SMALL_CAMERA, Path::new("x")).unwrap();
    let source = Rotated::new(desc.camera.clone(), desc.output_from_camera);
    let img = frames()[0]
        .scene
        .render(&source, &Vector3::new(0.0, GROUND_Y - 1.2, 0.0));
    for i in 0..n {
        write_png(&input.join(format!("{i:06}.png")), &img);
    }
    std::fs::write(dir.join("front.json"), SMALL_CAMERA).unwrap();
    input
}

#[test]
fn cli_fisheye_to_cylindrical() {
    let tmp = tempfile::tempdir().unwrap();
    let input = small_fisheye_dir(tmp.path(), 3);
    let out = tmp.path().join("cyl");
    let cam = tmp.path().join("front.json");
    let run = panoconv([
        "fisheye".as_ref(),
        "--camera".as_ref(),
        cam.as_os_str(),
        "--to".as_ref(),
        "cylindrical".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    for i in 0..3 {
        let png = common::read_rgb8(&out.join(format!("{i:06}.png")));
        let txt = read_text(&out.join(format!("{i:06}.txt")));
        assert!(txt.starts_with("projection: cylindrical\nK: "), "{txt}");
        let k = common::calib_values(&txt, "K").unwrap();
        assert_eq!(k.len(), 9);
        // Default scale: the fisheye's 47 px/rad; 190° wide, 120° tall (tan 60° each way).
        assert!(
            (k[0] - 47.0).abs() < 1e-9 && (k[4] - 47.0).abs() < 1e-9,
            "{k:?}"
        );
        assert_eq!(png.width, (47.0 * 190f64.to_radians()).ceil() as u32);
        assert_eq!(png.height, (2.0 * 47.0 * 3f64.sqrt()).ceil() as u32);
        let r = common::calib_values(&txt, "R").unwrap();
        // d_src = R d_out: the output's forward axis is pitched 5° up in the camera.
        assert!((r[5] - (-5f64.to_radians()).sin()).abs() < 1e-9, "{r:?}");
    }
    let m = common::read_manifest(&out);
    assert_eq!(m["command"], "fisheye");
    assert_eq!(m["summary"]["converted"], 3);
}

#[test]
fn cli_fisheye_bad_camera_is_a_setup_error() {
    let tmp = tempfile::tempdir().unwrap();
    let input = small_fisheye_dir(tmp.path(), 1);
    let cam = tmp.path().join("front.json");
    std::fs::write(&cam, SMALL_CAMERA.replace("47.0, \"fy\"", "\"47\", \"fy\"")).unwrap();
    let out = tmp.path().join("out");
    let run = panoconv([
        "fisheye".as_ref(),
        "--camera".as_ref(),
        cam.as_os_str(),
        "--to".as_ref(),
        "cylindrical".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr
            .contains(&format!("{}:7: fx: invalid type", cam.display())),
        "{}",
        run.stderr
    );
    assert!(run.stderr.contains("column"), "{}", run.stderr);
    assert!(!out.exists(), "nothing may be written on a set-up error");
}

#[test]
fn cli_fisheye_corrupt_image_fails_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let input = small_fisheye_dir(tmp.path(), 3);
    std::fs::write(input.join("000001.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    // A wrong-size image fails too, naming both sizes.
    write_png(&input.join("000003.png"), &RgbImage::new(100, 80));
    let out = tmp.path().join("out");
    let cam = tmp.path().join("front.json");
    let run = panoconv([
        "fisheye".as_ref(),
        "--camera".as_ref(),
        cam.as_os_str(),
        "--to".as_ref(),
        "equirect".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        out.as_os_str(),
    ]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    let bad = input.join("000001.png");
    assert!(
        run.stderr
            .contains(&format!("{}: cannot decode PNG", bad.display())),
        "{}",
        run.stderr
    );
    assert!(run
        .stderr
        .contains("image is 100x80, the camera description says 160x160"));
    let files = common::tree_files(&out);
    let want: std::collections::BTreeSet<String> = [
        "000000.png",
        "000000.txt",
        "000002.png",
        "000002.txt",
        "panoconv.json",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    assert_eq!(files, want);
    // Output inside the input is refused before anything is written.
    let inside = input.join("out");
    let run = panoconv([
        "fisheye".as_ref(),
        "--camera".as_ref(),
        cam.as_os_str(),
        "--to".as_ref(),
        "cylindrical".as_ref(),
        "--input".as_ref(),
        input.as_os_str(),
        "--output".as_ref(),
        inside.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("inside the input"), "{}", run.stderr);
    assert!(!inside.exists());
}
