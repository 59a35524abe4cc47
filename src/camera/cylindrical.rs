//! Cylindrical (Plaut et al.): (a, b) = (azimuth φ = atan2(x, z), h = y / rho) with the
//! cylindrical distance rho = sqrt(x² + z²), which plays the role z plays in a perspective
//! image. The cylinder axis is the camera's y axis; rays along it have no image.

use super::{CameraModel, ImageSize, Intrinsics, LinearCamera, Projection, ProjectionReject};
use nalgebra::{Point2, Vector3};

/// Rays within this angle-tangent of the axis (rho/|p|) are treated as on the axis.
const MIN_RHO: f64 = 1e-9;

#[derive(Debug, Clone, PartialEq)]
pub struct Cylindrical {
    pub k: Intrinsics,
    pub size: ImageSize,
}

impl Cylindrical {
    pub fn new(k: Intrinsics, size: ImageSize) -> Self {
        Self { k, size }
    }
}

impl CameraModel for Cylindrical {
    fn project(&self, bearing: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
        let (a, b) = self.bearing_to_ab(bearing)?;
        let (u, v) = self.k.to_pixel(a, b);
        Ok(Point2::new(u, v))
    }

    fn unproject(&self, pixel: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
        let (a, b) = self.k.from_pixel(pixel.x, pixel.y);
        self.ab_to_bearing(a, b)
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.x.hypot(p.z)
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn horizontal_period(&self) -> Option<f64> {
        Some(2.0 * std::f64::consts::PI * self.k.fu)
    }
}

impl LinearCamera for Cylindrical {
    fn projection(&self) -> Projection {
        Projection::Cylindrical
    }

    fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    fn bearing_to_ab(&self, d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        let rho = d.x.hypot(d.z);
        if !(rho > MIN_RHO * d.norm()) {
            return Err(ProjectionReject::Singular);
        }
        Ok((d.x.atan2(d.z), d.y / rho))
    }

    fn ab_to_bearing(&self, phi: f64, h: f64) -> Result<Vector3<f64>, ProjectionReject> {
        if !(phi.is_finite() && h.is_finite()) {
            return Err(ProjectionReject::OutsideDomain);
        }
        let (s, c) = phi.sin_cos();
        Ok(Vector3::new(s, h, c).normalize())
    }

    fn boxed_clone(&self) -> Box<dyn LinearCamera> {
        Box::new(self.clone())
    }
}
