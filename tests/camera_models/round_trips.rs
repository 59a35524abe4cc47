//! Round trips pixel → ray → pixel and ray → pixel → ray over each model's valid field of
//! view, and exactly the pixels and bearings inside it accepted.

use super::*;
use nalgebra::Point2;
use panoconv::camera::{CameraModel, ProjectionReject};
use std::f64::consts::PI;

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
