//! The level reference frame of a rig dataset's frame (KITTI-360's and nuScenes' alike): origin
//! at a reference camera's optical centre, y = gravity down (world −z), z = that camera's
//! optical axis projected on the horizontal plane, x = y × z. A level frame keeps a panorama's
//! horizon straight and lets KITTI's one angle `rotation_y` describe upright objects exactly,
//! whatever the vehicle's pitch and roll and the camera's mounting tilt.

use super::Pose;
use nalgebra::{Matrix3, Vector3};

/// Smallest horizontal component of the reference camera's optical axis (its sine of the angle
/// from the vertical) for which a heading is defined.
const MIN_HORIZONTAL: f64 = 1e-6;

/// world_from_level for a frame whose reference camera (KITTI-360: rectified image_00;
/// nuScenes: CAM_FRONT) is `world_from_rect0` (camera axes: x right, y down, z forward), or
/// None when it looks straight up or down (no heading).
pub fn world_from_level(world_from_rect0: &Pose) -> Option<Pose> {
    let axis = world_from_rect0.apply_vector(&Vector3::z());
    let horizontal = Vector3::new(axis.x, axis.y, 0.0);
    let n = horizontal.norm();
    if !(n > MIN_HORIZONTAL * axis.norm()) {
        return None;
    }
    let z = horizontal / n;
    let y = -Vector3::z();
    let x = y.cross(&z);
    Some(Pose::new(
        Matrix3::from_columns(&[x, y, z]),
        world_from_rect0.translation,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_level_frame_ignores_pitch_and_roll_but_keeps_heading() {
        // A camera at (10, 20, 3) heading 35° left of world +x (north-east-ish), pitched 5°
        // down and rolled 2°: rect axes x right, y down, z forward.
        let heading: f64 = 0.61;
        let (pitch, roll): (f64, f64) = (-0.0873, 0.035);
        let forward = Vector3::new(
            heading.cos() * pitch.cos(),
            heading.sin() * pitch.cos(),
            pitch.sin(),
        );
        let left = Vector3::new(-heading.sin(), heading.cos(), 0.0);
        let up0 = forward.cross(&-left);
        let (s, c) = roll.sin_cos();
        let right = -left * c + up0 * s;
        let down = forward.cross(&right);
        let cam = Pose::new(
            Matrix3::from_columns(&[right, down, forward]),
            Vector3::new(10.0, 20.0, 3.0),
        );
        let level = world_from_level(&cam).unwrap();
        assert!(level.orthonormality_error() < 1e-15);
        assert!((level.rotation.determinant() - 1.0).abs() < 1e-15);
        assert_eq!(level.translation, cam.translation);
        assert!((level.apply_vector(&Vector3::y()) - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-15);
        let z = level.apply_vector(&Vector3::z());
        assert!((z.y.atan2(z.x) - heading).abs() < 1e-12 && z.z == 0.0);
        // x points to the right of the heading, horizontally.
        let x = level.apply_vector(&Vector3::x());
        assert!((x - Vector3::new(heading.sin(), -heading.cos(), 0.0)).norm() < 1e-12);
        // Looking straight down has no heading.
        let nadir = Pose::new(
            Matrix3::from_columns(&[Vector3::x(), Vector3::y(), -Vector3::z()]),
            Vector3::zeros(),
        );
        assert!(world_from_level(&nadir).is_none());
    }
}
