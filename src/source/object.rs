//! [`SourceBox`]: a 3D object as a neutral oriented box.
//!
//! The box's own axes follow KITTI's object convention, so that KITTI labels map onto it
//! without a turn: local x along its length, local y along its height pointing *down* when the
//! object stands upright, local z along its width. `rotation` maps local axes to the reference
//! frame (reference_from_box), `centre` is the box's geometric centre (not KITTI's bottom
//! centre), `size` its full extents along local x, y, z.
//!
//! An upright box (local y along the reference frame's y) is described exactly by KITTI's one
//! angle: [`SourceBox::yaw`] is then `rotation_y`. A tilted box (KITTI-360 has a few) keeps
//! its full rotation; [`SourceBox::tilt`] says by how much it leans.

use nalgebra::{Matrix3, Vector3};

/// A 3D object: an oriented box with its class and what the dataset knows about its visibility.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceBox {
    /// Geometric centre, reference frame, metres.
    pub centre: Vector3<f64>,
    /// Full extents along local x (length), y (height) and z (width), metres.
    pub size: Vector3<f64>,
    /// reference_from_box: the box's local axes in the reference frame (a rotation).
    pub rotation: Matrix3<f64>,
    /// The class written to outputs (a KITTI type such as `Car`).
    pub class: String,
    /// The dataset's own class name (e.g. KITTI-360's `person`), for reports.
    pub dataset_class: String,
    /// The dataset's instance id, where it has one (the same object across frames).
    pub instance: Option<u64>,
    /// Fraction of the object outside the source image (KITTI's truncation), where known.
    pub truncation: Option<f64>,
    /// Occlusion state (KITTI's 0 to 3), where known.
    pub occlusion: Option<u8>,
    /// The sensor returns the dataset counted inside the box (nuScenes: LiDAR and radar
    /// points), where it counts them.
    pub sensor_points: Option<u64>,
    /// Velocity over the ground, m/s, in the reference frame's axes (the frame is fixed to the
    /// world at the frame's time), where the dataset gives it; None: unknown, taken as still.
    pub velocity: Option<Vector3<f64>>,
    /// When the box holds, seconds after the frame's time, where it differs (a rotating
    /// LiDAR measures an object as its sweep passes it; None: at the frame's time).
    pub time: Option<f64>,
}

impl SourceBox {
    /// The box of a KITTI label: `dimensions` = (height, width, length), `location` = bottom
    /// centre in rect, `rotation_y` = KITTI's yaw about rect's y axis.
    pub fn from_kitti(
        class: &str,
        dimensions: [f64; 3],
        location: Vector3<f64>,
        rotation_y: f64,
    ) -> Self {
        let [h, w, l] = dimensions;
        Self {
            centre: location - Vector3::new(0.0, h / 2.0, 0.0),
            size: Vector3::new(l, h, w),
            rotation: yaw_rotation(rotation_y),
            class: class.to_owned(),
            dataset_class: class.to_owned(),
            instance: None,
            truncation: None,
            occlusion: None,
            sensor_points: None,
            velocity: None,
            time: None,
        }
    }

    /// Length, height and width, metres.
    pub fn length(&self) -> f64 {
        self.size.x
    }

    /// Height, metres.
    pub fn height(&self) -> f64 {
        self.size.y
    }

    /// Width, metres.
    pub fn width(&self) -> f64 {
        self.size.z
    }

    /// KITTI's `location`: the centre of the bottom face (local +y is down).
    pub fn bottom_centre(&self) -> Vector3<f64> {
        self.centre + self.rotation * Vector3::new(0.0, self.size.y / 2.0, 0.0)
    }

    /// The eight corners in the reference frame, in KITTI's order (that of
    /// `kitti::Label::corners`): the bottom face (+x+z, +x−z, −x−z, −x+z in local axes), then
    /// the top face in the same order.
    pub fn corners(&self) -> [Vector3<f64>; 8] {
        let (l, h, w) = (self.size.x / 2.0, self.size.y / 2.0, self.size.z / 2.0);
        let xs = [l, l, -l, -l];
        let zs = [w, -w, -w, w];
        std::array::from_fn(|i| {
            let y = if i < 4 { h } else { -h };
            self.centre + self.rotation * Vector3::new(xs[i % 4], y, zs[i % 4])
        })
    }

    /// Whether a point (reference frame) lies inside the box (borders included).
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        let local = self.rotation.transpose() * (p - self.centre);
        (0..3).all(|i| local[i].abs() <= self.size[i] / 2.0)
    }

    /// The angle (radians, 0 to π) between the box's up axis (−local y) and the reference
    /// frame's up (−y): 0 for an upright object.
    pub fn tilt(&self) -> f64 {
        let down = self.rotation * Vector3::y();
        down.y.clamp(-1.0, 1.0).acos()
    }

    /// Whether the box leans less than `tolerance` radians from upright.
    pub fn is_upright(&self, tolerance: f64) -> bool {
        self.tilt() <= tolerance
    }

    /// KITTI's `rotation_y` (radians, in (−π, π]): the heading of the box's length axis about
    /// the reference y axis, `atan2(−x_z, x_x)` of local x in the reference frame. Exact for an
    /// upright box; for a tilted one, the heading of its length axis projected on the
    /// horizontal plane.
    pub fn yaw(&self) -> f64 {
        let x = self.rotation * Vector3::x();
        (-x.z).atan2(x.x)
    }
}

/// KITTI's rotation about rect's y axis by `ry`: local x → (cos ry, 0, −sin ry).
pub fn yaw_rotation(ry: f64) -> Matrix3<f64> {
    let (s, c) = ry.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// KITTI's corners as its devkit writes them (kitti::Label::corners; this layer may not
    /// import kitti/): x' = c·x + s·z, z' = −s·x + c·z around the bottom centre.
    fn kitti_corners(dims: [f64; 3], loc: Vector3<f64>, ry: f64) -> [Vector3<f64>; 8] {
        let [h, w, l] = dims;
        let (s, c) = ry.sin_cos();
        let xs = [l / 2.0, l / 2.0, -l / 2.0, -l / 2.0];
        let zs = [w / 2.0, -w / 2.0, -w / 2.0, w / 2.0];
        std::array::from_fn(|i| {
            let (x, z) = (xs[i % 4], zs[i % 4]);
            let y = if i < 4 { 0.0 } else { -h };
            loc + Vector3::new(c * x + s * z, y, -s * x + c * z)
        })
    }

    #[test]
    fn a_kitti_label_gives_kittis_corners_yaw_and_location() {
        for ry in [-3.0, -1.2, 0.0, 0.4, 1.57, 3.1] {
            let dims = [1.52, 1.65, 3.9];
            let loc = Vector3::new(-4.5, 1.65, 6.5);
            let b = SourceBox::from_kitti("Car", dims, loc, ry);
            let want = kitti_corners(dims, loc, ry);
            for (a, w) in b.corners().iter().zip(want.iter()) {
                assert!((a - w).norm() < 1e-12, "ry {ry}: {a} vs {w}");
            }
            assert!((b.yaw() - ry).abs() < 1e-12, "yaw {} vs {ry}", b.yaw());
            assert!((b.bottom_centre() - loc).norm() < 1e-12);
            assert!(b.tilt() < 1e-12 && b.is_upright(1e-3));
            assert_eq!((b.length(), b.height(), b.width()), (3.9, 1.52, 1.65));
        }
    }

    #[test]
    fn a_tilted_box_reports_its_tilt_and_the_heading_of_its_length() {
        // Pitch the box by 0.1 rad about its width axis (local z), then yaw it by 0.7.
        let pitch = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.1).into_inner();
        let b = SourceBox {
            rotation: yaw_rotation(0.7) * pitch,
            ..SourceBox::from_kitti("Car", [1.5, 1.6, 4.0], Vector3::new(0.0, 1.6, 10.0), 0.0)
        };
        assert!((b.tilt() - 0.1).abs() < 1e-12, "{}", b.tilt());
        assert!(!b.is_upright(1e-3));
        assert!((b.yaw() - 0.7).abs() < 1e-12, "{}", b.yaw());
    }

    #[test]
    fn contains_holds_the_corners_and_not_beyond() {
        let b = SourceBox::from_kitti("Car", [1.5, 2.0, 4.0], Vector3::new(1.0, 1.6, 8.0), 0.9);
        assert!(b.contains(&b.centre));
        for c in b.corners() {
            let inward = b.centre + (c - b.centre) * 0.999;
            let outward = b.centre + (c - b.centre) * 1.001;
            assert!(b.contains(&inward) && !b.contains(&outward));
        }
    }
}
