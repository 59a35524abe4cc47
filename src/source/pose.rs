//! [`Pose`]: an affine map between two frames, `dst = rotation · src + translation`.
//!
//! The linear part is a rotation for every rigid mounting; for a rectified camera of a dataset
//! that publishes its rectifying rotation rounded (KITTI-360's six-digit `R_rect`), it is that
//! rotation's exact inverse composed with the mounting, so it can be off orthonormal by the
//! rounding (about 1e-6). [`Pose::inverse`] therefore inverts the matrix instead of transposing
//! it, so that a map and its inverse agree to machine precision, as the dataset's own tools do.

use nalgebra::{Matrix3, Matrix4, Vector3};

/// `dst = rotation · src + translation`; named `dst_from_src` where it is stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// The linear part (a rotation up to a calibration's rounding).
    pub rotation: Matrix3<f64>,
    /// The source frame's origin in the destination frame, metres.
    pub translation: Vector3<f64>,
}

impl Pose {
    /// The identity map.
    pub fn identity() -> Self {
        Self {
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// A pose from its linear part and translation.
    pub fn new(rotation: Matrix3<f64>, translation: Vector3<f64>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// The pose of a homogeneous 4x4 matrix (its last row is ignored: it is [0 0 0 1] for
    /// every transform this is used with).
    pub fn from_matrix4(m: &Matrix4<f64>) -> Self {
        Self {
            rotation: m.fixed_view::<3, 3>(0, 0).into_owned(),
            translation: m.fixed_view::<3, 1>(0, 3).into_owned(),
        }
    }

    /// The homogeneous 4x4 matrix.
    pub fn to_matrix4(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation);
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// The 12 numbers of the 3x4 matrix [rotation | translation], row-major.
    pub fn to_row_major_3x4(&self) -> [f64; 12] {
        std::array::from_fn(|i| {
            let (r, c) = (i / 4, i % 4);
            if c == 3 {
                self.translation[r]
            } else {
                self.rotation[(r, c)]
            }
        })
    }

    /// A point mapped from the source frame to the destination frame.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation
    }

    /// A direction (no translation) mapped to the destination frame.
    pub fn apply_vector(&self, d: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * d
    }

    /// `self ∘ other`: first `other` (a→b), then `self` (b→c), giving c_from_a.
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The inverse map, or None when the linear part is singular.
    pub fn inverse(&self) -> Option<Pose> {
        let inv = self.rotation.try_inverse()?;
        Some(Pose {
            rotation: inv,
            translation: -(inv * self.translation),
        })
    }

    /// The largest deviation of the linear part from an orthonormal matrix,
    /// max |RᵀR − I|: 0 for a rigid pose, about 1e-6 for a rounded rectification.
    pub fn orthonormality_error(&self) -> f64 {
        (self.rotation.transpose() * self.rotation - Matrix3::identity())
            .abs()
            .max()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn sample() -> Pose {
        let r = Rotation3::from_euler_angles(0.1, -0.4, 2.0).into_inner();
        Pose::new(r, Vector3::new(1.5, -2.0, 0.25))
    }

    #[test]
    fn inverse_and_composition_round_trip() {
        let p = sample();
        let q = p.inverse().unwrap();
        let x = Vector3::new(3.0, -1.0, 7.5);
        assert!((q.apply(&p.apply(&x)) - x).norm() < 1e-12);
        let id = q.compose(&p);
        assert!((id.rotation - Matrix3::identity()).abs().max() < 1e-12);
        assert!(id.translation.norm() < 1e-12);
        // compose applies the right operand first
        let two = p.compose(&p);
        assert!((two.apply(&x) - p.apply(&p.apply(&x))).norm() < 1e-12);
        assert!(p.orthonormality_error() < 1e-12);
    }

    #[test]
    fn matrix4_and_row_major_agree() {
        let p = sample();
        let m = p.to_matrix4();
        assert_eq!(Pose::from_matrix4(&m), p);
        let rows = p.to_row_major_3x4();
        assert_eq!(rows[3], 1.5);
        assert_eq!(rows[7], -2.0);
        assert_eq!(rows[11], 0.25);
        assert_eq!(rows[1], p.rotation[(0, 1)]);
        assert_eq!(rows[4], p.rotation[(1, 0)]);
        let h = m * nalgebra::Vector4::new(1.0, 2.0, 3.0, 1.0);
        let a = p.apply(&Vector3::new(1.0, 2.0, 3.0));
        assert!((h.xyz() - a).norm() < 1e-12);
    }

    #[test]
    fn a_non_orthonormal_pose_inverts_exactly_and_a_singular_one_not_at_all() {
        // KITTI-360's rounded R_rect_00
        let r = Matrix3::new(
            0.999974, -0.007141, -0.000089, 0.007141, 0.999969, -0.003247, 0.000112, 0.003247,
            0.999995,
        );
        let p = Pose::new(r, Vector3::new(0.0, 1.0, 2.0));
        let err = p.orthonormality_error();
        assert!(err > 1e-7 && err < 1e-4, "{err}");
        let q = p.inverse().unwrap();
        let x = Vector3::new(10.0, -3.0, 40.0);
        assert!((p.apply(&q.apply(&x)) - x).norm() < 1e-12);
        assert!(Pose::new(Matrix3::zeros(), Vector3::zeros())
            .inverse()
            .is_none());
    }
}
