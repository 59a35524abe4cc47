//! The level frame of a sample: origin at the reference camera's optical centre, y = gravity
//! down (global −z), z = its optical axis projected on the horizontal plane, x = y × z: the
//! panorama's horizon straight whatever the vehicle's pitch and roll and the camera's tilt, and
//! KITTI's one angle describes an upright box exactly. (KITTI-360's level frame, the same rule.)

use crate::source::Pose;
use nalgebra::{Matrix3, Vector3};

/// Smallest horizontal component of the optical axis for which a heading is defined.
const MIN_HORIZONTAL: f64 = 1e-6;

/// global_from_level for a camera at `world_from_camera` (camera axes: x right, y down,
/// z forward), or None when it looks straight up or down.
pub fn world_from_level(world_from_camera: &Pose) -> Option<Pose> {
    let axis = world_from_camera.apply_vector(&Vector3::z());
    let horizontal = Vector3::new(axis.x, axis.y, 0.0);
    let n = horizontal.norm();
    if !(n > MIN_HORIZONTAL * axis.norm()) {
        return None;
    }
    let z = horizontal / n;
    let y = -Vector3::z();
    Some(Pose::new(
        Matrix3::from_columns(&[y.cross(&z), y, z]),
        world_from_camera.translation,
    ))
}
