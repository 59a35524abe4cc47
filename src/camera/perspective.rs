//! Pinhole camera: (a, b) = (x/z, y/z); distance z.

use super::linear::{Linear, Mapping};
use super::separable::Share;
use super::{Intrinsics, Projection, ProjectionReject};
use nalgebra::Vector3;

/// Rays closer than this to the image plane's horizon (z/|b| below it) have no image.
const MIN_FORWARD: f64 = 1e-9;

/// The pinhole (a, b) = (x/z, y/z) mapping.
#[derive(Debug, PartialEq)]
pub struct PinholeMapping;

/// A pinhole camera: `PinholeMapping` with K, as KITTI's rectified cameras.
pub type Perspective = Linear<PinholeMapping>;

impl Mapping for PinholeMapping {
    const PROJECTION: Projection = Projection::Perspective;
    const PERIODIC: bool = false;
    const FRONT_ONLY: bool = true;
    // z >= 1e-6·|d| passes the MIN_FORWARD test below.
    const WHOLE_FRONT: bool = true;

    #[inline]
    fn bearing_to_ab(d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        if !(d.z > MIN_FORWARD * d.norm()) {
            return Err(ProjectionReject::BehindCamera);
        }
        Ok((d.x / d.z, d.y / d.z))
    }

    fn split_a(a: f64) -> [f64; 2] {
        [a, 0.0]
    }

    fn split_b(b: f64) -> [f64; 2] {
        [b, 0.0]
    }

    #[inline]
    fn join([a, _]: [f64; 2], [b, _]: [f64; 2]) -> Result<Vector3<f64>, ProjectionReject> {
        if !(a.is_finite() && b.is_finite()) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(Vector3::new(a, b, 1.0).normalize())
    }

    #[inline]
    fn join_lanes(columns: &[Share], [b, _]: [f64; 2], [x, y, z]: [&mut [f64]; 3]) {
        if !b.is_finite() {
            for out in [x, y, z] {
                out.fill(f64::NAN);
            }
            return;
        }
        for (((col, x), y), z) in columns.iter().zip(x).zip(y).zip(z) {
            // `join`'s normalize, operation for operation; NaN where `a` is not finite
            let a = col.0[0];
            let n = (a * a + b * b + 1.0).sqrt();
            let xn = if a.is_finite() { a / n } else { f64::NAN };
            (*x, *y, *z) = (xn, b / n, 1.0 / n);
        }
    }

    fn distance(p: &Vector3<f64>) -> f64 {
        p.z
    }
}

/// [`crate::camera::CameraModel::project`] of a pinhole of intrinsics `k` ([`Perspective`]),
/// lane by lane: the pixels (u, v) of bearings (x, y, z), with the very operations of
/// `project` (the norm's sum of squares in order, the front test, the divisions, K), NaN u
/// where `project` rejects. Written as loops over lanes, without branches, so that it
/// vectorises.
#[inline(always)]
pub(crate) fn pinhole_lanes<const N: usize>(
    k: &Intrinsics,
    [x, y, z]: [[f64; N]; 3],
) -> [[f64; N]; 2] {
    let mut out = [[0.0; N]; 2];
    for i in 0..N {
        let norm = (x[i] * x[i] + y[i] * y[i] + z[i] * z[i]).sqrt();
        let front = z[i] > MIN_FORWARD * norm;
        let (u, v) = k.to_pixel(x[i] / z[i], y[i] / z[i]);
        out[0][i] = if front { u } else { f64::NAN };
        out[1][i] = v;
    }
    out
}

/// [`crate::camera::CameraModel::project_point`] of a pinhole of intrinsics `k`, lane by lane:
/// the points (x, y, z, any length) made unit bearings by its very operations (the norm, the
/// singular test, the divisions), then [`pinhole_lanes`]. NaN u where `project_point` rejects.
#[inline(always)]
pub(crate) fn pinhole_point_lanes<const N: usize>(
    k: &Intrinsics,
    [x, y, z]: [[f64; N]; 3],
) -> [[f64; N]; 2] {
    let mut unit = [[0.0; N]; 3];
    for i in 0..N {
        let n = (x[i] * x[i] + y[i] * y[i] + z[i] * z[i]).sqrt();
        let regular = n > 1e-12;
        unit[0][i] = x[i] / n;
        unit[1][i] = y[i] / n;
        unit[2][i] = if regular { z[i] / n } else { f64::NAN };
    }
    pinhole_lanes(k, unit)
}
