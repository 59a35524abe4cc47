//! A linear camera (perspective, equirect, cylindrical) turned by yaw, pitch and roll relative
//! to rect: the output cameras the command writes have rect's axes, drawn training cameras
//! may look elsewhere. Fisheye cameras carry their own axes (`FisheyeCamera::rect_from_camera`).

use nalgebra::{Matrix3, Point2, Vector3};
use panoconv::camera::{
    CameraModel, ImageSize, Intrinsics, OutputCamera, OutputProjection, ProjectionReject,
};

/// `inner` (rect axes) with its axes `rect_from_camera` in rect: a camera bearing d is
/// `rect_from_camera · d` there. As the library's `Rotated`, for an output camera.
#[derive(Debug)]
pub struct Turned {
    pub inner: Box<dyn OutputCamera>,
    pub rect_from_camera: Matrix3<f64>,
}

impl CameraModel for Turned {
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.inner.project(&(self.rect_from_camera.transpose() * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.inner.unproject(p).map(|d| self.rect_from_camera * d)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        self.inner
            .distance(&(self.rect_from_camera.transpose() * p))
    }

    fn size(&self) -> ImageSize {
        self.inner.size()
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        self.inner
            .front_halfspace()
            .map(|n| self.rect_from_camera * n)
    }

    fn horizontal_period(&self) -> Option<f64> {
        self.inner.horizontal_period()
    }

    fn project_all(&self, bearings: &[Option<Vector3<f64>>], out: &mut Vec<Option<Point2<f64>>>) {
        let camera_from_rect = self.rect_from_camera.transpose();
        let turned: Vec<Option<Vector3<f64>>> = bearings
            .iter()
            .map(|d| d.map(|d| camera_from_rect * d))
            .collect();
        self.inner.project_all(&turned, out);
    }

    fn sees_whole_front(&self) -> bool {
        self.inner.sees_whole_front()
    }
}

impl OutputCamera for Turned {
    fn projection(&self) -> OutputProjection {
        self.inner.projection()
    }

    fn intrinsics(&self) -> Intrinsics {
        self.inner.intrinsics()
    }

    fn with_intrinsics(
        &self,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<Box<dyn OutputCamera>, String> {
        Ok(Box::new(Turned {
            inner: self.inner.with_intrinsics(k, size)?,
            rect_from_camera: self.rect_from_camera,
        }))
    }

    fn centre_intrinsics(&self) -> Intrinsics {
        self.inner.centre_intrinsics()
    }

    fn boxed_output(&self) -> Box<dyn OutputCamera> {
        Box::new(Turned {
            inner: self.inner.boxed_output(),
            rect_from_camera: self.rect_from_camera,
        })
    }
}
