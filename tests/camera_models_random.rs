//! Round trips of the MEI, EUCM and double sphere models with random parameters: every bearing
//! of the valid field of view maps to a pixel that maps back to it, and every pixel with a ray
//! maps back to itself, within 1e-6 px.

use nalgebra::{Point2, Vector3};
use panoconv::camera::{
    CameraModel, DoubleSphere, Eucm, ImageSize, Intrinsics, Lens, MeiDistortion, Unified,
};
use proptest::prelude::*;

const ROUND_TRIP_PX: f64 = 1e-6;

fn k() -> Intrinsics {
    Intrinsics::new(400.0, 390.0, 500.3, 400.8)
}

fn size() -> ImageSize {
    ImageSize::new(1000, 800)
}

/// The widest usable half field of view: the limit itself where the image stays bounded,
/// `fraction` of it otherwise.
fn usable(limit: f64, finite: bool, fraction: f64) -> f64 {
    if finite {
        limit
    } else {
        limit * fraction
    }
}

fn lens(model: usize, a: f64, b: f64, d: [f64; 4], skew: f64, fraction: f64) -> Lens {
    match model {
        0 => {
            let (alpha, beta) = (a, 0.3 + 2.7 * b);
            let (limit, finite) = Eucm::fov_limit(alpha, beta);
            Lens::from(
                Eucm::new(alpha, beta, k(), size(), usable(limit, finite, fraction)).unwrap(),
            )
        }
        1 => {
            let (xi, alpha) = (-0.9 + 1.85 * b, a);
            let (limit, finite) = DoubleSphere::fov_limit(xi, alpha);
            Lens::from(
                DoubleSphere::new(xi, alpha, k(), size(), usable(limit, finite, fraction)).unwrap(),
            )
        }
        _ => {
            let xi = 3.0 * b;
            let distortion = MeiDistortion {
                k1: d[0],
                k2: d[1],
                p1: d[2],
                p2: d[3],
            };
            let (limit, finite) = Unified::fov_limit(xi, &distortion);
            let f = Intrinsics::new(k().fu * (1.0 + xi), k().fv * (1.0 + xi), k().cu, k().cv);
            Lens::from(
                Unified::new(
                    xi,
                    distortion,
                    f,
                    skew,
                    size(),
                    usable(limit, finite, fraction),
                )
                .unwrap(),
            )
        }
    }
}

fn distortion() -> impl Strategy<Value = [f64; 4]> {
    (-0.3..0.3f64, -0.1..2.0f64, -2e-3..2e-3f64, -2e-3..2e-3f64)
        .prop_map(|(a, b, c, d)| [a, b, c, d])
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn bearing_pixel_bearing(model in 0usize..3, a in 0.0..1.0f64, b in 0.0..1.0f64, d in distortion(),
                             skew in -1.0..1.0f64, fraction in 0.5..0.97f64, t in 0.0..1.0f64, phi in -3.2..3.2f64) {
        let cam = lens(model, a, b, d, skew, fraction);
        let theta = t * cam.max_theta();
        let bearing = Vector3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
        let p = cam.project(&bearing).unwrap();
        prop_assume!(p.x.abs() < 1e6 && p.y.abs() < 1e6);
        let back = cam.unproject(&p).map_err(|e| TestCaseError::fail(format!("{} {cam:?}: {p} has no ray: {e:?}", cam.name())))?;
        let q = cam.project(&back).unwrap();
        prop_assert!((q - p).norm() <= ROUND_TRIP_PX, "{}: {p} -> {q}", cam.name());
        prop_assert!(back.cross(&bearing).norm().atan2(back.dot(&bearing)) <= 1e-6, "{}", cam.name());
    }

    #[test]
    fn pixel_bearing_pixel(model in 0usize..3, a in 0.0..1.0f64, b in 0.0..1.0f64, d in distortion(),
                           skew in -1.0..1.0f64, fraction in 0.5..0.97f64, u in -0.5..999.5f64, v in -0.5..799.5f64) {
        let cam = lens(model, a, b, d, skew, fraction);
        let p = Point2::new(u, v);
        if let Ok(ray) = cam.unproject(&p) {
            let q = cam.project(&ray).unwrap();
            prop_assert!((q - p).norm() <= ROUND_TRIP_PX, "{}: {p} -> {q}", cam.name());
        }
    }
}
