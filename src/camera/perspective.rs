//! Pinhole camera: (a, b) = (x/z, y/z); distance z.

use super::linear::{Linear, Mapping};
use super::{Projection, ProjectionReject};
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

    fn distance(p: &Vector3<f64>) -> f64 {
        p.z
    }
}
