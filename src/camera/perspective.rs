//! Pinhole camera: (a, b) = (x/z, y/z); distance z.

use super::{CameraModel, ImageSize, Intrinsics, LinearCamera, Projection, ProjectionReject};
use nalgebra::{Point2, Vector3};

/// Rays closer than this to the image plane's horizon (z/|b| below it) have no image.
const MIN_FORWARD: f64 = 1e-9;

#[derive(Debug, Clone, PartialEq)]
pub struct Perspective {
    pub k: Intrinsics,
    pub size: ImageSize,
}

impl Perspective {
    pub fn new(k: Intrinsics, size: ImageSize) -> Self {
        Self { k, size }
    }
}

impl CameraModel for Perspective {
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
        p.z
    }

    fn size(&self) -> ImageSize {
        self.size
    }

    fn front_halfspace(&self) -> Option<Vector3<f64>> {
        Some(Vector3::z())
    }
}

impl LinearCamera for Perspective {
    fn projection(&self) -> Projection {
        Projection::Perspective
    }

    fn intrinsics(&self) -> Intrinsics {
        self.k
    }

    fn bearing_to_ab(&self, d: &Vector3<f64>) -> Result<(f64, f64), ProjectionReject> {
        if !(d.z > MIN_FORWARD * d.norm()) {
            return Err(ProjectionReject::BehindCamera);
        }
        Ok((d.x / d.z, d.y / d.z))
    }

    fn ab_to_bearing(&self, a: f64, b: f64) -> Result<Vector3<f64>, ProjectionReject> {
        if !(a.is_finite() && b.is_finite()) {
            return Err(ProjectionReject::OutsideDomain);
        }
        Ok(Vector3::new(a, b, 1.0).normalize())
    }

    fn boxed_clone(&self) -> Box<dyn LinearCamera> {
        Box::new(self.clone())
    }
}
