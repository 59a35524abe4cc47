//! [`Lens`] as the rest of panoconv uses it: crops and resizes through its affine intrinsics
//! (the half-pixel rule), and descriptions written by `to_json` reading back to the same camera.

use nalgebra::{Matrix3, Vector3};
use panoconv::camera::description::CameraDescription;
use panoconv::camera::{
    rotation_ypr, CameraModel, DoubleSphere, Eucm, Fisheye, ImageSize, Intrinsics, Lens,
    MeiDistortion, RadialModel, Unified,
};
use std::f64::consts::PI;
use std::path::Path;

fn lenses() -> Vec<Lens> {
    let size = ImageSize::new(900, 700);
    let k = Intrinsics::new(300.0, 302.0, 451.2, 349.7);
    let t = 95f64.to_radians();
    vec![
        Lens::from(
            Fisheye::new(
                RadialModel::KannalaBrandt([0.04, -0.012, 0.002, -0.0002]),
                k,
                size,
                2.0 * t,
            )
            .unwrap(),
        ),
        Lens::from(
            Fisheye::new(
                RadialModel::Polynomial([339.749, -31.988, 48.275, -7.201]),
                Intrinsics::new(1.0, 1.02, 453.4, 346.9),
                size,
                2.0 * t,
            )
            .unwrap(),
        ),
        Lens::from(
            Unified::new(
                1.7,
                MeiDistortion {
                    k1: 0.02,
                    k2: 0.8,
                    p1: 4e-4,
                    p2: -3e-4,
                },
                Intrinsics::new(800.0, 801.0, 451.2, 349.7),
                0.9,
                size,
                t,
            )
            .unwrap(),
        ),
        Lens::from(Eucm::new(0.6, 1.1, k, size, t).unwrap()),
        Lens::from(DoubleSphere::new(-0.1, 0.58, k, size, t).unwrap()),
    ]
}

fn bearings(max_theta: f64) -> Vec<Vector3<f64>> {
    (0..=30)
        .flat_map(|i| {
            (0..12).map(move |j| {
                let (t, phi) = (
                    max_theta * i as f64 / 30.0,
                    2.0 * PI * j as f64 / 12.0 + 0.05,
                );
                Vector3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), t.cos())
            })
        })
        .collect()
}

#[test]
fn crops_and_resizes_follow_the_half_pixel_rule() {
    // Crop (x0, y0) then resize by (sx, sy): u' = (u − x0 + 0.5)·sx − 0.5.
    let (x0, y0, sx, sy) = (37.0, 21.0, 0.61, 0.58);
    for lens in lenses() {
        let k = lens.intrinsics();
        let moved = Intrinsics::new(
            k.fu * sx,
            k.fv * sy,
            (k.cu - x0 + 0.5) * sx - 0.5,
            (k.cv - y0 + 0.5) * sy - 0.5,
        );
        let small = lens
            .with_intrinsics(moved, ImageSize::new(500, 380))
            .unwrap();
        assert_eq!(small.max_theta(), lens.max_theta());
        let mut worst = 0.0f64;
        for d in bearings(lens.max_theta()) {
            let p = lens.project(&d).unwrap();
            let q = small.project(&d).unwrap();
            let expected = ((p.x - x0 + 0.5) * sx - 0.5, (p.y - y0 + 0.5) * sy - 0.5);
            worst = worst.max((q.x - expected.0).hypot(q.y - expected.1));
        }
        eprintln!(
            "{}: crop + resize max {worst:.2e} px from the half-pixel rule",
            lens.name()
        );
        assert!(worst < 1e-9, "{}: {worst:e}", lens.name());
    }
}

#[test]
fn written_descriptions_read_back_to_the_same_camera() {
    for lens in lenses() {
        let desc = CameraDescription {
            camera: lens.clone(),
            output_from_camera: rotation_ypr(0.3, -0.1, 0.02),
        };
        let text = desc.to_json(Some("round trip"));
        let back = CameraDescription::parse(&text, Path::new("written.json"))
            .unwrap_or_else(|e| panic!("{}: {e}\n{text}", lens.name()));
        assert_eq!(back.camera.name(), lens.name());
        assert_eq!(back.camera.size(), lens.size());
        assert!((back.camera.max_theta() - lens.max_theta()).abs() < 1e-12);
        let r: Matrix3<f64> = back.output_from_camera - desc.output_from_camera;
        assert!(r.abs().max() < 1e-12);
        let worst = bearings(lens.max_theta())
            .iter()
            .map(|d| (back.camera.project(d).unwrap() - lens.project(d).unwrap()).norm())
            .fold(0.0, f64::max);
        eprintln!("{}: written and read back, max {worst:.2e} px", lens.name());
        assert!(worst < 1e-9, "{}: {worst:e}\n{text}", lens.name());
    }
}
