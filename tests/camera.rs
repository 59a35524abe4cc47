//! Camera models against exact maths: round trips over the whole image and the whole domain,
//! known values, and rejections.

use nalgebra::{Point2, Vector3};
use panoconv::camera::{
    CameraModel, Cylindrical, Equirect, ImageSize, Intrinsics, LinearCamera, Perspective,
    Projection, ProjectionReject,
};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Round-trip tolerances: pixels and radians.
const PX_TOL: f64 = 1e-6;
const ANGLE_TOL: f64 = 1e-9;

fn cameras(fu: f64, fv: f64, cu: f64, cv: f64) -> Vec<Box<dyn LinearCamera>> {
    let k = Intrinsics::new(fu, fv, cu, cv);
    let size = ImageSize::new(1242, 375);
    vec![
        Box::new(Perspective::new(k, size)),
        Box::new(Equirect::new(k, size)),
        Box::new(Cylindrical::new(k, size)),
    ]
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.normalize()
        .cross(&b.normalize())
        .norm()
        .atan2(a.normalize().dot(&b.normalize()))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// project(unproject(p)) == p for every pixel of the image, for every model.
    #[test]
    fn pixel_round_trip(fu in 100.0..2000.0f64, aspect in 0.5..2.0f64, cu in -500.0..1500.0f64, cv in -200.0..600.0f64,
                        u in -0.5..1241.5f64, v in -0.5..374.5f64) {
        for cam in cameras(fu, fu * aspect, cu, cv) {
            let p = Point2::new(u, v);
            let d = match cam.unproject(&p) {
                Ok(d) => d,
                // equirect pixels beyond a pole have no ray; nothing else may be rejected
                Err(ProjectionReject::OutsideDomain) if cam.projection() == Projection::Equirect => {
                    let (_, lat) = cam.intrinsics().from_pixel(u, v);
                    prop_assert!(lat.abs() > FRAC_PI_2);
                    continue;
                }
                Err(e) => return Err(TestCaseError::fail(format!("{:?} rejected {p:?}: {e:?}", cam.projection()))),
            };
            prop_assert!((d.norm() - 1.0).abs() < 1e-12, "bearing not unit");
            let mut q = cam.project(&d).unwrap();
            // 360° models are periodic in u: compare modulo one turn
            if let Some(period) = cam.horizontal_period() {
                q.x = p.x + (q.x - p.x + period / 2.0).rem_euclid(period) - period / 2.0;
            }
            prop_assert!((q - p).norm() < PX_TOL, "{:?}: {p:?} -> {q:?}", cam.projection());
        }
    }

    /// unproject(project(d)) == d over each model's whole domain, including behind the camera
    /// for the 360° models.
    #[test]
    fn bearing_round_trip(x in -1.0..1.0f64, y in -1.0..1.0f64, z in -1.0..1.0f64) {
        let d = Vector3::new(x, y, z);
        prop_assume!(d.norm() > 1e-3);
        let d = d.normalize();
        for cam in cameras(721.5, 721.5, 609.6, 172.9) {
            match cam.project(&d) {
                Ok(p) => {
                    let back = cam.unproject(&p).unwrap();
                    prop_assert!(angle(&back, &d) < ANGLE_TOL, "{:?}: {d:?} -> {back:?}", cam.projection());
                }
                Err(ProjectionReject::BehindCamera) => {
                    prop_assert_eq!(cam.projection(), Projection::Perspective);
                    prop_assert!(d.z <= 1e-9);
                }
                Err(ProjectionReject::Singular) => {
                    prop_assert_eq!(cam.projection(), Projection::Cylindrical);
                    prop_assert!(d.x.hypot(d.z) < 1e-8);
                }
                Err(e) => return Err(TestCaseError::fail(format!("{:?}: {e:?}", cam.projection()))),
            }
        }
    }
}

#[test]
fn equirect_known_values_use_atan2_behind_the_camera() {
    let k = Intrinsics::new(100.0, 100.0, 500.0, 250.0);
    let cam = Equirect::new(k, ImageSize::new(1000, 500));
    let px = |d: Vector3<f64>| cam.project(&d.normalize()).unwrap();
    assert!((px(Vector3::z()) - Point2::new(500.0, 250.0)).norm() < 1e-12);
    assert!((px(Vector3::x()) - Point2::new(500.0 + 100.0 * FRAC_PI_2, 250.0)).norm() < 1e-12);
    // straight behind: longitude ±π, never 0 (arctan(x/z) would say 0)
    let behind = px(Vector3::new(1e-12, 0.0, -1.0));
    assert!((behind.x - (500.0 + 100.0 * PI)).abs() < 1e-6, "{behind:?}");
    let behind_left = px(Vector3::new(-1.0, 0.0, -1.0));
    assert!((behind_left.x - (500.0 - 100.0 * 3.0 * PI / 4.0)).abs() < 1e-9);
    // y down: a point below the horizon has positive latitude
    let below = px(Vector3::new(0.0, 1.0, 1.0));
    assert!((below.y - (250.0 + 100.0 * PI / 4.0)).abs() < 1e-9);
    assert!((cam.distance(&Vector3::new(3.0, 4.0, 12.0)) - 13.0).abs() < 1e-12);
}

#[test]
fn equirect_clamps_at_the_poles() {
    let cam = Equirect::new(
        Intrinsics::new(100.0, 100.0, 500.0, 250.0),
        ImageSize::new(1000, 500),
    );
    let pole = cam
        .unproject(&Point2::new(10.0, 250.0 + 100.0 * FRAC_PI_2))
        .unwrap();
    assert!(angle(&pole, &Vector3::y()) < 1e-12);
    assert_eq!(
        cam.unproject(&Point2::new(10.0, 250.0 + 100.0 * FRAC_PI_2 + 0.01)),
        Err(ProjectionReject::OutsideDomain)
    );
}

#[test]
fn cylindrical_known_values_and_rho() {
    let cam = Cylindrical::new(
        Intrinsics::new(200.0, 150.0, 300.0, 100.0),
        ImageSize::new(600, 200),
    );
    // (x, y, z) = (1, 0.5, 1): φ = π/4, h = 0.5/√2, rho = √2
    let p = cam.project_point(&Vector3::new(1.0, 0.5, 1.0)).unwrap();
    assert!((p.x - (300.0 + 200.0 * PI / 4.0)).abs() < 1e-9);
    assert!((p.y - (100.0 + 150.0 * 0.5 / 2f64.sqrt())).abs() < 1e-9);
    assert!((cam.distance(&Vector3::new(1.0, 0.5, 1.0)) - 2f64.sqrt()).abs() < 1e-12);
    assert_eq!(cam.project(&Vector3::y()), Err(ProjectionReject::Singular));
    assert_eq!(cam.project(&-Vector3::y()), Err(ProjectionReject::Singular));
}

#[test]
fn perspective_rejects_the_back_half_space() {
    let cam = Perspective::new(
        Intrinsics::new(721.5, 721.5, 609.6, 172.9),
        ImageSize::new(1242, 375),
    );
    assert_eq!(
        cam.project(&-Vector3::z()),
        Err(ProjectionReject::BehindCamera)
    );
    assert_eq!(
        cam.project(&Vector3::x()),
        Err(ProjectionReject::BehindCamera)
    );
    assert!(cam
        .project(&Vector3::new(0.1, 0.0, 1.0).normalize())
        .is_ok());
    assert_eq!(cam.distance(&Vector3::new(3.0, 4.0, 12.0)), 12.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    /// The batch paths are the per-pixel ones bit for bit: a row of pixels unprojected by
    /// column and row shares gives `unproject`'s bearings (and rejections, beyond the poles
    /// and for non-finite positions), and `project_all` gives `project`'s pixels.
    #[test]
    fn batch_paths_equal_the_per_pixel_ones(fu in 50.0..2000.0f64, aspect in 0.5..2.0f64,
                                            cu in -500.0..1500.0f64, cv in -200.0..600.0f64,
                                            v in -2000.0..2000.0f64, x in -1.0..1.0f64,
                                            y in -1.0..1.0f64, z in -1.0..1.0f64) {
        let us = [-1e9, -700.0, -0.5, 0.0, 0.25, 17.3, 640.75, 1241.0, 5000.0, f64::NAN];
        for cam in cameras(fu, fu * aspect, cu, cv) {
            let sep = cam.separable().expect("a linear camera separates");
            let columns: Vec<_> = us.iter().map(|&u| sep.column(u)).collect();
            for v in [v, f64::INFINITY] {
                let mut batch = Vec::new();
                sep.bearings(&columns, sep.row(v), &mut batch);
                prop_assert_eq!(batch.len(), us.len());
                for (&u, d) in us.iter().zip(&batch) {
                    let one = cam.unproject(&Point2::new(u, v)).ok();
                    // bit for bit: the same arithmetic, not merely close
                    let bits = |d: Option<Vector3<f64>>| d.map(|d| d.map(f64::to_bits));
                    prop_assert_eq!(bits(*d), bits(one), "{:?} at ({}, {})", cam.projection(), u, v);
                }
            }
            let bearings = [Some(Vector3::new(x, y, z)), None, Some(Vector3::new(0.0, 1.0, 0.0)),
                            Some(Vector3::new(-x, y, -z.abs()))];
            let mut pixels = Vec::new();
            cam.project_all(&bearings, &mut pixels);
            let one: Vec<_> = bearings.iter().map(|d| cam.project(d.as_ref()?).ok()).collect();
            let bits = |p: &[Option<Point2<f64>>]| -> Vec<_> {
                p.iter().map(|p| p.map(|p| (p.x.to_bits(), p.y.to_bits()))).collect()
            };
            prop_assert_eq!(bits(&pixels), bits(&one), "{:?}", cam.projection());
        }
    }
}
