//! A pinhole camera's part of the reach bound: the four planes through its centre and its image
//! border one pixel out, whose inner sides hold every point with an image there. The cone about
//! the optical axis circumscribes that border, so the planes leave out what lies within the
//! cone beyond the image's edges (a 16:9 image fills about 60 % of its cone): those output
//! pixels take nothing from the camera and its table need not map them.
//!
//! A pixel with a tap in the image has its centre's camera point within the bound's angle δ
//! of a point with an image ([`super`]), so within δ of each plane's inner side: its signed
//! angle from each plane, asin(n·q/|q|) for the plane's unit inward normal n, is at least −δ.
//! The test per position is n·q ≥ −sin(δ + 1e-6)·|q| for every plane (NaN passes); a tile of
//! positions within `radius` of its middle one is decided whole where the middle's angles
//! settle every position with room to spare, as the cone's tiles are.

use crate::camera::CameraModel;
use nalgebra::Vector3;

/// Radians the tiles' decisions keep clear of the limit (as the cone's).
const CLEARANCE: f64 = 1e-7;

/// The planes of a pinhole camera's image border one pixel out.
#[derive(Debug, Clone, Copy)]
pub(in crate::warp) struct Frustum {
    /// Unit inward normals (camera axes) of the planes x = a0·z, x = a1·z, y = b0·z, y = b1·z.
    normals: [Vector3<f64>; 4],
}

impl Frustum {
    /// The planes of `model`'s image border one pixel out (pixel positions −1.5 and size +
    /// 0.5) where it is a pinhole with positive focal lengths; None for another camera. For z > 0, x − a0·z ≥ 0 exactly where u ≥ −1.5, and so on; the
    /// four together hold only points with z ≥ 0.
    pub(in crate::warp) fn of(model: &dyn CameraModel) -> Option<Frustum> {
        let k = model.pinhole().filter(|k| k.fu > 0.0 && k.fv > 0.0)?;
        let size = model.size();
        let (w, h) = (size.width as f64, size.height as f64);
        let (a0, a1) = ((-1.5 - k.cu) / k.fu, (w + 0.5 - k.cu) / k.fu);
        let (b0, b1) = ((-1.5 - k.cv) / k.fv, (h + 0.5 - k.cv) / k.fv);
        let normals = [
            Vector3::new(1.0, 0.0, -a0),
            Vector3::new(-1.0, 0.0, a1),
            Vector3::new(0.0, 1.0, -b0),
            Vector3::new(0.0, -1.0, b1),
        ]
        .map(|n| n.normalize());
        normals
            .iter()
            .all(|n| n.iter().all(|x| x.is_finite()))
            .then_some(Frustum { normals })
    }

    /// The bound with angle `delta` (radians) beyond the planes.
    pub(super) fn within(&self, delta: f64) -> Slack {
        Slack {
            normals: self.normals,
            delta,
            sin: (delta + 1e-6).sin(),
        }
    }
}

/// A [`Frustum`] and the angle δ a candidate may lie beyond its planes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Slack {
    normals: [Vector3<f64>; 4],
    delta: f64,
    /// sin(δ + 1e-6): the per-position test's bound.
    sin: f64,
}

impl Slack {
    /// Whether camera point `q` may be a candidate: within δ + 1e-6 of every plane's inner
    /// side (NaN compares false: such a point is a candidate).
    #[inline]
    pub(super) fn holds(&self, q: &Vector3<f64>) -> bool {
        let m = self.sin * q.norm();
        self.normals.iter().all(|n| !(n.dot(q) < -m))
    }

    /// The per-position decision of every position within `radius` of camera point `q` at
    /// once where `q`'s angles from the planes settle them, else None.
    pub(super) fn whole(&self, q: &Vector3<f64>, radius: f64) -> Option<bool> {
        let norm = q.norm();
        let angles = self
            .normals
            .map(|n| (n.dot(q) / norm).clamp(-1.0, 1.0).asin());
        if !(angles.iter().all(|a| a.is_finite()) && radius.is_finite()) {
            return None;
        }
        if angles
            .iter()
            .any(|a| a + radius < -(self.delta + 1e-6) - CLEARANCE)
        {
            Some(false)
        } else if angles.iter().all(|a| a - radius > -self.delta + CLEARANCE) {
            Some(true)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Intrinsics, Perspective};
    use nalgebra::Point2;

    #[test]
    fn the_planes_hold_the_image_and_leave_the_cones_corners() {
        let model = Perspective::new(
            Intrinsics::new(1000.0, 990.0, 950.5, 530.5),
            ImageSize::new(1920, 1080),
        );
        let f = Frustum::of(&model).expect("a pinhole").within(0.0);
        // every pixel one pixel out of the image and inside is held, beyond two is not
        for (x, y, held) in [
            (-1.5, 540.0, true),
            (1920.5, 540.0, true),
            (960.0, -1.5, true),
            (960.0, 1080.5, true),
            (-1.4, -1.4, true),
            (960.0, 540.0, true),
            (-3.5, 540.0, false),
            (1922.5, 540.0, false),
            (960.0, 1082.5, false),
            (-3.0, -3.0, false),
        ] {
            let d = model.unproject(&Point2::new(x, y)).expect("a bearing");
            assert_eq!(f.holds(&(d * 7.0)), held, "({x}, {y})");
        }
        // behind the camera: none
        assert!(!f.holds(&Vector3::new(0.0, 0.0, -1.0)));
        // a whole decision agrees with the positions about it
        let inner = model.unproject(&Point2::new(960.0, 540.0)).unwrap();
        assert_eq!(f.whole(&inner, 0.01), Some(true));
        let outer = model.unproject(&Point2::new(-400.0, 540.0)).unwrap();
        assert_eq!(f.whole(&outer, 0.01), Some(false));
        let edge = model.unproject(&Point2::new(-1.5, 540.0)).unwrap();
        assert_eq!(f.whole(&edge, 0.01), None);
        // not a pinhole, or a flipped one: no planes
        let flipped = Perspective::new(
            Intrinsics::new(-1000.0, 990.0, 950.5, 530.5),
            ImageSize::new(1920, 1080),
        );
        assert!(Frustum::of(&flipped).is_none());
    }
}
