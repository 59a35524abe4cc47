//! Cylindrical (Plaut et al.): (a, b) = (azimuth φ = atan2(x, z), h = y / rho) with the
//! cylindrical distance rho = sqrt(x² + z²), which plays the role z plays in a perspective
//! image. The cylinder axis is the camera's y axis; rays along it have no image.

use super::linear::{Linear, Mapping};
use super::separable::Share;
use super::{Projection, ProjectionReject};
use nalgebra::Vector3;

/// Rays within this angle-tangent of the axis (rho/|p|) are treated as on the axis.
const MIN_RHO: f64 = 1e-9;

/// The cylindrical (a, b) mapping; see the module documentation.
#[derive(Debug, PartialEq)]
pub struct CylindricalMapping;

/// A cylindrical camera: `CylindricalMapping` with K.
pub type Cylindrical = Linear<CylindricalMapping>;

impl Mapping for CylindricalMapping {
    const PROJECTION: Projection = Projection::Cylindrical;
    const PERIODIC: bool = true;
    const FRONT_ONLY: bool = false;

    #[inline]
    fn bearing_to_ab(d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        let rho = d.x.hypot(d.z);
        if !(rho > MIN_RHO * d.norm()) {
            return Err(ProjectionReject::Singular);
        }
        Ok((d.x.atan2(d.z), d.y / rho))
    }

    fn split_a(phi: f64) -> [f64; 2] {
        if !phi.is_finite() {
            return [f64::NAN; 2];
        }
        let (s, c) = phi.sin_cos();
        [s, c]
    }

    fn split_b(h: f64) -> [f64; 2] {
        [h, 0.0]
    }

    #[inline]
    fn join([s, c]: [f64; 2], [h, _]: [f64; 2]) -> Result<Vector3<f64>, ProjectionReject> {
        // the sine of a finite angle is never NaN: NaN marks an azimuth outside the domain
        if s.is_nan() || !h.is_finite() {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(Vector3::new(s, h, c).normalize())
    }

    #[inline]
    fn join_lanes(columns: &[Share], [h, _]: [f64; 2], [x, y, z]: [&mut [f64]; 3]) {
        if !h.is_finite() {
            for out in [x, y, z] {
                out.fill(f64::NAN);
            }
            return;
        }
        for (((col, x), y), z) in columns.iter().zip(x).zip(y).zip(z) {
            // `join`'s normalize, operation for operation: the sum of squares in order, its
            // root, each coordinate divided by it (a NaN sine, no azimuth, gives NaN)
            let [s, c] = col.0;
            let n = (s * s + h * h + c * c).sqrt();
            (*x, *y, *z) = (s / n, h / n, c / n);
        }
    }

    fn distance(p: &Vector3<f64>) -> f64 {
        p.x.hypot(p.z)
    }
}
