//! The MEI (unified), EUCM and double sphere models: round trips over their valid fields of
//! view, OpenCV's `cv2.omnidir` and `cv2.fisheye` as independent references, the closed forms of
//! the papers written out here, the identities between the models, field-of-view limits, and
//! the camera description fields.

// Calibration values are written digit for digit as published.
#![allow(clippy::excessive_precision)]

use nalgebra::{Point2, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::{
    CameraModel, DoubleSphere, Eucm, Fisheye, ImageSize, Intrinsics, Lens, MeiDistortion,
    Perspective, ProjectionReject, RadialModel, Unified,
};
use std::f64::consts::PI;
use std::path::Path;

use crate::opencv_ref::opencv_project;

/// Round trip pixel → ray → pixel, pixels.
const ROUND_TRIP_PX: f64 = 1e-6;
/// Agreement with OpenCV and with the closed forms written here, pixels.
const REFERENCE_PX: f64 = 1e-6;

/// KITTI-360's published calibration of `image_02` (calibration/image_02.yaml).
fn kitti360_image_02() -> Unified {
    mei(
        2.2134047507854890,
        [
            1.6798235660113681e-02,
            1.6548773243373522,
            4.2223943394772046e-04,
            4.2462134260997584e-04,
        ],
        [
            1.3363220825849971e+03,
            1.3357883350012958e+03,
            7.1694323510126321e+02,
            7.0576498308221585e+02,
        ],
        0.0,
        None,
    )
}

/// KITTI-360's `image_03`.
fn kitti360_image_03() -> Unified {
    mei(
        2.5535139132482758,
        [
            4.9370396274089505e-02,
            4.5068455478645308,
            1.3477698472982495e-03,
            -7.0340482615055284e-04,
        ],
        [
            1.4854388981875156e+03,
            1.4849477411748708e+03,
            6.9888316784030962e+02,
            6.9814541887723055e+02,
        ],
        0.0,
        None,
    )
}

/// A MEI camera at its whole valid field of view (`max_theta` None) on a 1400×1400 image.
fn mei(xi: f64, d: [f64; 4], k: [f64; 4], skew: f64, max_theta: Option<f64>) -> Unified {
    let distortion = MeiDistortion {
        k1: d[0],
        k2: d[1],
        p1: d[2],
        p2: d[3],
    };
    let (limit, _) = Unified::fov_limit(xi, &distortion);
    Unified::new(
        xi,
        distortion,
        Intrinsics::new(k[0], k[1], k[2], k[3]),
        skew,
        ImageSize::new(1400, 1400),
        max_theta.unwrap_or(limit),
    )
    .unwrap()
}

/// One camera per new model and regime (image radius bounded or not at the limit).
fn cameras() -> Vec<(&'static str, Lens)> {
    let size = ImageSize::new(1024, 768);
    let k = Intrinsics::new(350.0, 352.0, 511.0, 384.5);
    vec![
        ("mei kitti-360 image_02", Lens::from(kitti360_image_02())),
        ("mei kitti-360 image_03", Lens::from(kitti360_image_03())),
        (
            "mei xi<1 skewed",
            Lens::from(mei(
                0.8,
                [-0.15, 0.03, 2e-3, -1e-3],
                [600.0, 598.0, 700.3, 699.1],
                0.7,
                Some(100f64.to_radians()),
            )),
        ),
        (
            "eucm alpha>0.5",
            Lens::from(Eucm::new(0.62, 1.08, k, size, Eucm::fov_limit(0.62, 1.08).0).unwrap()),
        ),
        (
            "eucm alpha<0.5",
            Lens::from(Eucm::new(0.4, 0.9, k, size, 110f64.to_radians()).unwrap()),
        ),
        (
            "double sphere alpha>0.5",
            Lens::from(
                DoubleSphere::new(-0.2, 0.59, k, size, DoubleSphere::fov_limit(-0.2, 0.59).0)
                    .unwrap(),
            ),
        ),
        (
            "double sphere alpha<0.5",
            Lens::from(DoubleSphere::new(0.5, 0.45, k, size, 105f64.to_radians()).unwrap()),
        ),
    ]
}

fn theta_of(d: &Vector3<f64>) -> f64 {
    d.x.hypot(d.y).atan2(d.z)
}

/// The angle between two vectors, accurate for tiny angles too (unlike acos of the dot product).
fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

fn bearing(theta: f64, phi: f64) -> Vector3<f64> {
    Vector3::new(
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    )
}

#[test]
fn pixel_ray_pixel_round_trips_over_every_pixel_with_a_ray() {
    for (name, cam) in cameras() {
        let s = cam.size();
        let (mut worst, mut with_ray, mut without) = (0.0f64, 0usize, 0usize);
        // Every 4th pixel and the image's edges, at sub-pixel offsets.
        for j in (0..=s.height * 2).step_by(7) {
            for i in (0..=s.width * 2).step_by(7) {
                let p = Point2::new(i as f64 / 2.0 - 0.5, j as f64 / 2.0 - 0.5);
                match cam.unproject(&p) {
                    Ok(d) => {
                        assert!((d.norm() - 1.0).abs() < 1e-12, "{name}");
                        assert!(theta_of(&d) <= cam.max_theta() * (1.0 + 1e-9), "{name}");
                        let q = cam.project(&d).unwrap();
                        worst = worst.max((q - p).norm());
                        with_ray += 1;
                    }
                    Err(e) => {
                        assert_eq!(e, ProjectionReject::OutsideDomain, "{name}");
                        without += 1;
                    }
                }
            }
        }
        eprintln!(
            "{name}: {with_ray} pixels with a ray ({without} outside the field of view), round trip max {worst:.2e} px"
        );
        assert!(with_ray > 1000, "{name}: too few pixels with a ray");
        assert!(worst <= ROUND_TRIP_PX, "{name}: {worst:e} px");
    }
}

/// Whether `p` lies inside the closed polygon `poly` (even-odd rule).
fn inside(poly: &[Point2<f64>], p: &Point2<f64>) -> bool {
    let mut c = false;
    for (i, a) in poly.iter().enumerate() {
        let b = &poly[(i + 1) % poly.len()];
        if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) {
            c = !c;
        }
    }
    c
}

/// Distance from `p` to the polygon's edges.
fn distance_to(poly: &[Point2<f64>], p: &Point2<f64>) -> f64 {
    (0..poly.len())
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            let t = ((p - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
            (p - (a + (b - a) * t)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// A pixel has a ray exactly when it lies inside the image of the field of view's edge (the
/// curve of θ = max_theta), so that no pixel is refused wrongly (e.g. by an undistortion that
/// converged to a folded solution).
#[test]
fn exactly_the_pixels_inside_the_field_of_view_have_a_ray() {
    for (name, cam) in cameras() {
        let edge: Vec<Point2<f64>> = (0..2000)
            .map(|j| {
                cam.project(&bearing(cam.max_theta(), 2.0 * PI * j as f64 / 2000.0))
                    .unwrap()
            })
            .collect();
        let s = cam.size();
        let mut disagreements = 0usize;
        let mut worst = 0.0f64;
        for v in (0..s.height).step_by(4) {
            for u in (0..s.width).step_by(4) {
                let p = Point2::new(u as f64 + 0.25, v as f64 + 0.5);
                if cam.unproject(&p).is_ok() != inside(&edge, &p) {
                    disagreements += 1;
                    worst = worst.max(distance_to(&edge, &p));
                }
            }
        }
        eprintln!("{name}: {disagreements} pixels disagree with the edge curve, at most {worst:.3} px from it");
        // The edge is a polygon of 2000 chords: pixels within a hair of it may go either way.
        assert!(worst < 0.05, "{name}: {worst} px");
    }
}

#[test]
fn ray_pixel_ray_round_trips_over_the_valid_field_of_view() {
    for (name, cam) in cameras() {
        let (mut worst_rad, mut worst_px) = (0.0f64, 0.0f64);
        for i in 0..=500 {
            for j in 0..72 {
                let t = cam.max_theta() * i as f64 / 500.0;
                let d = bearing(t, 2.0 * PI * j as f64 / 72.0);
                let p = cam.project(&d).unwrap();
                if !(p.x.abs() < 1e7 && p.y.abs() < 1e7) {
                    continue; // the unbounded models near their limit
                }
                let back = cam.unproject(&p).unwrap();
                // Where the image radius peaks (ξ > 1, α > 0.5) the angle is ill-conditioned
                // at the very edge; the pixel round trip is checked everywhere.
                if i < 495 {
                    worst_rad = worst_rad.max(angle_between(&back, &d));
                }
                worst_px = worst_px.max((cam.project(&back).unwrap() - p).norm());
            }
        }
        eprintln!("{name}: ray round trip max {worst_rad:.2e} rad, {worst_px:.2e} px");
        assert!(worst_rad <= 1e-9, "{name}: {worst_rad:e} rad");
        assert!(worst_px <= ROUND_TRIP_PX, "{name}: {worst_px:e} px");
    }
}

#[test]
fn bearings_beyond_the_field_of_view_are_rejected() {
    for (name, cam) in cameras() {
        let beyond = bearing(cam.max_theta() + 1e-6, 0.4);
        assert_eq!(
            cam.project(&beyond),
            Err(ProjectionReject::OutsideDomain),
            "{name}"
        );
        assert!(
            cam.project(&bearing(cam.max_theta() - 1e-6, 0.4)).is_ok(),
            "{name}"
        );
    }
    // KITTI-360 image_02: ξ > 1, so the limit is acos(−1/ξ) = 116.9° (a 233.7° field of view)
    // unless the distortion folds earlier.
    let (limit, finite) =
        Unified::fov_limit(2.2134047507854890, &kitti360_image_02().model.distortion);
    eprintln!(
        "kitti-360 image_02: valid field of view {:.2}°",
        2.0 * limit.to_degrees()
    );
    assert!(finite);
    assert!(limit <= (-1.0f64 / 2.2134047507854890).acos() + 1e-12);
    assert!(limit > 100f64.to_radians());
    // Asking for more than the model's limit is refused.
    assert!(Eucm::new(
        0.7,
        1.0,
        Intrinsics::new(300.0, 300.0, 300.0, 300.0),
        ImageSize::new(600, 600),
        2.1
    )
    .is_err());
}

// ---------------------------------------------------------------------------------------------
// Closed forms written out independently of src/camera, and identities between the models

/// EUCM, Usenko et al. 2018 eq. 22, for any point (not only unit bearings).
fn eucm_reference(p: Vector3<f64>, alpha: f64, beta: f64, k: Intrinsics) -> Point2<f64> {
    let d = (beta * (p.x * p.x + p.y * p.y) + p.z * p.z).sqrt();
    let den = alpha * d + (1.0 - alpha) * p.z;
    Point2::new(k.fu * p.x / den + k.cu, k.fv * p.y / den + k.cv)
}

/// Double sphere, Usenko et al. 2018 eqs. 40-42.
fn double_sphere_reference(p: Vector3<f64>, xi: f64, alpha: f64, k: Intrinsics) -> Point2<f64> {
    let d1 = p.norm();
    let zs = xi * d1 + p.z;
    let d2 = (p.x * p.x + p.y * p.y + zs * zs).sqrt();
    let den = alpha * d2 + (1.0 - alpha) * zs;
    Point2::new(k.fu * p.x / den + k.cu, k.fv * p.y / den + k.cv)
}

/// Points at 0.3..40 m over a model's field of view.
fn scene_points(max_theta: f64) -> Vec<Vector3<f64>> {
    let mut out = Vec::new();
    for i in 0..=60 {
        for j in 0..24 {
            let t = max_theta * 0.999 * i as f64 / 60.0;
            let range = 0.3 + 40.0 * ((i * 7 + j * 3) % 11) as f64 / 10.0;
            out.push(bearing(t, 2.0 * PI * j as f64 / 24.0 + 0.1) * range);
        }
    }
    out
}

#[test]
fn eucm_and_double_sphere_match_the_papers_equations() {
    let k = Intrinsics::new(350.0, 352.0, 511.0, 384.5);
    let size = ImageSize::new(1024, 768);
    for (alpha, beta) in [(0.62, 1.08), (0.4, 0.9), (0.5, 1.0), (1.0, 0.7)] {
        let limit = Eucm::fov_limit(alpha, beta).0;
        let cam = Eucm::new(alpha, beta, k, size, limit * 0.98).unwrap();
        let mut worst = 0.0f64;
        for p in scene_points(cam.max_theta) {
            let got = cam.project_point(&p).unwrap();
            worst = worst.max((got - eucm_reference(p, alpha, beta, k)).norm());
        }
        eprintln!("eucm α {alpha} β {beta}: max {worst:.2e} px from eq. 22");
        assert!(worst <= REFERENCE_PX);
    }
    for (xi, alpha) in [(-0.2, 0.59), (0.5, 0.45), (0.0, 0.5), (0.8, 0.7)] {
        let limit = DoubleSphere::fov_limit(xi, alpha).0;
        let cam = DoubleSphere::new(xi, alpha, k, size, limit * 0.98).unwrap();
        let mut worst = 0.0f64;
        for p in scene_points(cam.max_theta) {
            let got = cam.project_point(&p).unwrap();
            worst = worst.max((got - double_sphere_reference(p, xi, alpha, k)).norm());
        }
        eprintln!("double sphere ξ {xi} α {alpha}: max {worst:.2e} px from eqs. 40-42");
        assert!(worst <= REFERENCE_PX);
    }
}

type Camera = Box<dyn CameraModel>;

/// Max pixel distance between two cameras over bearings up to `max_theta`.
fn max_difference(a: &dyn CameraModel, b: &dyn CameraModel, max_theta: f64) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..=200 {
        for j in 0..36 {
            let d = bearing(max_theta * i as f64 / 200.0, 2.0 * PI * j as f64 / 36.0);
            worst = worst.max((a.project(&d).unwrap() - b.project(&d).unwrap()).norm());
        }
    }
    worst
}

#[test]
fn identities_between_the_models() {
    let k = Intrinsics::new(300.0, 305.0, 400.2, 299.7);
    let size = ImageSize::new(800, 600);
    let t = 80f64.to_radians();
    let pinhole = Perspective::new(k, size);
    let stereographic = Fisheye::new(RadialModel::Stereographic, k, size, 2.0 * t).unwrap();
    let half_k = Intrinsics::new(k.fu / 2.0, k.fv / 2.0, k.cu, k.cv);
    let stereographic_half =
        Fisheye::new(RadialModel::Stereographic, half_k, size, 2.0 * t).unwrap();
    let no_distortion = MeiDistortion::NONE;
    let cases: Vec<(&str, Camera, Camera)> = vec![
        // Double sphere with ξ = 0 is EUCM with β = 1 (Usenko et al., sec. III-E).
        (
            "double sphere ξ=0 = eucm β=1",
            Box::new(DoubleSphere::new(0.0, 0.63, k, size, t).unwrap()),
            Box::new(Eucm::new(0.63, 1.0, k, size, t).unwrap()),
        ),
        // Double sphere with α = 0 is the unified model with the same ξ.
        (
            "double sphere α=0 = mei without distortion",
            Box::new(DoubleSphere::new(0.7, 0.0, k, size, t).unwrap()),
            Box::new(Unified::new(0.7, no_distortion, k, 0.0, size, t).unwrap()),
        ),
        // EUCM with α = 0 is the pinhole camera.
        (
            "eucm α=0 = pinhole",
            Box::new(Eucm::new(0.0, 1.3, k, size, t).unwrap()),
            Box::new(pinhole.clone()),
        ),
        // EUCM with α = 0.5, β = 1 is stereographic, r = 2 tan(θ/2).
        (
            "eucm α=0.5 β=1 = stereographic",
            Box::new(Eucm::new(0.5, 1.0, k, size, t).unwrap()),
            Box::new(stereographic),
        ),
        // The unified model with ξ = 0 is the pinhole camera, with ξ = 1 stereographic at f/2.
        (
            "mei ξ=0 = pinhole",
            Box::new(Unified::new(0.0, no_distortion, k, 0.0, size, t).unwrap()),
            Box::new(pinhole),
        ),
        (
            "mei ξ=1 = stereographic f/2",
            Box::new(Unified::new(1.0, no_distortion, k, 0.0, size, t).unwrap()),
            Box::new(stereographic_half),
        ),
    ];
    for (name, a, b) in cases {
        let worst = max_difference(a.as_ref(), b.as_ref(), t);
        eprintln!("{name}: max {worst:.2e} px");
        assert!(worst <= REFERENCE_PX, "{name}: {worst:e} px");
    }
}

// ---------------------------------------------------------------------------------------------
// OpenCV as the reference

#[test]
fn mei_matches_opencv_omnidir() {
    let skewed = mei(
        0.8,
        [-0.15, 0.03, 2e-3, -1e-3],
        [600.0, 598.0, 700.3, 699.1],
        0.7,
        Some(100f64.to_radians()),
    );
    for (name, cam) in [
        ("kitti-360 image_02", kitti360_image_02()),
        ("kitti-360 image_03", kitti360_image_03()),
        ("xi<1 skewed", skewed),
    ] {
        let points = scene_points(cam.max_theta);
        let k = [
            cam.k.fu,
            cam.model.skew,
            cam.k.cu,
            0.0,
            cam.k.fv,
            cam.k.cv,
            0.0,
            0.0,
            1.0,
        ];
        let d = cam.model.distortion;
        let reference = opencv_project(
            "omnidir",
            &points,
            k,
            [d.k1, d.k2, d.p1, d.p2],
            cam.model.xi,
        );
        let mut worst = 0.0f64;
        for (p, q) in points.iter().zip(&reference) {
            worst = worst.max((cam.project_point(p).unwrap() - q).norm());
        }
        eprintln!(
            "mei {name}: max {worst:.2e} px from cv2.omnidir.projectPoints over {} points up to θ = {:.1}°",
            points.len(),
            cam.max_theta.to_degrees()
        );
        assert!(worst <= REFERENCE_PX, "{name}: {worst:e} px");
    }
}

#[test]
fn kannala_brandt_matches_opencv_fisheye() {
    let k = Intrinsics::new(330.2, 330.9, 641.3, 480.7);
    let coefficients = [0.04, -0.012, 0.002, -0.0002];
    // cv2.fisheye works through the pinhole point: z > 0 only.
    let cam = Fisheye::new(
        RadialModel::KannalaBrandt(coefficients),
        k,
        ImageSize::new(1280, 966),
        PI * 0.999,
    )
    .unwrap();
    let points = scene_points(cam.max_theta);
    let reference = opencv_project("fisheye", &points, k.matrix(), coefficients, 0.0);
    let mut worst = 0.0f64;
    for (p, q) in points.iter().zip(&reference) {
        worst = worst.max((cam.project_point(p).unwrap() - q).norm());
    }
    eprintln!(
        "kannala-brandt: max {worst:.2e} px from cv2.fisheye.projectPoints over {} points",
        points.len()
    );
    assert!(worst <= REFERENCE_PX, "{worst:e} px");
}

// ---------------------------------------------------------------------------------------------
// Camera description fields

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

// ---------------------------------------------------------------------------------------------
// The new models as sources of `panoconv fisheye`'s warp

/// PSNR over the pixels `mask` keeps.
fn psnr(
    a: &panoconv::image::RgbImage,
    b: &panoconv::image::RgbImage,
    mask: impl Fn(u32, u32) -> bool,
) -> (f64, usize) {
    let (mut se, mut n) = (0.0, 0usize);
    for v in 0..a.height() {
        for u in 0..a.width() {
            if mask(u, v) {
                let (p, q) = (a.pixel(u, v), b.pixel(u, v));
                se += (0..3)
                    .map(|c| (p[c] as f64 - q[c] as f64).powi(2))
                    .sum::<f64>();
                n += 1;
            }
        }
    }
    (10.0 * (255.0f64.powi(2) / (se / (3 * n) as f64)).log10(), n)
}

#[test]
fn fisheye_to_cylindrical_matches_the_exact_render_for_the_new_models() {
    use panoconv::camera::{rotation_ypr, Cylindrical, Projection, Rotated};
    use panoconv::convert::pano::FisheyeView;
    use panoconv::geometry::Scale;
    let scene = &panoconv::tools::synth::frames()[0].scene;
    let centre = Vector3::new(0.0, panoconv::tools::synth::GROUND_Y - 1.2, 0.0);
    for (name, cam) in cameras() {
        // A 480-pixel-wide version of each camera (the affine part scaled by the half-pixel
        // rule), so that the renders stay quick.
        let s = cam.size();
        let scale = 480.0 / s.width as f64;
        let k = cam.intrinsics();
        let size = ImageSize::new(480, (s.height as f64 * scale).round() as u32);
        let k = Intrinsics::new(
            k.fu * scale,
            k.fv * scale,
            (k.cu + 0.5) * scale - 0.5,
            (k.cv + 0.5) * scale - 0.5,
        );
        let desc = CameraDescription {
            camera: cam.with_intrinsics(k, size).unwrap(),
            output_from_camera: rotation_ypr(0.0, -8f64.to_radians(), 2f64.to_radians()),
        };
        let source = Rotated::new(desc.camera.clone(), desc.output_from_camera);
        let fisheye_image = scene.render(&source, &centre);
        let spec = FisheyeView {
            projection: Projection::Cylindrical,
            hfov: Some(160f64.to_radians()),
            vfov: Some(80f64.to_radians()),
            scale: Scale::PixelsPerDegree(desc.camera.centre_intrinsics().fu.to_radians() / 1.5),
        };
        let view = spec.plan(&desc).unwrap();
        let warped = view.table.apply(&fisheye_image);
        let out_cam = Rotated::new(
            Cylindrical::new(view.camera.intrinsics(), view.camera.size()),
            desc.output_from_camera * view.source_from_output,
        );
        let inside = |u, v| view.table.is_inside(u, v);
        // `Scene::render` where the table covers
        let exact = crate::common::render_where(scene, &out_cam, &centre, 0.55, 6, inside);
        let (db, n) = psnr(&warped, &exact, inside);
        let total = (view.camera.size().width * view.camera.size().height) as usize;
        eprintln!("{name}: PSNR {db:.2} dB over {n} of {total} px");
        assert!(n > total / 2, "{name}: coverage {n}/{total}");
        assert!(db >= 45.0, "{name}: {db:.2} dB");
    }
}
