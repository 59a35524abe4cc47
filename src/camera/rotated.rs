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

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        self.inner
            .front_halfspace()
            .map(|n| self.reference_from_camera * n)
    }

    // The inner camera's front half-space turned with it: the same bearings, turned.
    fn sees_whole_front(&self) -> bool {
        self.inner.sees_whole_front()
    }
}
