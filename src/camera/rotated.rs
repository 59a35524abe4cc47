//! A camera turned relative to a reference frame, and the yaw/pitch/roll convention.
//!
//! Angles (degrees in files, radians here), all in the x right / y down / z forward frame:
//! yaw turns the camera to the right (its forward axis towards +x), pitch tilts it up (forward
//! towards −y), roll turns it clockwise as seen from behind (its right axis towards +y, down).
//! The camera's axes in the reference frame are `R = Ry(yaw) · Rx(pitch) · Rz(roll)`: a bearing
//! d in camera axes is `R · d` in the reference frame.

use super::{CameraModel, ImageSize, ProjectionReject};
use nalgebra::{Matrix3, Point2, Rotation3, Vector3};

/// `reference_from_camera` for yaw, pitch and roll in radians (convention above).
pub fn rotation_ypr(yaw: f64, pitch: f64, roll: f64) -> Matrix3<f64> {
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw);
    // A positive rotation about +x turns +z towards −y (up), as pitch must.
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), pitch);
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), roll);
    (ry * rx * rz).into_inner()
}

/// Whether `m` is a rotation (orthonormal, determinant +1) within `tol`.
pub fn is_rotation(m: &Matrix3<f64>, tol: f64) -> bool {
    m.iter().all(|v| v.is_finite())
        && (m.transpose() * m - Matrix3::identity()).abs().max() <= tol
        && (m.determinant() - 1.0).abs() <= tol
}

/// Two unit vectors perpendicular to unit vector `n` and to each other (a right-handed
/// frame with `n`).
pub fn perpendiculars(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let a = n.cross(&helper).normalize();
    (a, n.cross(&a))
}

/// `inner` seen from a reference frame in which its axes are `reference_from_camera`: bearings
/// in and out of this model are in the reference frame.
#[derive(Debug, Clone)]
pub struct Rotated<C> {
    /// The camera in its own axes.
    pub inner: C,
    /// The camera's axes in the reference frame: a camera bearing d is
    /// `reference_from_camera · d` there.
    pub reference_from_camera: Matrix3<f64>,
}

impl<C: CameraModel> Rotated<C> {
    /// `inner` with its axes `reference_from_camera` in the reference frame (a rotation).
    pub fn new(inner: C, reference_from_camera: Matrix3<f64>) -> Self {
        Self {
            inner,
            reference_from_camera,
        }
    }
}

impl<C: CameraModel> CameraModel for Rotated<C> {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.inner
            .project(&(self.reference_from_camera.transpose() * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.inner
            .unproject(p)
            .map(|d| self.reference_from_camera * d)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.inner
            .distance(&(self.reference_from_camera.transpose() * p))
    }

    fn size(&self) -> ImageSize {
        self.inner.size()
    }

    fn exact_key(&self, key: &mut super::ExactKey) -> bool {
        key.name("rotated");
        key.matrix(&self.reference_from_camera);
        self.inner.exact_key(key)
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        self.inner
            .front_halfspace()
            .map(|n| self.reference_from_camera * n)
    }

    // The inner camera's front half-space turned with it: the same bearings, turned.
    fn sees_whole_front(&self) -> bool {
        self.inner.sees_whole_front()
    }

    // u and u ± period are the same inner bearing, so the same bearing turned.
    fn horizontal_period(&self) -> Option<f64> {
        self.inner.horizontal_period()
    }

    // The inner camera's pixels of the bearings turned: exactly `project`'s, in its one call.
    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        let camera_from_reference = self.reference_from_camera.transpose();
        let turned: Vec<Option<Vector3<f64>>> = bearings
            .iter()
            .map(|d| d.map(|d| camera_from_reference * d))
            .collect();
        self.inner.project_all(&turned, out);
    }

    // The defaults stay: `separable` (None: a turn mixes the columns' and rows' bearings), and
    // `project_point` and `project_point_coordinate`, the point's bearing through `project`:
    // the inner camera's would turn the point before normalising it, other bits than the label
    // search defines (`reproject::labels`).
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, Intrinsics, Perspective};

    fn turn() -> Matrix3<f64> {
        rotation_ypr(0.7, -0.3, 0.2)
    }

    fn equirect() -> Equirect {
        let f = 360.0 / (2.0 * std::f64::consts::PI);
        Equirect::new(Intrinsics::new(f, f, 179.5, 89.5), ImageSize::new(360, 180))
    }

    /// Points in every direction, of several lengths, with the zero point among them.
    fn points() -> Vec<Vector3<f64>> {
        let mut out = vec![Vector3::zeros(), Vector3::new(0.0, 0.0, -2.0)];
        for k in 0..500 {
            let (a, b) = (k as f64 * 0.731, k as f64 * 0.377);
            let r = 0.01 + (k % 7) as f64 * 3.0;
            out.push(Vector3::new(a.sin() * b.cos(), b.sin(), a.cos() * b.cos()) * r);
        }
        out
    }

    #[test]
    fn the_period_is_the_inner_cameras_and_u_plus_a_period_is_the_same_bearing() {
        let inner = equirect();
        let camera = Rotated::new(inner.clone(), turn());
        let period = camera.horizontal_period();
        assert_eq!(period, inner.horizontal_period());
        let period = period.expect("an equirect turned still wraps");
        assert!((period - 360.0).abs() < 1e-9, "{period}");
        // turned bearings near the seam and away from it: u ± period is the same bearing
        let mut wrapped = 0;
        for d in points().iter().skip(2).map(|p| p.normalize()) {
            let Ok(p) = camera.project(&d) else { continue };
            for shift in [-period, period] {
                let back = camera.unproject(&Point2::new(p.x + shift, p.y)).unwrap();
                assert!(
                    (back - d).norm() < 1e-9,
                    "{d} at u {} + {shift}: {back}",
                    p.x
                );
            }
            wrapped += 1;
        }
        assert!(wrapped > 400, "{wrapped}");
        // a camera that does not wrap keeps none, turned
        let perspective = Perspective::new(
            Intrinsics::new(200.0, 200.0, 99.5, 49.5),
            ImageSize::new(200, 100),
        );
        assert_eq!(Rotated::new(perspective, turn()).horizontal_period(), None);
    }

    #[test]
    fn points_and_batches_are_the_turned_inner_cameras() {
        let cameras: Vec<Box<dyn CameraModel>> = vec![
            Box::new(Rotated::new(equirect(), turn())),
            Box::new(Rotated::new(
                Perspective::new(
                    Intrinsics::new(200.0, 200.0, 99.5, 49.5),
                    ImageSize::new(200, 100),
                ),
                turn(),
            )),
        ];
        let points = points();
        for camera in &cameras {
            let (mut projected, mut rejected) = (0, 0);
            for p in &points {
                let got = camera.project_point(p);
                // the very f64 of the point's bearing through `project`, one coordinate too
                let want = (p.norm() > 1e-12).then(|| camera.project(&(p / p.norm())));
                let bits = |r: Result<Point2<f64>, ProjectionReject>| {
                    r.ok().map(|px| [px.x.to_bits(), px.y.to_bits()])
                };
                assert_eq!(bits(got), want.and_then(bits), "{p}");
                for axis in 0..2 {
                    let one = camera.project_point_coordinate(p, axis);
                    assert_eq!(
                        one.ok().map(f64::to_bits),
                        bits(got).map(|b| b[axis]),
                        "{p} axis {axis}"
                    );
                }
                if got.is_ok() {
                    projected += 1;
                } else {
                    rejected += 1;
                }
            }
            assert!(projected > 100 && rejected > 0, "{projected} {rejected}");
            // a batch is exactly `project`, None for None and for a rejected bearing
            let bearings: Vec<Option<Vector3<f64>>> = points
                .iter()
                .skip(1)
                .map(|p| Some(p.normalize()))
                .chain([None])
                .collect();
            let mut out = vec![None];
            camera.project_all(&bearings, &mut out);
            assert_eq!(out.len(), bearings.len() + 1);
            for (d, got) in bearings.iter().zip(&out[1..]) {
                let want = d.and_then(|d| camera.project(&d).ok());
                assert_eq!(got.map(|p| p.coords), want.map(|p| p.coords), "{d:?}");
            }
        }
    }
}
