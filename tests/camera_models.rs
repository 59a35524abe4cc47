//! The MEI (unified), EUCM and double sphere models: round trips over their valid fields of
//! view, OpenCV's `cv2.omnidir` and `cv2.fisheye` as independent references, the closed forms of
//! the papers written out here, the identities between the models, field-of-view limits, and
//! the camera description fields. This file holds the test cameras the topics share; each
//! topic is a file of `tests/camera_models/`.

// Calibration values are written digit for digit as published.
#![allow(clippy::excessive_precision)]

mod descriptions;
mod references;
mod round_trips;
mod warp;

use nalgebra::Vector3;
use panoconv::camera::{DoubleSphere, Eucm, ImageSize, Intrinsics, Lens, MeiDistortion, Unified};

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
