//! The cameras a conversion writes images in: the linear projections (perspective, equirect,
//! cylindrical) and a real fisheye lens turned relative to KITTI's rectified axes. What the
//! pipeline needs of them besides projecting: the projection's name, the affine intrinsics that
//! crops, resizes and augmented views move, and the calib lines that describe them.

use super::lens::Lens;
use super::{CameraModel, ImageSize, Intrinsics, OutputProjection, ProjectionReject};
use nalgebra::{Matrix3, Point2, Vector3};

/// A camera an image is written in. Bearings in and out are in the frame the labels live in
/// (KITTI's rect axes: x right, y down, z forward), relative to the camera's optical centre.
pub trait OutputCamera: CameraModel {
    /// The `projection:` line's value.
    fn projection(&self) -> OutputProjection;
    /// The affine part pixel = K · (a, b, 1) of the model's normalised coordinates.
    fn intrinsics(&self) -> Intrinsics;
    /// The same camera with other intrinsics and image size (a crop, a resize, a view).
    fn with_intrinsics(
        &self,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<Box<dyn OutputCamera>, String>;
    /// Pixels per radian at the image centre (for rescaling distances by focal length); the
    /// intrinsics themselves for the linear projections.
    fn centre_intrinsics(&self) -> Intrinsics {
        self.intrinsics()
    }
    /// The fisheye lens and its axes, when this is one (the calib writer adds their lines).
    fn as_fisheye(&self) -> Option<&FisheyeCamera> {
        None
    }
    /// A boxed copy.
    fn boxed_output(&self) -> Box<dyn OutputCamera>;
}

/// A fisheye lens whose axes are `rect_from_camera` in rect: a lens bearing d is
/// `rect_from_camera · d` in rect.
#[derive(Debug, Clone)]
pub struct FisheyeCamera {
    /// The lens in its own axes (optical axis +z).
    pub lens: Lens,
    /// The lens's axes in KITTI's rectified camera frame (a rotation).
    pub rect_from_camera: Matrix3<f64>,
}

impl CameraModel for FisheyeCamera {
    #[inline]
    fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        self.lens.project(&(self.rect_from_camera.transpose() * d))
    }

    #[inline]
    fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        self.lens.unproject(p).map(|d| self.rect_from_camera * d)
    }

    /// The range along the ray (the fisheye convention of KITTI-360 and Kumar et al.).
    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.lens.size()
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        self.lens
            .front_halfspace()
            .map(|n| self.rect_from_camera * n)
    }

    fn exact_key(&self, key: &mut super::ExactKey) -> bool {
        key.name("fisheye camera");
        key.matrix(&self.rect_from_camera);
        self.lens.exact_key(key)
    }
}

impl OutputCamera for FisheyeCamera {
    fn projection(&self) -> OutputProjection {
        OutputProjection::Fisheye
    }

    fn intrinsics(&self) -> Intrinsics {
        self.lens.intrinsics()
    }

    fn with_intrinsics(
        &self,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<Box<dyn OutputCamera>, String> {
        let lens = self
            .lens
            .with_intrinsics(k, size)
            .map_err(|e| e.to_string())?;
        Ok(Box::new(FisheyeCamera {
            lens,
            rect_from_camera: self.rect_from_camera,
        }))
    }

    fn centre_intrinsics(&self) -> Intrinsics {
        self.lens.centre_intrinsics()
    }

    fn as_fisheye(&self) -> Option<&FisheyeCamera> {
        Some(self)
    }

    fn boxed_output(&self) -> Box<dyn OutputCamera> {
        Box::new(self.clone())
    }
}
