//! Equirectangular: (a, b) = (longitude λ = atan2(x, z), latitude φ = asin(y / |p|)); distance
//! is the range |p|. Latitude is positive downwards (y down). Pixels beyond a pole are outside
//! the domain (clamped, never wrapped); longitude is periodic.

use super::{CameraModel, ImageSize, Intrinsics, LinearCamera, Projection, ProjectionReject};
use nalgebra::{Point2, Vector3};
use std::f64::consts::FRAC_PI_2;

#[derive(Debug, Clone, PartialEq)]
pub struct Equirect {
    pub k: Intrinsics,
    pub size: ImageSize,
}

impl Equirect {
    pub fn new(k: Intrinsics, size: ImageSize) -> Self {
        Self { k, size }
    }
}

impl CameraModel for Equirect {
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
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn horizontal_period(&self) -> Option<f64> {
        Some(2.0 * std::f64::consts::PI * self.k.fu)
    }
}

impl LinearCamera for Equirect {
    fn projection(&self) -> Projection {
        Projection::Equirect
    }

    fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    fn bearing_to_ab(&self, d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        let n = d.norm();
        if !(n > 0.0) || !n.is_finite() {
            return Err(ProjectionReject::Singular);
        }
        let lat = (d.y / n).clamp(-1.0, 1.0).asin();
        Ok((d.x.atan2(d.z), lat))
    }

    fn ab_to_bearing(&self, lon: f64, lat: f64) -> Result<Vector3<f64>, ProjectionReject> {
        // A pole pixel computed in floating point may land a rounding error beyond π/2.
        if !(lon.is_finite() && lat.is_finite()) || lat.abs() > FRAC_PI_2 + 1e-12 {
            return Err(ProjectionReject::OutsideDomain);
        }
        let lat = lat.clamp(-FRAC_PI_2, FRAC_PI_2);
        let (sl, cl) = lat.sin_cos();
        let (so, co) = lon.sin_cos();
        Ok(Vector3::new(cl * so, sl, cl * co))
    }

    fn boxed_clone(&self) -> Box<dyn LinearCamera> {
        Box::new(self.clone())
    }
}
