//! [`RigCamera`]: one source camera of a frame's rig: its model, its pose in the frame's
//! reference frame and its image.

use super::Pose;
use crate::camera::CameraModel;
use nalgebra::{Point2, Vector3};
use std::path::PathBuf;
use std::sync::Arc;

/// A source camera: a camera model (pixels ↔ bearings in the camera's own axes), where it sits
/// in the frame's reference frame, and the image file that it took.
#[derive(Debug, Clone)]
pub struct RigCamera {
    /// The dataset's name for the camera (`image_00`, `image_2`, ...).
    pub name: String,
    /// The camera's model, in its own axes (x right, y down, z forward). Shared: the same
    /// calibration serves every frame of a sequence.
    pub model: Arc<dyn CameraModel>,
    /// Camera axes and optical centre in the reference frame: a point p in camera
    /// coordinates is `reference_from_camera.apply(p)` in the reference frame.
    pub reference_from_camera: Pose,
    /// The image file.
    pub image: PathBuf,
    /// When the image was taken, seconds after the frame's time (its LiDAR sweep's, at which
    /// its boxes are given), where the dataset says; None: at the frame's time.
    pub time: Option<f64>,
}

impl RigCamera {
    /// The optical centre in the reference frame.
    pub fn centre(&self) -> Vector3<f64> {
        self.reference_from_camera.translation
    }

    /// The camera's optical axis (+z of its axes) in the reference frame, unit length.
    pub fn optical_axis(&self) -> Vector3<f64> {
        self.reference_from_camera
            .apply_vector(&Vector3::z())
            .normalize()
    }

    /// The pixel of a point given in the reference frame, or None when the camera has no
    /// image of it (behind it, outside its field of view). The pixel may lie off the image.
    pub fn project(&self, point: &Vector3<f64>) -> Option<Point2<f64>> {
        let camera_from_reference = self.reference_from_camera.inverse()?;
        self.model
            .project_point(&camera_from_reference.apply(point))
            .ok()
    }

    /// The unit bearing of a pixel in the reference frame's axes (from [`RigCamera::centre`]).
    pub fn bearing(&self, pixel: &Point2<f64>) -> Option<Vector3<f64>> {
        let d = self.model.unproject(pixel).ok()?;
        Some(self.reference_from_camera.apply_vector(&d).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};
    use nalgebra::Matrix3;

    #[test]
    fn project_and_bearing_follow_the_pose() {
        // A pinhole camera 2 m right of the reference origin, turned 90° to look along +x.
        let turn = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
        let camera = RigCamera {
            name: "side".into(),
            model: Arc::new(Perspective::new(
                Intrinsics::new(500.0, 500.0, 320.0, 240.0),
                ImageSize::new(640, 480),
            )),
            reference_from_camera: Pose::new(turn, Vector3::new(2.0, 0.0, 0.0)),
            image: PathBuf::from("side.png"),
            time: None,
        };
        assert!((camera.optical_axis() - Vector3::x()).norm() < 1e-15);
        // 10 m along +x from the camera, 1 m down: straight below the principal point.
        let px = camera.project(&Vector3::new(12.0, 1.0, 0.0)).unwrap();
        assert!(
            (px.x - 320.0).abs() < 1e-9 && (px.y - 290.0).abs() < 1e-9,
            "{px}"
        );
        // A point behind it has no image.
        assert!(camera.project(&Vector3::new(-5.0, 0.0, 0.0)).is_none());
        let b = camera.bearing(&px).unwrap();
        let want = Vector3::new(10.0, 1.0, 0.0).normalize();
        assert!((b - want).norm() < 1e-12, "{b}");
        assert_eq!(camera.centre(), Vector3::new(2.0, 0.0, 0.0));
    }
}
