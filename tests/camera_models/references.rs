//! Independent references: the papers' closed forms written out here, the identities between
//! the models, and OpenCV (`cv2.omnidir`, `cv2.fisheye`).

use super::*;
use crate::opencv_ref::opencv_project;
use nalgebra::Point2;
use panoconv::camera::{CameraModel, Fisheye, Perspective, RadialModel};
use std::f64::consts::PI;

// ---------------------------------------------------------------------------------------------
// Closed forms written out independently of src/camera, and identities between the models

/// EUCM, Usenko et al. 2018 eq. 22, for any point (not only unit bearings).
pub(super) fn eucm_reference(p: Vector3<f64>, alpha: f64, beta: f64, k: Intrinsics) -> Point2<f64> {
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
