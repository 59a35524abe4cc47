//! A rig frame in its dataset's world frame (metres, z up), as an adapter outside the crate
//! gives it, and its neutral [`Frame`] in the level frame of its first camera: the same level
//! frame, axes and box conventions as `kitti360` and `nuscenes` (source::world_from_level).

use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::source::{world_from_level, Frame, LidarPoint, Pose, RigCamera, SourceBox};
use nalgebra::{Matrix3, Vector3};
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One camera of a frame: its model in its own axes (x right, y down, z forward), its pose
/// when its image was taken, and the image file.
#[derive(Debug, Clone)]
pub struct WorldCamera {
    /// The dataset's name for it.
    pub name: String,
    /// The lens, in the camera's axes.
    pub model: Arc<dyn CameraModel>,
    /// world_from_camera at the image's time (a rigid pose).
    pub world_from_camera: Pose,
    /// The image file.
    pub image: PathBuf,
    /// When the image was taken, seconds after the frame's time (the boxes' and the scan's),
    /// where known.
    pub time: Option<f64>,
}

/// A 3D object in the world frame.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldBox {
    /// The class written (a KITTI type such as `Car`, or `DontCare`).
    pub class: String,
    /// The dataset's own class name (reports, the objects record).
    pub label: String,
    /// The box centre, world frame, metres.
    pub centre: Vector3<f64>,
    /// Length, width, height, metres.
    pub size: Vector3<f64>,
    /// world_from_box: the box's axes (x along its length towards its front, z up).
    pub world_from_box: Matrix3<f64>,
    /// The dataset's sensor-point count inside the box, where it counts them (0: unseen).
    pub points: Option<u64>,
    /// The dataset's instance id.
    pub instance: Option<u64>,
    /// Velocity in the world frame, m/s, where known (None: taken as still).
    pub velocity: Option<Vector3<f64>>,
    /// When the box holds, seconds after the frame's time (None: at the frame's time).
    pub time: Option<f64>,
}

/// A frame in the world frame.
#[derive(Debug, Clone)]
pub struct WorldFrame {
    /// The cameras, in the source's camera-set order.
    pub cameras: Vec<WorldCamera>,
    /// The 3D objects.
    pub boxes: Vec<WorldBox>,
    /// The LiDAR points in the world frame.
    pub lidar: Vec<LidarPoint>,
    /// world_from_lidar at the scan's time, where known.
    pub world_from_lidar: Option<Pose>,
    /// The first fields of `objects/ID.json` (which frame of the dataset this is).
    pub record: Map<String, Value>,
    /// The per-frame files the adapter read besides the images (hashed into the manifest).
    pub inputs: Vec<PathBuf>,
}

/// The KITTI box axes (x length, y down, z width) in a world box's axes (x length, y left,
/// z up): box_from_kitti.
const KITTI_AXES_IN_BOX: Matrix3<f64> = Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0);

/// world_from_box of a box turned by `yaw` radians counter-clockwise about the world's z axis
/// (from the world's x axis to the box's length axis).
pub fn box_from_yaw(yaw: f64) -> Matrix3<f64> {
    let (s, c) = yaw.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

impl WorldFrame {
    /// The neutral frame `id` in the level frame of the first camera (origin at its optical
    /// centre, y down along gravity, z its optical axis made horizontal). `root` names the
    /// source in errors.
    pub fn into_frame(self, id: &str, root: &Path) -> Result<Frame> {
        let Some(first) = self.cameras.first() else {
            return Err(frame_error(root, id, "cameras", "a frame needs a camera"));
        };
        let world_from_reference = world_from_level(&first.world_from_camera).ok_or_else(|| {
            frame_error(
                root,
                id,
                "cameras[0].world_from_camera",
                "the first camera looks straight up or down; no level frame",
            )
        })?;
        let level_from_world = world_from_reference.inverse().expect("a rotation");
        let mut provenance: Vec<PathBuf> = self.cameras.iter().map(|c| c.image.clone()).collect();
        provenance.extend(self.inputs);
        let rig = self
            .cameras
            .into_iter()
            .map(|c| RigCamera {
                name: c.name,
                model: c.model,
                reference_from_camera: level_from_world.compose(&c.world_from_camera),
                image: c.image,
                time: c.time,
            })
            .collect();
        let objects = self
            .boxes
            .into_iter()
            .map(|b| SourceBox {
                centre: level_from_world.apply(&b.centre),
                size: Vector3::new(b.size.x, b.size.z, b.size.y),
                rotation: level_from_world.rotation * b.world_from_box * KITTI_AXES_IN_BOX,
                class: b.class,
                dataset_class: b.label,
                instance: b.instance,
                truncation: None,
                occlusion: None,
                sensor_points: b.points,
                velocity: b.velocity.map(|v| level_from_world.rotation * v),
                time: b.time,
            })
            .collect();
        let lidar = self
            .lidar
            .into_iter()
            .map(|p| LidarPoint {
                position: level_from_world.apply(&p.position),
                intensity: p.intensity,
            })
            .collect();
        Ok(Frame {
            id: id.to_owned(),
            provenance,
            rig,
            objects,
            regions: Vec::new(),
            lidar,
            world_from_reference: Some(world_from_reference),
            reference_from_lidar: self.world_from_lidar.map(|p| level_from_world.compose(&p)),
            lidar_from_imu: None,
            input_hashes: Vec::new(),
        })
    }
}

/// An error of frame `id`'s `field`, naming the source's root.
pub fn frame_error(root: &Path, id: &str, field: &str, message: impl std::fmt::Display) -> Error {
    Error::file(root, format!("frame {id}: {field}: {message}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};

    /// A camera 1.5 m above the world origin looking along world +y (north), level.
    fn camera() -> WorldCamera {
        // camera x (right) = world +x... looking +y: right is +x, down is −z, forward +y
        let r = Matrix3::from_columns(&[Vector3::x(), -Vector3::z(), Vector3::y()]);
        WorldCamera {
            name: "front".into(),
            model: Arc::new(Perspective::new(
                Intrinsics::new(100.0, 100.0, 50.0, 40.0),
                ImageSize::new(100, 80),
            )),
            world_from_camera: Pose::new(r, Vector3::new(0.0, 0.0, 1.5)),
            image: "front.png".into(),
            time: None,
        }
    }

    #[test]
    fn a_world_box_lands_in_the_level_frame_with_kittis_axes() {
        // a car 10 m ahead (world +y), heading west (yaw π/2 from +x is +y: along the view)
        let b = WorldBox {
            class: "Car".into(),
            label: "car".into(),
            centre: Vector3::new(0.0, 10.0, 0.75),
            size: Vector3::new(4.0, 2.0, 1.5),
            world_from_box: box_from_yaw(std::f64::consts::FRAC_PI_2),
            points: Some(12),
            instance: Some(3),
            velocity: Some(Vector3::new(0.0, 2.0, 0.0)),
            time: Some(-0.02),
        };
        let frame = WorldFrame {
            cameras: vec![camera()],
            boxes: vec![b],
            lidar: vec![LidarPoint {
                position: Vector3::new(1.0, 5.0, 0.0),
                intensity: 0.5,
            }],
            world_from_lidar: None,
            record: Map::new(),
            inputs: vec!["boxes.txt".into()],
        }
        .into_frame("7", Path::new("root"))
        .unwrap();
        let o = &frame.objects[0];
        // level: x right, y down, z forward; the camera is the origin, 1.5 m above the ground
        assert!(
            (o.centre - Vector3::new(0.0, 0.75, 10.0)).norm() < 1e-12,
            "{}",
            o.centre
        );
        assert_eq!((o.length(), o.height(), o.width()), (4.0, 1.5, 2.0));
        // its length along the view: KITTI's rotation_y of a car facing away is −π/2
        assert!(
            (o.yaw() + std::f64::consts::FRAC_PI_2).abs() < 1e-12,
            "{}",
            o.yaw()
        );
        assert!(o.is_upright(1e-12));
        // its velocity along the world's +y: forward in the level frame
        let v = o.velocity.unwrap();
        assert!((v - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-12, "{v}");
        let p = frame.lidar[0].position;
        assert!((p - Vector3::new(1.0, 1.5, 5.0)).norm() < 1e-12, "{p}");
        assert_eq!(frame.provenance.len(), 2);
        assert!(frame.rig[0].reference_from_camera.translation.norm() < 1e-12);
    }
}
